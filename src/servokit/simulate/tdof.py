"""Feedforward inputs implemented in the TDOF structure (book §2.1.3, Figs. 2.5, 2.6, 2.27).

The feedforward input ``u_ff`` drives both the plant and a nominal model; the model's
output ``y_m`` is the reference of the feedback controller ``K``::

    u = u_ff + K (y_m - y),       y_m = P_nominal e^{-s Td} u_ff             (Fig. 2.6)

When the plant equals the nominal model the feedback error is zero and the response
is the open-loop response ``P e^{-s Td} u_ff`` (eq. 2.8 with ``M = P``): the input can be
designed on the delay-free nominal plant and the delay is accounted for by the model
(Fig. 2.6; pass a nominal model without delay for Fig. 2.5).  The model-matching TDOF
of Figs. 2.4(c) and 2.27 is the same loop with ``u_ff = G_FF r`` and ``M = P G_FF``.

Here ``y_m`` is the nominal model's exact output at the sampling instants, i.e. the
output of ``M(z)``, the ZOH discretisation of the nominal model with its delay (as
eq. 4.75), computed with the same exact simulator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit.models.modal import ModalPlant
from servokit.simulate.hybrid import Signal, SimulationResult, simulate

__all__ = ["TdofResult", "tdof_response"]


@dataclass(frozen=True)
class TdofResult:
    """Response of the TDOF loop: ``sim`` (plants in closed loop) and ``reference`` ``y_m[k]``."""

    sim: SimulationResult
    reference: np.ndarray


def tdof_response(
    plants: ModalPlant | Sequence[ModalPlant],
    nominal: ModalPlant,
    *,
    controller: control.LTI,
    dt: float,
    n_samples: int,
    feedforward: np.ndarray | Sequence[float],
    ff_dt: float | None = None,
    substeps: int = 10,
    multirate: tuple[int, control.LTI] | None = None,
    output_disturbance: Signal | np.ndarray | None = None,
    input_disturbance: Signal | np.ndarray | None = None,
) -> TdofResult:
    """Simulate plant variants under a feedforward input in the TDOF structure (Fig. 2.6).

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Real plants (e.g. the perturbed set), simulated together.
    nominal : ModalPlant
        Nominal model ``P e^{-s Td}`` whose output is the reference (keep its delay for
        Fig. 2.6, set it to zero for Fig. 2.5).
    controller : python-control LTI
        Discrete feedback controller ``K`` with sampling period ``dt``.
    dt, n_samples, substeps, multirate, output_disturbance, input_disturbance
        As in :func:`servokit.simulate.simulate`.
    feedforward, ff_dt
        Feedforward samples and their hold period (default ``dt``).

    Returns
    -------
    TdofResult
    """
    model = simulate(
        nominal,
        dt=dt,
        n_samples=n_samples,
        substeps=substeps,
        feedforward=feedforward,
        ff_dt=ff_dt,
    )
    ym = model.yd[0]
    sim = simulate(
        plants,
        dt=dt,
        n_samples=n_samples,
        substeps=substeps,
        feedforward=feedforward,
        ff_dt=ff_dt,
        controller=controller,
        reference=ym,
        multirate=multirate,
        output_disturbance=output_disturbance,
        input_disturbance=input_disturbance,
    )
    return TdofResult(sim=sim, reference=ym)
