"""Writing the report files of ``servokit reproduce --out DIR``: rendering only.

:func:`write_report` writes ``results.json`` (with its schema beside it) and
``report.html`` atomically from the
:class:`~servokit.report.CaseResult` rows it is given (running the cases is
:mod:`servokit.cases.runner`'s job).  :func:`clear_report` removes the report files of an
earlier run first: the figures are overwritten as the cases run, so an old page beside
new figures would mix two runs, and a run killed half-way must leave no page a reader
could take for a complete one.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from servokit.report import CaseResult

__all__ = ["REPORT_FILES", "clear_report", "write_report"]

#: The files ``write_report`` produces, in writing order (the page last).
REPORT_FILES = ("results.schema.json", "results.json", "report.html")


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
