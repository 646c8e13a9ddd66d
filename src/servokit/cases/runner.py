"""Running the cases for ``servokit reproduce --out DIR``.

:func:`select_cases` picks the cases (from the explicit list of
:mod:`servokit.cases.registry`, no case imported); :func:`run_cases` runs them (timing
each, advancing a progress callback), in parallel processes when there are several
cores (:func:`iter_cases`, issue 24), with every figure as PNG (and SVG on request);
:func:`servokit.report.files.write_report` then renders the rows it is given.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from servokit.cases.registry import case_chapter, case_names, run_all
from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from servokit.report import CaseResult

__all__ = ["default_workers", "iter_cases", "run_cases", "select_cases"]


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


def default_workers() -> int:
    """Processes for the cases: the cores this process may use, at most 4.

    Returns
    -------
    int
        ``>= 1``.
    """
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, 4))


def _die_with_parent() -> None:
    """Worker initialiser: end with the parent (a killed ``reproduce`` leaves no worker)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not glibc: the worker ends after its case
        pass


def _run_one(outdir: Path, name: str, svg: bool) -> tuple[list[CaseResult], float]:
    """One case with its figure formats (a worker process's job); results and seconds."""
    from servokit._figures import also_save_as

    start = time.perf_counter()
    with also_save_as(*(("svg",) if svg else ())):
        done = run_all(outdir, only=[name])
    return done, time.perf_counter() - start


def iter_cases(
    outdir: Path, names: Sequence[str], *, svg: bool = False, workers: int | None = None
) -> Iterator[tuple[str, list[CaseResult], float]]:
    """Run ``names``, yielding ``(name, results, seconds)`` in ``names`` order.

    With ``workers > 1`` the cases run in a pool of forked processes (each case writes
    only its own figures, so they do not interfere); results come back in run order so
    that ``results.json`` does not depend on which case finished first.

    Parameters
    ----------
    outdir : Path
        Figure directory (created).
    names : sequence of str
        Registered case names, from :func:`select_cases`.
    svg : bool
        Also save every figure as SVG beside its PNG.
    workers : int, optional
        Processes; default :func:`default_workers`.  1 runs in this process.

    Yields
    ------
    tuple of (str, list of CaseResult, float)
        Case name, its results and its wall-clock seconds.
    """
    Path(outdir).mkdir(parents=True, exist_ok=True)
    workers = default_workers() if workers is None else int(workers)
    if workers <= 1 or len(names) <= 1:
        for name in names:
            yield (name, *_run_one(outdir, name, svg))
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    # fork: the workers inherit the case registry (including cases registered at run time)
    ctx = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_die_with_parent) as pool:
        futures = [pool.submit(_run_one, outdir, name, svg) for name in names]
        for name, fut in zip(names, futures, strict=True):
            yield (name, *fut.result())


def run_cases(
    outdir: Path,
    names: Sequence[str],
    *,
    advance: Callable[[], object] = lambda: None,
    svg: bool = False,
    workers: int | None = 1,
) -> tuple[list[CaseResult], dict[str, float]]:
    """Run ``names`` writing figures to ``outdir``; return the results and runtimes [s].

    Parameters
    ----------
    outdir, names, svg
        As for :func:`iter_cases` (PNG only by default).
    advance : callable, optional
        Called after each case (a progress bar).
    workers : int, optional
        Processes (see :func:`iter_cases`); ``None``: one per core.

    Returns
    -------
    results : list of CaseResult
        One per name.
    runtimes : dict
        Wall-clock seconds per case name.
    """
    results: list[CaseResult] = []
    runtimes: dict[str, float] = {}
    for name, done, seconds in iter_cases(outdir, names, svg=svg, workers=workers):
        results += done
        runtimes[name] = seconds
        advance()
    return results, runtimes
