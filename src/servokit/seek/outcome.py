"""Simulated seek of one feedforward input over a plant set, read on the Ts/10 grid (§2.4.1)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit.feedforward import FeedforwardInput
from servokit.models import ModalPlant
from servokit.simulate import seek_response, settling_time
from servokit.simulate.metrics import READOUT_SUBSTEPS

__all__ = ["BAND", "SeekOutcome", "simulate_seek"]

#: Seek band of the HDD benchmark [track] (§2.4.1, assumption 4).
BAND = 0.1


@dataclass(frozen=True, eq=False)
class SeekOutcome:
    """Simulated seek of one design over the plant set."""

    ff: FeedforwardInput
    t: np.ndarray
    y: np.ndarray
    seek_times: np.ndarray

    @property
    def worst(self) -> float:
        return float(np.max(self.seek_times))

    @property
    def worst_plant(self) -> int:
        return int(np.argmax(self.seek_times))


def simulate_seek(
    plants: Sequence[ModalPlant],
    ff: FeedforwardInput,
    target: float,
    *,
    band: float = BAND,
    horizon: float | None = None,
) -> SeekOutcome:
    """Open-loop seek of every plant on the dt/10 grid; seek time per plant (§2.4.1).

    Parameters
    ----------
    plants : sequence of ModalPlant
        Plants simulated together (their input delays are simulated as given).
    ff : FeedforwardInput
        Held input, applied without feedback.
    target : float
        Seek distance [track].
    band : float
        Half-width of the settling band [track] (0.1 in the benchmark).
    horizon : float, optional
        Simulated record length [s]; default that of
        :func:`~servokit.simulate.seek_response` (``max(3 T, T + 2 ms)``, ``T = N dt``).

    Returns
    -------
    SeekOutcome
        ``ff``, the time grid ``t`` (step ``ff.dt / 10``) [s], the positions ``y``
        (plants x times) [track] and the seek time of each plant [s] (``inf`` if not
        settled within the record).
    """
    res = seek_response(plants, ff, grid=ff.dt / READOUT_SUBSTEPS, horizon=horizon)
    return SeekOutcome(ff, res.t, res.yc, settling_time(res.t, res.yc, target, band))
