"""Ctrl-C for the ``servokit`` command line: exit 130 within a second, one line.

The first SIGINT unwinds the run through ``KeyboardInterrupt`` (so staged output is
removed and the previous results stay); a watchdog ends the process if that takes
longer than :data:`INTERRUPT_GRACE_S`, or if Python swallowed the interrupt (raised
inside a weakref callback); worker processes (a local Dask cluster) ignore Ctrl-C and
are killed with the run.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

#: Exit status of an interrupted run (128 + SIGINT), as a shell reports Ctrl-C.
EXIT_INTERRUPTED = 130
#: Seconds an interrupted run may spend unwinding (closing a Dask cluster, removing a
#: staging directory) before the process is ended outright.
INTERRUPT_GRACE_S = 0.5
#: The process that installed the handler; forked workers inherit the handler, not the role.
_MAIN_PID = os.getpid()
_announced = threading.Lock()


def announce_interrupt() -> None:
    """Print the one interrupt line (once per process, whoever notices the interrupt first)
    and ignore further Ctrl-C so the unwinding is not cut short."""
    with contextlib.suppress(ValueError):  # not on the main thread: already ignored
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    if _announced.acquire(blocking=False):
        sys.stderr.write("servokit: interrupted\n")
        sys.stderr.flush()


def _kill_children() -> None:
    """SIGKILL the worker processes this process started (a local Dask cluster) and the
    multiprocessing resource tracker, so none outlives the run or prints after it."""
    import multiprocessing
    from multiprocessing import resource_tracker

    for child in multiprocessing.active_children():
        with contextlib.suppress(OSError, ValueError):
            child.kill()
    pid = getattr(getattr(resource_tracker, "_resource_tracker", None), "_pid", None)
    if pid:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _interrupted_exit() -> None:
    """End the process now as interrupted (no cleanup, no traceback)."""
    try:
        announce_interrupt()
        _kill_children()
        _remove_stages()
    finally:
        os._exit(EXIT_INTERRUPTED)


def _remove_stages() -> None:
    """Remove the staging directories of unfinished output (the previous results stay)."""
    import shutil

    from servokit._io import ACTIVE_STAGES

    for stage in list(ACTIVE_STAGES):
        shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def quiet_children() -> Iterator[None]:
    """Start worker processes (a local Dask cluster) that ignore Ctrl-C and log only errors.

    Ctrl-C in a terminal reaches the whole process group; the workers must leave the
    interrupt to this process (which closes them) instead of each printing a traceback.
    An ignored SIGINT is inherited by the children across ``exec``.
    """
    on_main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGINT) if on_main else None
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")
    try:
        import dask

        dask.config.refresh()
    except ImportError:
        pass
    if on_main:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        if on_main:
            signal.signal(signal.SIGINT, before)


def _on_sigint(signum: int, frame: Any) -> None:
    """First Ctrl-C: unwind through ``KeyboardInterrupt``; a watchdog ends the process if the
    unwinding (or a swallowed interrupt) takes longer than :data:`INTERRUPT_GRACE_S`."""
    if os.getpid() != _MAIN_PID:  # a forked worker (case runner pool): leave quietly
        os._exit(EXIT_INTERRUPTED)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut the cleanup
    timer = threading.Timer(INTERRUPT_GRACE_S, _interrupted_exit)
    timer.daemon = True
    timer.start()
    raise KeyboardInterrupt


def _unraisable(info: Any) -> None:
    """A ``KeyboardInterrupt`` raised inside a weakref callback or ``__del__`` is swallowed
    by Python (printed as "Exception ignored"); end the run as interrupted instead."""
    if isinstance(info.exc_value, KeyboardInterrupt):
        _interrupted_exit()
    sys.__unraisablehook__(info)


def install() -> None:
    """Install the SIGINT handler (main thread) and the unraisable-exception hook."""
    global _MAIN_PID
    _MAIN_PID = os.getpid()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _on_sigint)
    sys.unraisablehook = _unraisable


