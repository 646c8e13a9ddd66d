"""A seek over a plant set: one design entry point, N search, robust LP, sweeps at scale.

This layer sits above :mod:`servokit.feedforward` (the designs) and
:mod:`servokit.simulate` (the engine): it evaluates designs by simulation.

* :class:`SeekRequest` and :func:`design_seek` — one checked request and one design
  (FSC, FFSC or robust, fixed or automatic N) used by the CLI, the sweeps and the export;
  :func:`run_seek` designs and simulates the seek over the request's plants;
* :func:`simulate_seek` and :func:`seek_plot` — the outcome over the plant set and its figure;
* :func:`table_2_4_weights`, :data:`DESIGNS` — the HDD benchmark designs of §2.4.2;
* :func:`choose_N` — the step number N minimising the worst-case seek time (§2.4.2);
* :func:`robust_minimum_time` — the shortest worst-case seek guaranteed on a plant set
  under input, slew and §2.6 limits, as linear programs (:mod:`.robust`);
* :func:`sweep_seek_times` — seek-time distributions over 10^4-10^5 Monte-Carlo plants
  in bounded memory, in-process or on Dask (:mod:`.sweep`);
* :func:`robust_seek_over_box` — the robust seek whose worst case is validated inside a
  variation box (Monte-Carlo and adversarial search, redesign until they agree;
  :mod:`.validated`).
"""

from servokit.seek.hdd import DESIGNS, SeekDesign, search_range, table_2_4_weights
from servokit.seek.outcome import SeekOutcome, simulate_seek
from servokit.seek.plots import seek_plot
from servokit.seek.request import (
    METHODS,
    SeekDesignResult,
    SeekRequest,
    SeekRun,
    design_seek,
    run_seek,
)
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
from servokit.seek.validated import BoxRound, ValidatedSeek, robust_seek_over_box

__all__ = [
    "DESIGNS",
    "METHODS",
    "SeekDesign",
    "SeekDesignResult",
    "SeekOutcome",
    "SeekRequest",
    "SeekRun",
    "design_seek",
    "run_seek",
    "search_range",
    "seek_plot",
    "simulate_seek",
    "table_2_4_weights",
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
    "BoxRound",
    "ValidatedSeek",
    "robust_seek_over_box",
]
