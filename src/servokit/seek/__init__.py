"""A seek over a plant set: N search, robust minimum-time design, sweeps at scale.

This layer sits above :mod:`servokit.feedforward` (the designs) and
:mod:`servokit.simulate` (the engine): it evaluates designs by simulation.

* :func:`choose_N` — the step number N minimising the worst-case seek time (§2.4.2);
* :func:`robust_minimum_time` — the shortest worst-case seek guaranteed on a plant set
  under input, slew and §2.6 limits, as linear programs (:mod:`.robust`);
* :func:`sweep_seek_times` — seek-time distributions over 10^4-10^5 Monte-Carlo plants
  in bounded memory, in-process or on Dask (:mod:`.sweep`).
"""

from servokit.seek.robust import (
    NoFeasibleSeekError,
    RobustFeedforwardInput,
    robust_minimum_time,
)
from servokit.seek.search import NSearchResult, choose_N
from servokit.seek.sweep import (
    SweepResult,
    chunk_bytes,
    connect_dask,
    plan_chunks,
    sweep_seek_times,
)

__all__ = [
    "NSearchResult",
    "NoFeasibleSeekError",
    "RobustFeedforwardInput",
    "SweepResult",
    "choose_N",
    "chunk_bytes",
    "connect_dask",
    "plan_chunks",
    "robust_minimum_time",
    "sweep_seek_times",
]
