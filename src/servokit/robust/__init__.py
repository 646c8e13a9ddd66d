"""Beyond the book: robust minimum-time feedforward over a plant set, and sweeps at scale.

* :func:`robust_minimum_time` — the shortest worst-case seek guaranteed on a plant set
  under input, slew and §2.6 limits, as linear programs (:mod:`.feedforward`);
* :mod:`servokit.robust.sweep` — seek-time distributions over 10^4-10^5 Monte-Carlo
  plants in bounded memory, in-process or on Dask (``sweep_seek_times``, ``connect_dask``);
* :func:`robust_seek_over_box` — the robust seek whose worst case is validated inside
  the variation box (Monte-Carlo and adversarial search, redesign until they agree).
"""

from servokit.robust.feedforward import (
    NoFeasibleSeekError,
    RobustFeedforwardInput,
    robust_minimum_time,
)
from servokit.robust.validated import ValidatedSeek, robust_seek_over_box

__all__ = [
    "NoFeasibleSeekError",
    "RobustFeedforwardInput",
    "ValidatedSeek",
    "robust_minimum_time",
    "robust_seek_over_box",
]
