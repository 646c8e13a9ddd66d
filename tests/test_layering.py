"""The package's layering, read from the source with ast (issue 19).

The import graph has one node per module of src/servokit and an edge for every
``import``/``from ... import`` in it: at module level *and* inside functions (lazy imports
still tie the layers together).  Two kinds of import are left out, each for a reason:

* imports under ``if TYPE_CHECKING:`` never run;
* imports inside a module-level ``__getattr__``: these are the deprecation/compat shims
  (``servokit.simulate.choose_N``, ``models.catalogue.get_plant``,
  ``feedforward.robust_minimum_time``...).  They run only when a user touches an old
  name, never while a module is imported, and they point from an old home to a new one
  by design; the test below lists them so a new one is a visible decision.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from functools import cache
from pathlib import Path

import servokit

ROOT = Path(servokit.__file__).resolve().parent
#: module-level __getattr__ forwards allowed to point upward (old name -> new home)
SHIM_MODULES = {
    "servokit.feedforward",
    "servokit.models.catalogue",
    "servokit.models.controllers",
    "servokit.simulate",
}
#: at most this many functions of more than 60 body lines outside cli/
MAX_LONG_FUNCTIONS = 10
LONG = 60


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@cache
def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in ROOT.rglob("*.py")}


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _resolve(module: str, is_package: bool, node: ast.ImportFrom | ast.Import) -> list[str]:
    """Module names an import statement loads (a ``from X import sub`` loads X.sub)."""
    known = _modules()
    if isinstance(node, ast.Import):
        return [a.name for a in node.names if a.name.startswith("servokit")]
    if node.level:
        base = module.split(".") if is_package else module.split(".")[:-1]
        base = base[: len(base) - (node.level - 1)]
        target = ".".join(base + ([node.module] if node.module else []))
    else:
        target = node.module or ""
    if not target.startswith("servokit"):
        return []
    out = [target]
    out += [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in known]
    return out


def _imports(module: str, path: Path) -> tuple[set[str], set[str]]:
    """(imports that count, imports inside module-level __getattr__ shims)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_package = path.name == "__init__.py"
    counted: set[str] = set()
    shims: set[str] = set()

    def walk(nodes: list[ast.stmt], sink: set[str]) -> None:
        for node in nodes:
            if isinstance(node, ast.If) and _is_type_checking(node):
                walk(node.orelse, sink)
                continue
            if isinstance(node, ast.FunctionDef) and node.name == "__getattr__" and sink is counted:
                walk(node.body, shims)
                continue
            if isinstance(node, ast.Import | ast.ImportFrom):
                sink.update(_resolve(module, is_package, node))
            for field in ("body", "orelse", "finalbody", "handlers"):
                child = getattr(node, field, None)
                if isinstance(child, list):
                    walk([c for c in child if isinstance(c, ast.stmt | ast.excepthandler)], sink)

    walk(tree.body, counted)
    return counted, shims


@cache
def _graph() -> tuple[dict[str, set[str]], dict[str, set[str]]]:
    graph: dict[str, set[str]] = {}
    shims: dict[str, set[str]] = {}
    for module, path in _modules().items():
        counted, shim = _imports(module, path)
        graph[module] = {m for m in counted if m in _modules() and m != module}
        if shim:
            shims[module] = shim
    return graph, shims


def _subpackage(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else module


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (depth-first search), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def _package_graph() -> dict[str, set[str]]:
    graph, _ = _graph()
    packages: dict[str, set[str]] = defaultdict(set)
    for module, targets in graph.items():
        src = _subpackage(module)
        packages[src] |= {_subpackage(t) for t in targets if _subpackage(t) != src}
    packages.pop("servokit", None)  # the root package only names its sub-packages
    for targets in packages.values():
        targets.discard("servokit")
    return dict(packages)


def test_the_graph_sees_imports_at_module_level_and_inside_functions() -> None:
    graph, shims = _graph()
    # cli/_options imports servokit.models lazily, inside load_plant
    assert any("servokit.models" in t for t in graph["servokit.cli._options"])
    # cli/seek imports servokit.seek lazily, inside a function
    assert "servokit.seek" in graph["servokit.cli.seek"]
    assert "servokit.seek" in shims["servokit.simulate"]


def test_no_import_cycle_between_subpackages() -> None:
    cycle = _cycle(_package_graph())
    assert cycle is None, "import cycle between sub-packages: " + " -> ".join(cycle or [])


def test_no_import_cycle_between_modules_outside_package_inits() -> None:
    # a sub-package's __init__ re-exports its modules, and a module importing its own
    # package's public names goes through that __init__: that is not a layering cycle
    graph, _ = _graph()
    packages = {m for m, p in _modules().items() if p.name == "__init__.py"}
    plain = {
        m: {t for t in ts if t not in packages} for m, ts in graph.items() if m not in packages
    }
    cycle = _cycle(plain)
    assert cycle is None, "import cycle between modules: " + " -> ".join(cycle or [])


def test_models_has_no_circle() -> None:
    graph, _ = _graph()
    models = {m: {t for t in ts if t.startswith("servokit.models.")}
              for m, ts in graph.items() if m.startswith("servokit.models.")}  # fmt: skip
    assert _cycle(models) is None
    # leaves: the numpy-only LTI data, and the python-control helpers built on it
    assert graph["servokit.models.rational"] <= {"servokit.errors"}
    assert graph["servokit.models.tf"] <= {
        "servokit.errors",
        "servokit._lazy",
        "servokit.models.rational",
    }


def test_only_cases_and_reproduce_import_cases() -> None:
    graph, shims = _graph()
    allowed = {"servokit.cli.reproduce"}
    offenders = sorted(
        m
        for m, ts in graph.items()
        if any(_subpackage(t) == "servokit.cases" for t in ts)
        and _subpackage(m) != "servokit.cases"
        and m not in allowed
    )
    assert not offenders, f"import servokit.cases outside cases/ and cli/reproduce: {offenders}"


def test_simulate_imports_no_design_code() -> None:
    graph, _ = _graph()
    design = ("servokit.feedforward", "servokit.seek", "servokit.robust")
    offenders = sorted(
        (m, t)
        for m, ts in graph.items()
        if _subpackage(m) == "servokit.simulate"
        for t in ts
        if _subpackage(t) in design
    )
    assert not offenders, offenders


def test_upward_shims_are_the_listed_deprecation_forwards() -> None:
    _, shims = _graph()
    assert set(shims) == SHIM_MODULES, set(shims) ^ SHIM_MODULES


def _body_lines(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines of the body after the docstring."""
    body = fn.body
    doc = (
        isinstance(body[0], ast.Expr)
        and isinstance(body[0].value, ast.Constant)
        and isinstance(body[0].value.value, str)
    )
    first = body[1] if doc and len(body) > 1 else body[0]
    return int(fn.end_lineno or first.lineno) - first.lineno + 1


def long_functions() -> list[tuple[int, str]]:
    """(body lines, name) of every function outside cli/ longer than 60 body lines."""
    out = []
    for module, path in _modules().items():
        if _subpackage(module) == "servokit.cli":
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                if (n := _body_lines(node)) > LONG:
                    out.append((n, f"{module}.{node.name}"))
    return sorted(out, reverse=True)


def test_body_line_counter() -> None:
    src = "def f():\n    '''doc\n    more'''\n    a = 1\n    return a\n"
    (fn,) = ast.parse(src).body
    assert _body_lines(fn) == 2  # type: ignore[arg-type]


def test_few_long_functions_outside_cli() -> None:
    found = long_functions()
    assert len(found) <= MAX_LONG_FUNCTIONS, found


def test_case_list_matches_the_registrations() -> None:
    from servokit.cases.registry import CASES, registry

    registered = registry()
    assert set(CASES) <= set(registered)
    for name, (_, module) in CASES.items():
        assert registered[name].__module__ == f"servokit.cases.{module}", name
