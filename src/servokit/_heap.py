"""glibc heap settings for processes that churn through large numpy temporaries.

glibc serves an allocation above its mmap threshold (128 kB at start, raised
dynamically) with a fresh ``mmap`` and returns it with ``munmap`` when freed, so every
large temporary array is page-faulted in afresh (a kernel page fault and zeroing per
4 kB page).  Worker processes that allocate and free arrays of a few MB thousands of
times (a sweep's chunks, the reproduce cases) spend a measurable share of their time in
the kernel that way (issue 24: bench/sweep.py, bench/reproduce_cpu.py).
"""

from __future__ import annotations

from typing import Any

__all__ = ["keep_freed_arrays"]

#: ``mallopt`` parameters of glibc (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Allocations up to this many bytes come from the heap (reused) instead of fresh maps.
MMAP_THRESHOLD_BYTES = 32 << 20
#: Freed memory at the top of the heap kept for reuse before it is returned.
TRIM_THRESHOLD_BYTES = 64 << 20

#: Thresholds for a short-lived worker that ends with its job (a reproduce worker):
#: arrays up to 128 MB from the heap and 256 MB of freed memory kept.  Over the 25
#: reproduce cases: 64 000 page faults instead of 91 000-118 000, 0.6-0.9 s of system
#: time instead of 1.1-1.4 s, the same peak memory (428 MB).
WORKER_MMAP_THRESHOLD_BYTES = 128 << 20
WORKER_TRIM_THRESHOLD_BYTES = 256 << 20

#: None: not looked up in this process; False: no glibc ``mallopt``; else the function
#: (a failure is remembered too: the lookup of the C library can start a subprocess)
_MALLOPT: Any = None
#: the thresholds set in this process, or False if setting them failed
_TUNED: tuple[int, int] | bool | None = None


def keep_freed_arrays(
    mmap_threshold_bytes: int = MMAP_THRESHOLD_BYTES,
    trim_threshold_bytes: int = TRIM_THRESHOLD_BYTES,
) -> bool:
    """Let glibc keep freed array memory in this process for reuse.

    Sets glibc's mmap threshold (allocations up to it come from the heap, reused) and
    its trim threshold (freed memory kept at the top of the heap).  The setting is
    process-wide, is inherited by forked children, and only lets the process keep up to
    ``trim_threshold_bytes`` of freed memory; it changes no result.  Dask's nanny
    starts workers with ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes the mmap
    threshold at 128 kB: the call restores in-process speed there.  Elsewhere than
    glibc it does nothing.

    Parameters
    ----------
    mmap_threshold_bytes : int
        Largest allocation served from the heap (default 32 MB; a short-lived worker:
        :data:`WORKER_MMAP_THRESHOLD_BYTES`).
    trim_threshold_bytes : int
        Freed memory kept at the top of the heap before it is returned (default 64 MB).

    Returns
    -------
    bool
        True when the thresholds are set in this process (now or by an earlier call
        with the same values); a failed lookup of ``mallopt`` is remembered.
    """
    global _MALLOPT, _TUNED
    wanted = (int(mmap_threshold_bytes), int(trim_threshold_bytes))
    if _TUNED == wanted:
        return True
    if _MALLOPT is None:
        _MALLOPT = _find_mallopt()
    if _MALLOPT is False:
        _TUNED = False
        return False
    ok = bool(_MALLOPT(_M_MMAP_THRESHOLD, wanted[0]))
    ok = ok and bool(_MALLOPT(_M_TRIM_THRESHOLD, wanted[1]))
    _TUNED = wanted if ok else False
    return ok


def _find_mallopt() -> Any:
    """glibc's ``mallopt``, or False (no C library found, or not glibc)."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        mallopt = getattr(ctypes.CDLL(name), "mallopt", None) if name else None
    except OSError:
        return False
    return False if mallopt is None else mallopt
