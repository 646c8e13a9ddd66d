"""Beyond the book: robust minimum-time feedforward over a plant set, and sweeps at scale.

* :func:`robust_minimum_time` — the shortest worst-case seek guaranteed on a plant set
  under input (and slew) limits, as linear programs (:mod:`.feedforward`).
"""

from servokit.robust.feedforward import (
    NoFeasibleSeekError,
    RobustFeedforwardInput,
    robust_minimum_time,
)

__all__ = ["NoFeasibleSeekError", "RobustFeedforwardInput", "robust_minimum_time"]
