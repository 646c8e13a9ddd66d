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
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from servokit.cases.registry import CASES, case_chapter, case_names, registry, run_all
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
    return max(1, min(_cores(), 4))


#: Variables read by BLAS/OpenMP libraries loaded after the limit is set (in a worker).
_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """Run the cases with one BLAS thread per process (the parallelism is across cases).

    The cases' linear algebra is on small matrices (14-30 states: exact ZOH by Pade
    ``expm``, batched 14 x 14 solves, closed-loop eigenvalues), where OpenBLAS threads
    spin for work instead of doing it: on the 2-core machine of issue 24 one
    ``delayed_zoh`` costs 10 ms of CPU with two threads and 0.09 ms with one.
    """
    from threadpoolctl import threadpool_limits

    saved = {k: os.environ.get(k) for k in _THREAD_VARS}
    os.environ.update(dict.fromkeys(_THREAD_VARS, "1"))  # for libraries loaded later
    try:
        with threadpool_limits(limits=1):
            yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def skip_missing_slycot() -> None:
    """Make python-control's repeated ``import slycot`` fail at once when it is absent.

    python-control tries ``from slycot import ...`` on every state-space evaluation
    (``StateSpace.__call__`` -> ``slycot_laub``) and falls back to numpy on ImportError;
    without slycot each attempt searches ``sys.path`` again (60 % of a one-point
    evaluation, 10^4 of them in the ``limits`` case).  A ``None`` entry in
    ``sys.modules`` raises the same ImportError without the search.
    """
    import importlib.util
    import sys

    if "slycot" not in sys.modules and importlib.util.find_spec("slycot") is None:
        sys.modules["slycot"] = None  # type: ignore[assignment]


def _init_worker() -> None:
    """Worker initialiser: end with the parent (a killed ``reproduce`` leaves no worker)."""
    import ctypes
    import signal

    try:
        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not glibc: the worker ends after its case
        pass


def _run_one(outdir: Path, name: str, svg: bool) -> tuple[list[CaseResult], float]:
    """One case with its figure formats; results and seconds."""
    from servokit._figures import also_save_as

    start = time.perf_counter()
    with also_save_as(*(("svg",) if svg else ())):
        done = run_all(outdir, only=[name])
    return done, time.perf_counter() - start


def _run_group(
    outdir: Path, names: Sequence[str], svg: bool
) -> list[tuple[list[CaseResult], float]]:
    """Cases of one module in one worker (a pool job): they share that module's caches."""
    return [_run_one(outdir, name, svg) for name in names]


def _groups(names: Sequence[str]) -> list[list[str]]:
    """``names`` grouped by case module, in the order of each group's first case.

    Cases of one module share its computed designs (``functools.lru_cache``), which a
    separate worker would compute again.  The order is kept (``hdd-loopshape`` last):
    its "design time" row is a wall time, measured best while the other cases are done.
    """
    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(CASES.get(name, (0, f"<{name}>"))[1], []).append(name)
    return list(groups.values())


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def iter_cases(
    outdir: Path, names: Sequence[str], *, svg: bool = False, workers: int | None = None
) -> Iterator[tuple[str, list[CaseResult], float]]:
    """Run ``names``, yielding ``(name, results, seconds)`` in ``names`` order.

    With ``workers > 1`` the cases run in a pool of forked processes (each case writes
    only its own figures, so they do not interfere), the cases of one module in one
    worker; results come back in run order so that ``results.json`` does not depend on
    which case finished first.  The case modules are imported before the fork, once for
    every worker.

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
    groups = _groups(names)
    skip_missing_slycot()
    if workers <= 1 or len(groups) <= 1:
        for name in names:
            with one_blas_thread():
                done = _run_one(outdir, name, svg)
            yield (name, *done)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    import matplotlib.pyplot  # noqa: F401  (imported once here, inherited by the workers)

    registry()  # imports every case module (and numpy, scipy, python-control) before the fork
    # fork: the workers inherit the imports and the case registry (cases registered at run
    # time included)
    ctx = multiprocessing.get_context("fork")
    done: dict[str, tuple[list[CaseResult], float]] = {}
    with (
        one_blas_thread(),  # inherited by the forked workers
        ProcessPoolExecutor(
            min(workers, len(groups)), mp_context=ctx, initializer=_init_worker
        ) as pool,
    ):
        futures = {pool.submit(_run_group, outdir, g, svg): g for g in groups}
        owner = {name: fut for fut, g in futures.items() for name in g}
        for name in names:
            fut = owner[name]
            if name not in done:
                done.update(zip(futures[fut], fut.result(), strict=True))
            yield (name, *done.pop(name))


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
