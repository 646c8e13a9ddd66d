"""Start-up: parsing any command must not import the heavy libraries.

A correctness check, not a timing test (timings are in ``bench/startup.py``): the CLI's
module tree and the parsing of every command's arguments stay free of python-control,
matplotlib, scipy.signal and scipy.stats, which cost seconds to import; a command imports
them inside the function that needs them.
"""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("control", "matplotlib", "scipy.signal", "scipy.stats", "sklearn", "distributed")

_PROBE = r"""
import sys
import typer.main
import servokit.cli
servokit.cli._discover()
root = typer.main.get_command(servokit.cli.app)
for name, cmd in root.commands.items():
    subs = getattr(cmd, "commands", None) or {"": cmd}
    for sub_name, sub in subs.items():
        ctx = sub.make_context(sub_name or name, ["--help"], resilient_parsing=True)
        sub.get_help(ctx)
print(" ".join(m for m in %r if m in sys.modules))
"""


def test_parsing_every_command_imports_no_heavy_library() -> None:
    # a fresh interpreter: the test session itself has imported everything already
    out = subprocess.run(
        [sys.executable, "-c", _PROBE % (HEAVY,)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout.strip()
    assert out == "", f"imported while parsing the CLI: {out}"


#: Commands whose answer needs numpy only: they run for real and must stay light.
CHEAP = (
    ["plant", "list"],
    ["plant", "show", "hdd-benchmark", "--json"],
    ["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "3e-9"],
    ["limits", "waterbed", "--alpha-db", "-40", "--freq", "1000", "--dt", "4e-5"],
    ["filter", "notch", "--freq", "4449", "--damping", "0.09", "--dt", "1e-4", "--json"],
    ["filter", "notch", "--freq", "4449", "--damping", "0.09", "--filter-freq", "5000"],
    ["unobservable", "magnitude", "--freq", "4000", "--dt", "25e-6"],
    # a ModalPlant-only simulation and seek design (no python-control object anywhere)
    ["simulate", "--plant", "hdd-benchmark", "--dt", "1e-4", "--duration", "0.01", "--step", "1"],
    ["seek", "--target", "1", "--method", "fsc", "--n-samples", "26"],
    ["sweep", "--method", "fsc", "--target", "1", "--n-variants", "100"],
    ["filter", "peak", "--freq", "4449", "--damping", "0.015", "--gain", "0.1778", "--phi", "2.5"],
    ["filter", "lag", "--freq", "6900", "--damping", "0.1", "--phase", "1.1519", "--dt", "2e-5"],
    ["filter", "inverse", "--zero-freq", "4449", "--pole-freq", "4775"],
    # book controllers as numpy coefficients, the plant's exact ZOH as numpy arrays
    ["margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69"],
    ["margins", "--plant", "vcm-dual-stage", "--controller", "table-5.2", "--json"],
    # the multirate filters of eq. (4.67)-(4.68) as numpy coefficients (Tustin in numpy)
    ["sensitivity", "--plant", "hdd-sampled-data", "--controller", "eq-4.69", "--n-freq", "50"],
    # fixed-point export: coefficients, numpy partial fractions (python-control unloaded)
    "export controller --controller eq-4.69 --precision q15 --u-max 2 --out fw".split(),
    # the loop as numpy coefficients (servokit.limits.RationalLoop); variance adds quad
    ["limits", "bode-integral", "--num", "0.5,0.1", "--den", "1,-0.5,0.1", "--dt", "1e-4"],
    ["limits", "variance", "--num", "40000", "--den", "1,300,0", "--dist-num", "1",
     "--dist-den", "0.01,1"],
    ["feedforward", "minimum-jerk", "--move-time", "1", "--dt", "0.1"],
    # the bridges and the AMD loop evaluated with numpy (servokit.feedback.ssa *_response)
    ["ssa", "ddssa", "--c-pzt", "2e-9", "--c1", "2e-9", "--c2", "2e-9", "--c3", "2e-9"],
    ["ssa", "idssa", "--c", "1e-9", "--r", "10e3", "--k", "2"],
    ["ssa", "amd", "--mode", "5461:2:10", "--mode", "9103:2:10"],
)

_RUN = r"""
import sys
import servokit
import servokit.cli
codes = []
for argv in %r:
    sys.argv = ["servokit", *argv]
    try:
        servokit.cli.main()
    except SystemExit as exc:
        codes.append(exc.code)
print("\nRESULT", codes, " ".join(m for m in %r if m in sys.modules))
"""


def _run_light(commands, heavy: tuple[str, ...], cwd, what: str, timeout: float = 120) -> str:  # noqa: ANN001
    """Run ``commands`` one after another in one fresh interpreter (in ``cwd``: some write
    files); every one must exit 0 and none of ``heavy`` may be imported. Their stdout."""
    proc = subprocess.run(
        [sys.executable, "-c", _RUN % (commands, heavy)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=True,
    )
    codes, _, loaded = proc.stdout.rsplit("RESULT ", 1)[1].strip().partition("] ")
    assert codes.strip("[]") == ", ".join(["0"] * len(commands)), proc.stderr
    assert loaded.strip() == "", f"imported by {what}: {loaded}"
    return proc.stdout


def test_cheap_commands_run_without_heavy_libraries(tmp_path) -> None:  # noqa: ANN001
    out = _run_light(CHEAP, HEAVY, tmp_path, "a numpy-only command")
    assert '"num_z"' in out and "notch: num" in out


_IMPORT_ALL = r"""
import sys, warnings
import servokit
warnings.simplefilter("ignore")  # servokit.robust is a deprecated alias
for name in servokit.__all__:
    getattr(servokit, name)
heavy = %r + ("scipy.optimize", "scipy.integrate", "scipy.spatial", "qpsolvers", "dask")
print(" ".join(m for m in heavy if m in sys.modules))
"""


def test_importing_every_subpackage_imports_no_heavy_library() -> None:
    # library modules import python-control & co. on first use (servokit._lazy)
    out = subprocess.run(
        [sys.executable, "-c", _IMPORT_ALL % (HEAVY,)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout.strip()
    assert out == "", f"imported by `import servokit.<subpackage>`: {out}"


def test_lazy_module_loads_on_first_use_and_then_holds_the_namespace() -> None:
    from servokit._lazy import LazyModule

    lazy = LazyModule("colorsys")  # a small stdlib module this test can import freely
    assert "colorsys" in repr(lazy)
    assert lazy.rgb_to_hsv(1.0, 0.0, 0.0) == (0.0, 1.0, 1.0)
    assert "rgb_to_hsv" in vars(lazy)  # later look-ups skip __getattr__
    import colorsys

    assert lazy.hsv_to_rgb is colorsys.hsv_to_rgb


def test_lazy_exports_import_a_name_on_first_use() -> None:
    code = (
        "import sys, servokit.feedback as f\n"
        "assert 'servokit.feedback.margins' not in sys.modules\n"
        "assert 'stability_margins' in dir(f) and 'stability_margins' not in vars(f)\n"
        "g = f.stability_margins\n"
        "assert 'servokit.feedback.margins' in sys.modules and vars(f)['stability_margins'] is g\n"
        "try:\n    f.no_such_name\nexcept AttributeError as e:\n    print('ok', e)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    assert out.startswith("ok") and "no_such_name" in out


def _registered_names(source: str) -> set[str]:
    """Top-level command names a CLI module's source registers: ``sub_app("name", ...)``
    and ``@app.command("name", ...)`` (their first argument, a string literal)."""
    import ast

    names = set()
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Call) or not node.args:
            continue
        func = node.func
        first = node.args[0]
        is_sub = isinstance(func, ast.Name) and func.id == "sub_app"
        is_cmd = (
            isinstance(func, ast.Attribute)
            and func.attr == "command"
            and isinstance(func.value, ast.Name)
            and func.value.id == "app"
        )
        if (is_sub or is_cmd) and isinstance(first, ast.Constant):
            names.add(first.value)
    return names


def test_command_modules_table_matches_the_sources_and_the_tree() -> None:
    """``main`` imports only the module of the command run: the table must name, for
    every top-level command, the module that registers it (a new command missing from
    the table still works, through the import-everything path, but starts slower)."""
    from pathlib import Path

    import typer.main

    import servokit.cli
    from servokit.cli import COMMAND_MODULES

    package = Path(servokit.cli.__file__).parent
    found = {}
    for path in sorted(package.glob("[!_]*.py")):
        for name in _registered_names(path.read_text()):
            found[name] = path.stem
    assert found == COMMAND_MODULES
    servokit.cli._discover()
    tree = typer.main.get_command(servokit.cli.app)
    assert set(tree.commands) == set(COMMAND_MODULES)


def test_running_one_command_imports_only_its_module() -> None:
    code = (
        "import sys, servokit.cli\n"
        "sys.argv = ['servokit', 'limits', 'dynamic-range', '--stroke-m', '0.03',"
        " '--accuracy-m', '3e-9']\n"
        "try:\n    servokit.cli.main()\nexcept SystemExit as e:\n    assert e.code == 0\n"
        "print(sorted(m for m in sys.modules if m.startswith('servokit.cli.')"
        " and not m.rsplit('.', 1)[1].startswith('_')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    ).stdout
    assert out.strip().splitlines()[-1] == "['servokit.cli.limits']"


#: The switching commands and ``export ivc``: loops from numpy data (the plant's ZOH,
#: the controller's coefficients, the lead-lag and the book loops without python-control).
#: scipy.linalg (Lyapunov, balancing, expm) and, for the admissible set's LPs and the
#: §3.3.2 delay fit, scipy.optimize are still imported: the right tools, ~0.2 s each.
CHEAP_SWITCHING = (
    ["switching", "admissible-set", "--plant", "hdd-benchmark", "--controller", "lead-lag",
     "--freq", "500", "--dt", "3.7879e-5", "--u-max", "0.02", "--condition", "-16:3.9e4"],
    ["switching", "cost-map", "--plant", "hdd-benchmark", "--controller", "lead-lag",
     "--freq", "500", "--dt", "3.7879e-5", "--position", "-60", "--vel-range", "-1e5:1e5",
     "--acc-range", "-1e9:1e9"],
    ["switching", "ivc", "--plant", "hdd-sampled-data", "--controller", "eq-4.69",
     "--method", "jmin"],
    "export ivc --method pole-zero --precision q15 --format c".split(),
)


def test_switching_commands_run_without_heavy_libraries(tmp_path) -> None:  # noqa: ANN001
    out = _run_light(CHEAP_SWITCHING, HEAVY, tmp_path, "a switching command", timeout=300)
    assert "IVC admissible" in out and "IVC gain K" in out
    assert (tmp_path / "firmware" / "ivc.c").is_file()


#: Commands whose SciPy use was more than their computation needed (issue 23): the FSC
#: design takes each mode's ZOH in closed form and factorises with numpy.linalg, so a seek
#: design loads none of these SciPy subpackages (scipy.linalg alone costs 0.2-0.3 s).
CHEAP_SCIPY = (
    ["seek", "--target", "1", "--method", "fsc", "--n-samples", "26"],
    ["sweep", "--method", "fsc", "--tracks", "1", "--n-variants", "100"],
    "export feedforward --method fsc --target 10 --format c --out fw".split(),
)
SCIPY_SUBPACKAGES = ("scipy.linalg", "scipy.integrate", "scipy.optimize", "scipy.interpolate")


def test_fsc_commands_run_without_scipy_subpackages(tmp_path) -> None:  # noqa: ANN001
    _run_light(CHEAP_SCIPY, HEAVY + SCIPY_SUBPACKAGES, tmp_path, "an FSC design")
    assert (tmp_path / "fw" / "hdd_ff.c").is_file()


#: Commands that need SciPy's own algorithms (AAA and least squares, DOP853, QUADPACK):
#: their start line (``SERVOKIT_PROGRESS=1``) comes before the SciPy subpackage loads.
LATE_SCIPY = (
    (["fit", "FRF", "--out", "fitted", "--modes", "2"], "scipy.interpolate"),
    (["ssa", "adaptive", "--duration", "2e-4"], "scipy.integrate"),
    (["limits", "variance", "--num", "40000", "--den", "1,300,0", "--dist-num", "1",
      "--dist-den", "0.01,1"], "scipy.integrate"),
)  # fmt: skip

_ORDER = r"""
import importlib.abc, sys
class Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name == %r:
            print("IMPORT", name, file=sys.stderr, flush=True)
sys.meta_path.insert(0, Finder())
sys.argv = ["servokit", *%r]
import servokit.cli
servokit.cli.main()
"""


def test_scipy_commands_start_before_importing_scipy(tmp_path) -> None:  # noqa: ANN001
    import os
    from pathlib import Path

    frf = str(Path(__file__).resolve().parents[1] / "examples" / "data" / "stage_frf.csv")
    for argv, module in LATE_SCIPY:
        argv = [frf if a == "FRF" else a for a in argv]
        proc = subprocess.run(  # a fresh interpreter each: the import order is the point
            [sys.executable, "-c", _ORDER % (module, argv)],
            cwd=tmp_path,
            capture_output=True,
            text=True,
            timeout=120,
            env={**os.environ, "SERVOKIT_PROGRESS": "1"},
        )
        assert proc.returncode == 0, proc.stderr
        lines = proc.stderr.splitlines()
        start = next(i for i, line in enumerate(lines) if line.startswith(f"{argv[0]}"))
        assert f"IMPORT {module}" in lines[start + 1 :], proc.stderr  # loaded, after the line


#: Commands whose loops now run on numpy coefficients (issue 23: pes, dual-stage, identify
#: imported python-control for a controller or a filter); scipy.linalg is listed per command
#: where it is still honest (dual-stage: the plant zeros from the Rosenbrock pencil).
CHEAP_LOOPS = (
    (["pes", "--peak-filter", "960:0.08:12", "--n-revolutions", "20"], ("scipy.linalg",)),
    (["pes", "--json", "--n-revolutions", "20"], ("scipy.linalg",)),
    (["dual-stage", "--method", "inverse", "--json"], ()),
    (["dual-stage", "--method", "gain", "--structure", "cms"], ()),
    (
        "identify --plant vcm-dual-stage --controller table-5.2 --fmin 1000 --fmax 3000 "
        "--freq-step 1000".split(),
        ("scipy.linalg",),
    ),
)

#: ``report`` draws its figures (matplotlib is needed) but loads it after the start line,
#: and never loads python-control: the start line is recorded with what was imported then
_REPORT = r"""
import os, sys
os.environ["SERVOKIT_PROGRESS"] = "1"
seen = []
class Err:
    def write(self, text):
        if text.startswith("report:"):
            seen.append("matplotlib" in sys.modules)
        return sys.__stderr__.write(text)
    def flush(self):
        sys.__stderr__.flush()
    def isatty(self):
        return False
sys.stderr = Err()
import servokit.cli
sys.argv = ["servokit", "report", "--plant", "hdd-sampled-data", "--controller", "eq-4.69",
            "--out", "design"]
try:
    servokit.cli.main()
except SystemExit as exc:
    code = exc.code
print("\nRESULT", code, seen, " ".join(m for m in %r if m in sys.modules))
"""


def test_numpy_loop_commands_run_without_heavy_libraries(tmp_path) -> None:  # noqa: ANN001
    for argv, also in CHEAP_LOOPS:  # one interpreter each: their heavy lists differ
        _run_light([argv], HEAVY + ("scipy.optimize", *also), tmp_path, " ".join(argv), 300)
    proc = subprocess.run(
        [sys.executable, "-c", _REPORT % (("control", "scipy.signal", "scipy.stats"),)],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        check=True,
    )
    result = proc.stdout.rsplit("RESULT ", 1)[1].strip()
    assert result == "0 [False]", f"report: exit, matplotlib at the start line, heavy: {result}"
    assert (tmp_path / "design" / "report.html").stat().st_size > 10_000
