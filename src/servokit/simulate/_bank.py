"""A bank of modal plants discretised on a fine grid, batched over variants and modes.

Every plant variant ``v`` and mode ``m`` is the second-order system

    q'' + 2 zeta w q' + w^2 q = K A u(t - Td),     y = sum_m q_m,

discretised exactly under a zero-order hold on the fine step ``h`` with the delay split
as ``Td = dd*h + frac`` (see :func:`servokit.models._zoh.delayed_zoh`):

    x[j+1] = Phi x[j] + Gnew u[j-dd] + Gold u[j-dd-1].

The block quantities used by the simulator (powers ``Phi^i`` for ``i = 0..S`` and the
impulse responses of one block of ``S`` fine steps) are built by cumulative products of
the exact one-step matrices: ``S`` is a number of sub-steps per sample (tens to a few
hundred), where the rounding of a product chain stays at the 1e-14 level.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models._zoh import delayed_zoh
from servokit.models.convert import as_modal_plants
from servokit.models.modal import ModalPlant

__all__ = ["PlantBank", "as_plant_list"]


def as_plant_list(plants: ModalPlant | Sequence[ModalPlant]) -> list[ModalPlant]:
    """Accept one plant or a non-empty sequence of plants that share one delay."""
    # python-control plants are converted (servokit.models.convert); others: TypeError
    plist = as_modal_plants(plants)
    if not plist:
        raise ServokitValueError("plants is empty; pass a ModalPlant or a list of them")
    delays = {p.delay for p in plist}
    if len(delays) > 1:
        raise ServokitValueError(
            "plants must share one input delay to be simulated together; group them by delay"
        )
    return plist


@dataclass(frozen=True)
class PlantBank:
    """Exact fine-step models of ``V`` plant variants with ``M`` modes each (zero-padded)."""

    Phi: np.ndarray  # (V, M, 2, 2) one fine step
    Gnew: np.ndarray  # (V, M, 2)
    Gold: np.ndarray  # (V, M, 2)
    dd: int  # whole fine steps of delay
    h: float

    @classmethod
    def build(cls, plants: Sequence[ModalPlant], h: float) -> PlantBank:
        n_modes = max(len(p.modes) for p in plants)
        V = len(plants)
        w = np.zeros((V, n_modes))
        z = np.zeros((V, n_modes))
        r = np.zeros((V, n_modes))  # padded modes have zero gain and do nothing
        for v, p in enumerate(plants):
            wv, zv, rv = p.arrays()
            w[v, : len(wv)], z[v, : len(zv)], r[v, : len(rv)] = wv, zv, rv
        A = np.zeros((V, n_modes, 2, 2))
        A[..., 0, 1] = 1.0
        A[..., 1, 0] = -(w**2)
        A[..., 1, 1] = -2.0 * z * w
        B = np.zeros((V, n_modes, 2, 1))
        B[..., 1, 0] = r
        Phi, Gnew, Gold, dd = delayed_zoh(A, B, h, plants[0].delay)
        return cls(Phi, Gnew[..., 0], Gold[..., 0], dd, h)

    @property
    def shape(self) -> tuple[int, int]:
        return self.Phi.shape[0], self.Phi.shape[1]

    def powers(self, S: int) -> np.ndarray:
        """``Phi^i`` for ``i = 0..S``, shape (V, M, S+1, 2, 2)."""
        V, M = self.shape
        out = np.empty((V, M, S + 1, 2, 2))
        out[:, :, 0] = np.eye(2)
        for i in range(S):
            out[:, :, i + 1] = self.Phi @ out[:, :, i]
        return out
