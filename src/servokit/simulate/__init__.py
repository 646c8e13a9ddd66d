"""Hybrid sampled-data simulation, batched over plant variants, and seek/settling metrics."""

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
from servokit.simulate.saturation import Actuator, SaturatedResult, simulate_saturated
from servokit.simulate.search import NSearchResult, choose_N
from servokit.simulate.tdof import TdofResult, tdof_response

__all__ = [
    "Actuator",
    "SaturatedResult",
    "simulate_saturated",
    "PesResult",
    "track_following_pes",
    "HeldInput",
    "NSearchResult",
    "SimulationResult",
    "StepMetrics",
    "choose_N",
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
