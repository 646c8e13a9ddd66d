"""servokit: design and analysis of high-speed, high-precision motion control.

Sub-packages follow the book's design phases (each is imported on first use, e.g.
``servokit.seek``):

* :mod:`servokit.models` — modal plants with delay, exact discretisation, variation sets,
  the catalogue, the book's controllers, plant/controller files;
* :mod:`servokit.simulate` — the hybrid sampled-data simulator and seek/settling metrics;
* :mod:`servokit.feedforward` — phases 1-2: polynomials, FSC, FFSC, constrained FSC;
* :mod:`servokit.seek` — a seek over a plant set: one request and ``design_seek``, the
  N search, the robust minimum-time LP, Monte-Carlo sweeps;
* :mod:`servokit.switching` — phase 3: mode switching, IVC, admissible sets;
* :mod:`servokit.feedback` — phase 4: filters, peak filters, margins, dual-stage, SSA;
* :mod:`servokit.sampled` — sampled-data sensitivity, multirate, unobservable
  oscillations, SRS, identification;
* :mod:`servokit.limits` — Bode integrals, waterbed, variance bounds;
* :mod:`servokit.learn` — SVM settling judgement;
* :mod:`servokit.export` — firmware tables and step functions;
* :mod:`servokit.report` — results.json and report.html from case rows;
* :mod:`servokit.cases` — the book's case studies (run by ``servokit reproduce``);
* :mod:`servokit.cli` — the ``servokit`` command;
* :mod:`servokit.errors` — the error types and argument checks;
* :mod:`servokit.robust` — deprecated alias of :mod:`servokit.seek`.
"""

import signal as _signal
import sys as _sys


def _interrupted_while_starting(*_: object) -> None:
    """Ctrl-C while the ``servokit`` command is still importing (before its own handling is
    installed): the one interrupt line and exit 130, not a ``KeyboardInterrupt`` traceback."""
    import os

    os.write(2, b"servokit: interrupted\n")
    os._exit(130)


# only for the `servokit` command itself (a library user's Ctrl-C stays theirs); the
# command's main() replaces it with the full handling (servokit.cli._signals)
if _sys.argv and _sys.argv[0].rsplit("/", 1)[-1] == "servokit":
    if _signal.getsignal(_signal.SIGINT) is _signal.default_int_handler:
        _signal.signal(_signal.SIGINT, _interrupted_while_starting)

from importlib import import_module  # noqa: E402
from typing import Any  # noqa: E402

__version__ = "0.1.0"
__all__ = [
    "models",
    "simulate",
    "feedforward",
    "seek",
    "switching",
    "feedback",
    "sampled",
    "limits",
    "learn",
    "export",
    "report",
    "cases",
    "cli",
    "errors",
    "robust",
]


def __getattr__(name: str) -> Any:
    if name in __all__:
        return import_module(f"servokit.{name}")
    raise AttributeError(f"module 'servokit' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
