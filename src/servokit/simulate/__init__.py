"""Hybrid sampled-data simulation, batched over plant variants, and seek/settling metrics.

The simulator imports no design code.  ``choose_N`` and ``NSearchResult`` (the N search,
which designs inputs) moved to :mod:`servokit.seek`; the old names still resolve here with
a :class:`DeprecationWarning`.
"""

import warnings
from typing import Any

from servokit.simulate.hybrid import SimulationResult, iter_simulate, simulate, simulate_metrics
from servokit.simulate.metrics import (
    HeldInput,
    StepMetrics,
    seek_response,
    seek_time,
    settling_time,
    step_metrics,
)
from servokit.simulate.pes import PesResult, track_following_pes
from servokit.simulate.tdof import TdofResult, tdof_response

__all__ = [
    "PesResult",
    "track_following_pes",
    "HeldInput",
    "SimulationResult",
    "StepMetrics",
    "iter_simulate",
    "simulate_metrics",
    "TdofResult",
    "seek_response",
    "seek_time",
    "settling_time",
    "simulate",
    "step_metrics",
    "tdof_response",
]

#: names that moved to servokit.seek (they design inputs; the simulator imports no design)
_MOVED = {"choose_N", "NSearchResult"}


def __getattr__(name: str) -> Any:
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"servokit.simulate.{name} is deprecated; use servokit.seek.{name}",
        DeprecationWarning,
        stacklevel=2,
    )
    from servokit import seek

    return getattr(seek, name)
