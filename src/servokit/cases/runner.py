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
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

from servokit.cases.registry import CASES, case_chapter, case_names, registry, run_all
from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from servokit.report import CaseResult

__all__ = ["default_workers", "iter_cases", "previous_runtimes", "run_cases", "select_cases"]


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
#: Net allocations between two young-generation collections in a case worker
#: (Python's default: 700).
WORKER_GC_THRESHOLD = 10_000


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
    """Worker initialiser: end with the parent (a killed ``reproduce`` leaves no worker);
    keep freed array memory for reuse, with the thresholds of a process that ends with
    the run (:data:`~servokit._heap.WORKER_MMAP_THRESHOLD_BYTES`): 64 000 page faults in
    the workers over the 25 cases instead of 91 000-118 000 with the default setting,
    and 0.3-0.5 s less system time)."""
    import ctypes
    import gc
    import signal

    from servokit._heap import (
        WORKER_MMAP_THRESHOLD_BYTES,
        WORKER_TRIM_THRESHOLD_BYTES,
        keep_freed_arrays,
    )

    try:
        ctypes.CDLL("libc.so.6").prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # not glibc: the worker ends after its case
        pass
    keep_freed_arrays(WORKER_MMAP_THRESHOLD_BYTES, WORKER_TRIM_THRESHOLD_BYTES)
    # young collections every 10 000 net allocations instead of 700: a figure's artists
    # mostly die young, before a collection walks them (with the collection and freeze
    # after each case, :func:`_run_group`: the collector's time over the 25 cases run
    # serially 0.32-0.41 s instead of 0.51-0.77 s, peak memory 433 MB instead of 447 MB)
    gc.set_threshold(WORKER_GC_THRESHOLD, *gc.get_threshold()[1:])


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
    """Cases of one module in one worker (a pool job): they share that module's caches.

    After each case the worker collects its garbage once and freezes what survives (the
    module caches, the registry): the collector's later full passes walk only the next
    case's objects, as :func:`_frozen_heap` keeps them off the parent's imports.
    """
    import gc

    done = []
    for name in names:
        done.append(_run_one(outdir, name, svg))
        gc.collect()
        gc.freeze()
    return done


def _groups(names: Sequence[str]) -> list[list[str]]:
    """``names`` grouped by case module, in the order of each group's first case.

    Cases of one module share its computed designs (``functools.lru_cache``), which a
    separate worker would compute again.
    """
    groups: dict[str, list[str]] = {}
    for name in names:
        groups.setdefault(CASES.get(name, (0, f"<{name}>"))[1], []).append(name)
    return list(groups.values())


def _longest_first(groups: list[list[str]], costs: Mapping[str, float]) -> list[list[str]]:
    """``groups`` by descending total cost (unknown costs count 0; ties keep their order).

    Handing the pool the longest jobs first keeps a long case from running alone at the
    end while the other workers idle (longest-processing-time-first list scheduling).
    """
    return sorted(groups, key=lambda g: -sum(costs.get(name, 0.0) for name in g))


def previous_runtimes(results_json: Path, max_bytes: int = 4 << 20) -> dict[str, float]:
    """Wall seconds per case of an earlier run's ``results.json`` (``{}`` if none usable).

    Only a hint for the order in which the pool takes the cases: a missing, irregular,
    oversized or malformed file gives ``{}`` (the run order), never an error.

    Parameters
    ----------
    results_json : Path
        ``results.json`` of an earlier ``servokit reproduce`` into the same ``--out``.
    max_bytes : int
        Larger files are not read.

    Returns
    -------
    dict of str to float
        Case name to its finite, non-negative ``runtime_s``.
    """
    import json
    import math
    import stat

    try:
        st = os.stat(results_json)
        if not stat.S_ISREG(st.st_mode) or st.st_size > max_bytes:
            return {}
        cases = json.loads(Path(results_json).read_bytes()).get("cases", [])
        pairs = ((c.get("name"), c.get("runtime_s")) for c in cases if isinstance(c, dict))
        # bool is an int to Python, a JSON true is no time; an integer of 400 digits
        # overflows float (OverflowError below)
        return {
            n: float(t)
            for n, t in pairs
            if isinstance(n, str) and type(t) in (int, float) and math.isfinite(t) and t >= 0
        }
    except (OSError, ValueError, AttributeError, TypeError, RecursionError, OverflowError):
        return {}


@contextmanager
def _frozen_heap() -> Iterator[None]:
    """The objects alive now left out of the garbage collector's scans while forking.

    A forked worker's full collections would otherwise walk every object of the parent's
    imports (numpy, scipy, python-control, matplotlib) again and again: about 0.5 s of
    the 1 s the collector takes over the cases (``gc.callbacks``, serial run).  This is
    the ``gc.freeze()`` before ``fork()`` of the :mod:`gc` documentation; the parent
    unfreezes once the workers exist.
    """
    import gc

    was_frozen = gc.get_freeze_count() > 0
    gc.freeze()
    try:
        yield
    finally:
        if not was_frozen:
            gc.unfreeze()


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def iter_cases(
    outdir: Path,
    names: Sequence[str],
    *,
    svg: bool = False,
    workers: int | None = None,
    costs: Mapping[str, float] | None = None,
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
    costs : mapping of str to float, optional
        Expected seconds per case (e.g. :func:`previous_runtimes`): the pool takes the
        longest first.  The yield order is ``names`` order whatever the costs.

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
    yield from _pooled(outdir, names, groups, svg, workers, costs or {})


def _pooled(
    outdir: Path,
    names: Sequence[str],
    groups: list[list[str]],
    svg: bool,
    workers: int,
    costs: Mapping[str, float],
) -> Iterator[tuple[str, list[CaseResult], float]]:
    """:func:`iter_cases` in a pool of forked workers (longest groups submitted first)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    done: dict[str, tuple[list[CaseResult], float]] = {}
    # one BLAS thread from before the case modules import (SciPy's OpenBLAS loads then and
    # reads the variable): threads started by a BLAS call at import spin idle for a while
    # afterwards (0.35-0.4 s of the parent's CPU); inherited by the forked workers
    with one_blas_thread():
        import matplotlib.pyplot  # noqa: F401  (imported once here, inherited by the workers)

        # every case module (and numpy, scipy, python-control) imported before the fork:
        # the workers inherit the imports and the registry (cases registered at run time
        # included)
        registry()
        ctx = multiprocessing.get_context("fork")
        with ProcessPoolExecutor(
            min(workers, len(groups)), mp_context=ctx, initializer=_init_worker
        ) as pool:
            with _frozen_heap():  # the workers fork at the first submit
                order = _longest_first(groups, costs)
                futures = {pool.submit(_run_group, outdir, g, svg): g for g in order}
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
