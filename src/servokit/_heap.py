"""glibc heap settings for processes that churn through large numpy temporaries.

glibc serves an allocation above its mmap threshold (128 kB at start, raised
dynamically) with a fresh ``mmap`` and returns it with ``munmap`` when freed, so every
large temporary array is page-faulted in afresh (a kernel page fault and zeroing per
4 kB page).  Worker processes that allocate and free arrays of a few MB thousands of
times (a sweep's chunks, the reproduce cases) spend a measurable share of their time in
the kernel that way (issue 24: bench/sweep.py, bench/reproduce_cpu.py).
"""

from __future__ import annotations

__all__ = ["keep_freed_arrays"]

#: ``mallopt`` parameters of glibc (malloc.h).
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: Allocations up to this many bytes come from the heap (reused) instead of fresh maps.
MMAP_THRESHOLD_BYTES = 32 << 20
#: Freed memory at the top of the heap kept for reuse before it is returned.
TRIM_THRESHOLD_BYTES = 64 << 20

#: None: not tried in this process; True/False: whether the thresholds are set (a
#: failure is remembered too: the lookup of the C library can start a subprocess)
_TUNED: bool | None = None


def keep_freed_arrays() -> bool:
    """Let glibc keep freed array memory in this process for reuse (once per process).

    Sets glibc's mmap threshold to 32 MB and its trim threshold to 64 MB.  The setting is
    process-wide, is inherited by forked children, and only lets the process keep up to
    64 MB of freed memory; it changes no result.  Dask's nanny starts workers with
    ``MALLOC_TRIM_THRESHOLD_=65536``, which also fixes the mmap threshold at 128 kB: the
    call restores in-process speed there.  Elsewhere than glibc it does nothing.

    Returns
    -------
    bool
        True when the thresholds are set in this process (now or by an earlier call);
        the answer of the first call is kept.
    """
    global _TUNED
    if _TUNED is None:
        _TUNED = _set_thresholds()
    return _TUNED


def _set_thresholds() -> bool:
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        mallopt = getattr(ctypes.CDLL(name), "mallopt", None) if name else None
    except OSError:
        return False
    if mallopt is None:  # not glibc
        return False
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(
        mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES)
    )
