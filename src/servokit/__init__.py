"""servokit: design and analysis of high-speed, high-precision motion control.

Sub-packages follow the book's design phases: :mod:`servokit.models`,
:mod:`servokit.simulate`, :mod:`servokit.feedforward`, :mod:`servokit.sampled`,
:mod:`servokit.cases`, :mod:`servokit.report`.
"""

from importlib import import_module
from typing import Any

__version__ = "0.1.0"
__all__ = [
    "models",
    "simulate",
    "feedforward",
    "feedback",
    "sampled",
    "cases",
    "report",
    "errors",
    "learn",
    "limits",
]


def __getattr__(name: str) -> Any:
    if name in __all__:
        return import_module(f"servokit.{name}")
    raise AttributeError(f"module 'servokit' has no attribute {name!r}")
