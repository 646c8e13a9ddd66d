"""The ``servokit`` command line.

Every module in this package registers its sub-commands on the shared typer
``app`` of :mod:`servokit.cli._app`. :func:`main` imports only the module of the command
being run (:data:`COMMAND_MODULES`): importing all of them and building the whole
command tree cost 0.2-0.3 s of every run (typer builds a pydantic adapter per
parameter); the root help and unknown names import them all.
"""

from __future__ import annotations

import importlib
import os
import pkgutil
import sys
from collections.abc import Sequence


def _one_blas_thread_for_reproduce(argv: Sequence[str]) -> None:
    """``servokit reproduce`` runs every case on one BLAS thread: say so before numpy and
    SciPy load their OpenBLAS, whose threads otherwise start and spin idle for a while
    (0.1-0.2 s of CPU per library, 0.35-0.4 s of the parent of a reproduce run).  Only
    in a fresh process (numpy not loaded) and never over the user's own setting."""
    words = [a for a in argv[1:] if not a.startswith("-")]
    if words[:1] == ["reproduce"] and "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


_one_blas_thread_for_reproduce(sys.argv)

from servokit.cli._app import app, main  # noqa: E402  (after the BLAS setting)

__all__ = ["COMMAND_MODULES", "app", "main"]

#: The module of this package that registers each top-level command (checked against
#: the modules' sources by ``tests/test_cli_startup.py``).
COMMAND_MODULES: dict[str, str] = {
    "dual-stage": "dual_stage", "export": "export", "feedforward": "feedforward",
    "filter": "resonance", "fit": "fit", "identify": "identify", "limits": "limits",
    "loopshape": "loopshape", "margins": "resonance", "pes": "pes", "plant": "plant",
    "report": "report", "reproduce": "reproduce", "seek": "seek",
    "sensitivity": "sensitivity", "settle": "settle", "simulate": "simulate", "srs": "srs",
    "ssa": "ssa", "sweep": "sweep", "switching": "switching",
    "unobservable": "unobservable",
}  # fmt: skip


def _discover(argv: Sequence[str] | None = None) -> None:
    """Import the command modules: all of them, or only the one ``argv`` runs.

    Parameters
    ----------
    argv : sequence of str, optional
        The command line after the program name; when its first word is a known
        command, only that command's module is imported (its tree is all that is built).
    """
    name = argv[0] if argv else None
    if name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{COMMAND_MODULES[name]}")
        return
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
