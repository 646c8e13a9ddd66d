"""Running the cases for ``servokit reproduce --out DIR`` and writing the report files.

:func:`run_cases` runs the selected cases one by one (timing each, advancing a progress
callback) with every figure also saved as SVG; :func:`write_report` then writes
``results.json`` (with its schema beside it) and ``report.html`` atomically.
:func:`clear_report` removes the report files of an earlier run first: the figures are
overwritten as the cases run, so an old page beside new figures would mix two runs, and
a run killed half-way must leave no page a reader could take for a complete one.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from servokit.report import CaseResult

__all__ = ["REPORT_FILES", "clear_report", "run_cases", "select_cases", "write_report"]

#: The files ``write_report`` produces, in writing order (the page last).
REPORT_FILES = ("results.schema.json", "results.json", "report.html")


def select_cases(names: Sequence[str] | None, chapters: Sequence[int] | None) -> list[str]:
    """Names of the registered cases to run, in run order.

    Parameters
    ----------
    names : sequence of str, optional
        Case names (``--case``); all when empty.
    chapters : sequence of int, optional
        Keep only the cases of these book chapters (``--chapter``).

    Returns
    -------
    list of str
        Case names; unknown names raise a ``ServokitValueError`` naming ``--case``.
    """
    from servokit.cases import case_chapter, registry
    from servokit.errors import ServokitValueError

    known = list(registry())
    chosen = list(names) if names else known
    unknown = [n for n in chosen if n not in known]
    if unknown:
        raise ServokitValueError(
            f"--case {unknown[0]!r} is unknown; choose one of {', '.join(known)}"
        )
    if chapters:
        chosen = [n for n in chosen if case_chapter(n) in set(chapters)]
        if not chosen:
            raise ServokitValueError(
                f"--chapter {', '.join(map(str, chapters))} selects no case; "
                "give a chapter 2-6 that has cases"
            )
    return chosen


def run_cases(
    outdir: Path,
    names: Sequence[str],
    *,
    advance: Callable[[], object] = lambda: None,
    svg: bool = True,
) -> tuple[list[CaseResult], dict[str, float]]:
    """Run ``names`` writing figures to ``outdir``; return the results and runtimes [s].

    Parameters
    ----------
    outdir : Path
        Figure directory (created).
    names : sequence of str
        Registered case names, from :func:`select_cases`.
    advance : callable, optional
        Called after each case (a progress bar).
    svg : bool
        Also save every figure as SVG beside its PNG.

    Returns
    -------
    results : list of CaseResult
        One per name.
    runtimes : dict
        Wall-clock seconds per case name.
    """
    from servokit._figures import also_save_as
    from servokit.cases import run_all

    results: list[CaseResult] = []
    runtimes: dict[str, float] = {}
    with also_save_as(*(("svg",) if svg else ())):
        for name in names:
            start = time.perf_counter()
            results += run_all(outdir, only=[name])
            runtimes[name] = time.perf_counter() - start
            advance()
    return results, runtimes


def clear_report(outdir: Path) -> None:
    """Remove the report files of an earlier run from ``outdir`` (figures stay).

    Parameters
    ----------
    outdir : Path
        The report directory.
    """
    for name in reversed(REPORT_FILES):
        (Path(outdir) / name).unlink(missing_ok=True)


def write_report(
    results: Sequence[CaseResult], outdir: Path, runtimes_s: dict[str, float] | None = None
) -> tuple[Path, Path]:
    """Write ``results.json`` and ``report.html`` into ``outdir``, each atomically.

    Parameters
    ----------
    results : sequence of CaseResult
        The cases that ran.
    outdir : Path
        Report directory (holds the figures).
    runtimes_s : dict, optional
        Runtime [s] per case name.

    Returns
    -------
    tuple of Path
        ``(results.json, report.html)``; the schema ``results.json`` names in its
        ``$schema`` is written beside them.
    """
    import json

    from servokit.report.html import render_html
    from servokit.report.results import (
        load_schema,
        results_document,
        write_atomic,
        write_results,
    )

    outdir = Path(outdir)
    doc = results_document(results, outdir=outdir, runtimes_s=runtimes_s)
    write_atomic(outdir / REPORT_FILES[0], json.dumps(load_schema(), indent=2) + "\n")
    json_path = write_results(doc, outdir / REPORT_FILES[1])
    html_path = write_atomic(outdir / REPORT_FILES[2], render_html(doc, outdir))
    return json_path, html_path
