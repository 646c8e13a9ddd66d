"""Every public function has numpydoc Parameters / Returns sections (the API docs need them).

A function in a public module's ``__all__`` (modules and packages whose names do not
start with ``_``; the CLI's typer commands are help text, not API, and are skipped) must
document its parameters in a ``Parameters`` section when it takes any, and its result
in a ``Returns`` (or ``Yields``) section unless annotated ``-> None``.

Functions that predate this rule are listed in ``docstring_baseline.txt``; the list may
only shrink.  The report and export packages have no exceptions.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import warnings
from collections.abc import Callable, Iterator
from functools import cache
from pathlib import Path

import pytest
from numpydoc.docscrape import FunctionDoc

import servokit

BASELINE = Path(__file__).with_name("docstring_baseline.txt")
STRICT = ("servokit.report", "servokit.export")


def missing_sections(fn: Callable) -> list[str]:
    """Names of the numpydoc sections ``fn`` lacks."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        doc = FunctionDoc(fn)
    sig = inspect.signature(fn)
    params = [p for p in sig.parameters.values() if p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
    missing = []
    if params and not doc["Parameters"]:
        missing.append("Parameters")
    returns = sig.return_annotation not in (None, "None", inspect.Signature.empty)
    if returns and not (doc["Returns"] or doc["Yields"]):
        missing.append("Returns")
    return missing


def public_functions() -> Iterator[tuple[str, Callable]]:
    for info in pkgutil.walk_packages(servokit.__path__, "servokit."):
        parts = info.name.split(".")
        if parts[1] == "cli" or any(p.startswith("_") for p in parts[1:]):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name, None)
            if inspect.isfunction(obj) and obj.__module__ == module.__name__:
                yield f"{module.__name__}.{name}", obj


@cache
def _gaps() -> dict[str, list[str]]:
    return {name: m for name, fn in public_functions() if (m := missing_sections(fn))}


def test_checker_catches_a_bare_function() -> None:
    def documented(x: float) -> float:
        """Double.

        Parameters
        ----------
        x : float
            Input.

        Returns
        -------
        float
            ``2 x``.
        """
        return 2 * x

    def bare(x: float) -> float:
        """Double ``x``."""
        return 2 * x

    assert missing_sections(documented) == []
    assert missing_sections(bare) == ["Parameters", "Returns"]


def test_report_and_export_fully_documented() -> None:
    gaps = {k: v for k, v in _gaps().items() if k.startswith(STRICT)}
    assert not gaps, f"add numpydoc sections: {gaps}"


def test_no_new_undocumented_public_function() -> None:
    lines = BASELINE.read_text().splitlines()
    allowed = {line.strip() for line in lines if line.strip() and not line.startswith("#")}
    new = {k: v for k, v in _gaps().items() if k not in allowed}
    assert not new, (
        f"public functions without numpydoc Parameters/Returns: {new}; add the sections "
        "(see numpydoc's format)"
    )


@pytest.mark.slow
def test_sphinx_builds_the_api_docs(tmp_path: Path) -> None:
    from sphinx.cmd.build import build_main

    docs = Path(__file__).resolve().parents[1] / "docs"
    assert build_main(["-q", "-b", "html", "-d", str(tmp_path / "doctrees"), str(docs),
                       str(tmp_path / "html")]) == 0  # fmt: skip
    page = (tmp_path / "html" / "reference" / "generated" / "servokit.export.html").read_text()
    assert "write_export" in page
