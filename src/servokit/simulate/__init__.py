"""Hybrid sampled-data simulation, batched over plant variants, and seek/settling metrics."""

from servokit.simulate.hybrid import SimulationResult, simulate
from servokit.simulate.metrics import (
    HeldInput,
    StepMetrics,
    seek_response,
    seek_time,
    settling_time,
    step_metrics,
)

__all__ = [
    "HeldInput",
    "SimulationResult",
    "StepMetrics",
    "seek_response",
    "seek_time",
    "settling_time",
    "simulate",
    "step_metrics",
]
