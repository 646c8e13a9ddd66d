"""Running the cases for ``servokit reproduce --out DIR``.

:func:`select_cases` picks the cases (from the explicit list of
:mod:`servokit.cases.registry`, no case imported); :func:`run_cases` runs them one by one
(timing each, advancing a progress callback) with every figure also saved as SVG;
:func:`servokit.report.files.write_report` then renders the rows it is given.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from servokit.cases.registry import case_chapter, case_names, run_all
from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from servokit.report import CaseResult

__all__ = ["run_cases", "select_cases"]


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
    known = case_names()
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

    results: list[CaseResult] = []
    runtimes: dict[str, float] = {}
    with also_save_as(*(("svg",) if svg else ())):
        for name in names:
            start = time.perf_counter()
            results += run_all(outdir, only=[name])
            runtimes[name] = time.perf_counter() - start
            advance()
    return results, runtimes
