"""Automatic choice of the step number N of an FSC/FFSC input (book §2.4.2).

The book found N by trial and error: the N whose input gives the smallest worst-case
seek time over the plant set.  :func:`choose_N` does that search with the batched
simulator; it lives here, above :mod:`servokit.feedforward`, because it evaluates the
designs by simulation.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedforward.constraints import InfeasibleConstraintsError
from servokit.feedforward.ffsc import FeedforwardInput, StepsBelowOrderError, fsc_input
from servokit.models.convert import as_modal_plants
from servokit.models.modal import ModalPlant
from servokit.simulate.metrics import seek_time

__all__ = ["NSearchResult", "choose_N"]


@dataclass(frozen=True, eq=False)
class NSearchResult:
    """Result of :func:`choose_N`: the best step number and the worst-case seek time per N.

    Attributes
    ----------
    N : int
        Step number with the smallest worst-case seek time (smallest N on ties).
    seek_time : float
        That worst-case seek time [s].
    worst_plant : int
        Index of the plant that sets it.
    ff : FeedforwardInput
        The input designed with ``N``.
    N_values : ndarray (K,)
    worst_seek_times : ndarray (K,)
        Worst-case seek time [s] for every N tried (inf if some plant never settles).
    """

    N: int
    seek_time: float
    worst_plant: int
    ff: FeedforwardInput
    N_values: np.ndarray
    worst_seek_times: np.ndarray


def choose_N(
    plants: ModalPlant | Sequence[ModalPlant],
    dt: float,
    target: float,
    N_range: Iterable[int],
    *,
    design_plant: ModalPlant | None = None,
    band: float = 0.1,
    grid: float | None = None,
    horizon: float | None = None,
    seek_time_fn: Callable[..., np.ndarray] | None = None,
    **design_kw: Any,
) -> NSearchResult:
    """Step number N minimising the worst-case seek time over ``plants`` (§2.4.2).

    Parameters
    ----------
    plants : ModalPlant or sequence
        Plants the input is evaluated on (e.g. ``hdd_benchmark_variants()``).
    dt, target
        As in :func:`servokit.feedforward.fsc_input`.
    N_range : iterable of int
        Candidate step numbers.
    design_plant : ModalPlant, optional
        Model the input is designed on; default the first of ``plants`` (the nominal one).
    band : float
        Settling band around ``target`` (plant output units).
    grid : float, optional
        Read-out period [s] of the position; default ``dt / 10``.
    horizon : float, optional
        Simulated record length [s]; default that of :func:`seek_time`.
    seek_time_fn : callable, optional
        Replacement for :func:`seek_time` (same signature).
    **design_kw
        Passed to :func:`servokit.feedforward.fsc_input` (``band_weights``, ``model``, ...).

    Returns
    -------
    NSearchResult
        Best N (smallest on ties), its worst-case seek time and input, and the whole sweep;
        N values for which the design is impossible (below the model order) or some plant
        never settles within the record get an infinite seek time.

    Raises
    ------
    ServokitValueError
        Empty ``plants`` or ``N_range``, or no N settles every plant.
    """
    plant_list = as_modal_plants(plants)  # python-control plants too
    if not plant_list:
        raise ServokitValueError("plants is empty; pass at least one ModalPlant")
    Ns = sorted({int(n) for n in N_range})
    if not Ns:
        raise ServokitValueError("N_range is empty; pass candidate step numbers, e.g. range(8, 30)")
    if seek_time_fn is None:
        seek_time_fn = seek_time
    design = plant_list[0] if design_plant is None else design_plant
    worst = np.full(len(Ns), np.inf)
    which = np.zeros(len(Ns), dtype=int)
    inputs: list[FeedforwardInput | None] = []
    for i, n_steps in enumerate(Ns):
        try:
            ff = fsc_input(design, dt, n_steps, target, **design_kw)
        except (StepsBelowOrderError, InfeasibleConstraintsError):
            inputs.append(None)  # too few steps, or the limits cannot be met: not a candidate
            continue
        times = np.asarray(
            seek_time_fn(plant_list, ff, target, band=band, grid=grid, horizon=horizon),
            dtype=float,
        )
        worst[i] = float(np.max(times))
        which[i] = int(np.argmax(times))
        inputs.append(ff)
    if not np.any(np.isfinite(worst)):
        raise ServokitValueError(
            f"no N in {Ns[0]}..{Ns[-1]} settles every plant within +-{band}; "
            "widen N_range or the band"
        )
    best = int(np.argmin(worst))
    ff_best = inputs[best]
    assert ff_best is not None
    return NSearchResult(
        N=Ns[best],
        seek_time=float(worst[best]),
        worst_plant=int(which[best]),
        ff=ff_best,
        N_values=np.array(Ns),
        worst_seek_times=worst,
    )
