"""Linear maps from held input samples to every variant's output, for the robust seek LP.

Every plant variant ``v`` is linear in the held input samples ``u[0..N-1]`` (each held
for ``dt`` from ``k dt``, zero from ``N dt`` on), so on the read-out grid ``t_j = j h``
(``h = dt / S``) its output is

    y_v[j] = sum_k u[k] p_v[j - k S],                                          (R1)

with ``p_v`` the response to one unit sample held over ``[0, dt)`` (the pulse
response, delay included), taken from :func:`servokit.simulate.simulate` once for all
variants.

Beyond the checked record.  The grid rows stop at a horizon ``T >= N dt + Td``; after it
every mode moves freely.  A flexible mode ``q'' + 2 zeta w q' + w^2 q = 0``
(``0 < zeta < 1``) with ``sigma = zeta w``, ``wd = w sqrt(1 - zeta^2)`` moves as

    q(T + tau) = e^{-sigma tau} (a cos wd tau + b sin wd tau),
    a = q(T),  b = (q'(T) + sigma q(T)) / wd,                                  (R2)

so ``|q(T + tau)| <= sqrt(a^2 + b^2) <= |a| + |b|`` for every ``tau >= 0``.  The rigid
body (``w = 0``) stays where it is once its velocity, ``r dt sum_k u[k]``, is zero.
Hence, for all ``t >= T``,

    |y_v(t) - target| <= |q_rigid,v(T) - target| + sum_m (|a_vm| + |b_vm|),    (R3)

and requiring the right-hand side to be ``<= band`` bounds the whole infinite tail with
linear rows (the L1 bound of the L2 envelope), not just a truncated record.  ``a`` and
``b`` are linear in ``u``: ``x_vm(T) = sum_k e^{A (T - Td - (k+1) dt)} Gamma(dt) u[k]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models._zoh import zoh_pair
from servokit.models.modal import ModalPlant
from servokit.simulate import simulate

__all__ = ["PulseBank", "TailMaps"]


def _modal_arrays(plants: Sequence[ModalPlant]) -> tuple[np.ndarray, ...]:
    """Frequencies [rad/s], dampings and gains (V, M), zero-padded (padded gain 0)."""
    M = max(len(p.modes) for p in plants)
    out = [np.zeros((len(plants), M)) for _ in range(3)]
    for v, p in enumerate(plants):
        for arr, vals in zip(out, p.arrays(), strict=True):
            arr[v, : vals.size] = vals
    return tuple(out)


@dataclass(frozen=True, eq=False)
class TailMaps:
    """Rows bounding the free motion after the horizon, eqs. (R2)-(R3).

    Attributes
    ----------
    rigid : ndarray (V, N)
        Rigid-body position at the horizon per unit input sample (sum over rigid modes).
    a, b : ndarray (V, F, N)
        Coefficients of (R2) of the ``F`` flexible modes (zero rows for padded modes).
    """

    rigid: np.ndarray
    a: np.ndarray
    b: np.ndarray


@dataclass(frozen=True, eq=False)
class PulseBank:
    """Pulse responses and modal data of a plant set on the grid ``h = dt / substeps``."""

    dt: float
    substeps: int
    delay: float
    pulse: np.ndarray  # (V, J) response to u = [1] on the fine grid
    w: np.ndarray  # (V, M) [rad/s]
    z: np.ndarray
    r: np.ndarray

    @classmethod
    def build(
        cls, plants: Sequence[ModalPlant], dt: float, substeps: int, duration: float
    ) -> PulseBank:
        """Simulate the unit pulse on every plant for ``duration`` seconds (R1)."""
        w, z, r = _modal_arrays(plants)
        rigid = (w == 0.0) & (r != 0.0)
        if not rigid.any(axis=1).all():
            v = int(np.flatnonzero(~rigid.any(axis=1))[0])
            raise ServokitValueError(
                f"plants[{v}] has no rigid-body mode: an input that returns to zero leaves it "
                "at 0, so no seek reaches the target; add a Mode(0, 0, residue)"
            )
        flex = (w > 0.0) & (r != 0.0)
        if np.any(flex & (z >= 1.0)):
            raise ServokitValueError(
                "robust_minimum_time bounds the tail of underdamped modes only; a mode has "
                "damping >= 1: split it into real poles or remove it"
            )
        n_samples = int(np.ceil(duration / dt)) + 1
        res = simulate(plants, dt=dt, n_samples=n_samples, substeps=substeps, feedforward=[1.0])
        return cls(dt, substeps, float(plants[0].delay), res.yc, w, z, r)

    @property
    def n_plants(self) -> int:
        """Number of variants V."""
        return int(self.pulse.shape[0])

    def horizon_index(self, N: int, tail: float) -> int:
        """Grid index of the horizon: ``tail`` seconds after the delayed input ends."""
        h = self.dt / self.substeps
        J = int(np.ceil((N * self.dt + self.delay + tail) / h - 1e-9))
        if J >= self.pulse.shape[1]:
            raise ServokitValueError(  # a programming error of the caller: pulse too short
                f"the pulse response covers {self.pulse.shape[1]} grid points, {J + 1} needed"
            )
        return J

    def output_map(self, N: int, rows: np.ndarray) -> np.ndarray:
        """``H (V, len(rows), N)`` with ``y_v[rows] = H[v] @ u``, eq. (R1)."""
        lag = rows[:, None] - self.substeps * np.arange(N)[None, :]
        H = self.pulse[:, np.clip(lag, 0, None)]
        H[:, lag < 0] = 0.0
        return H

    @cached_property
    def _modal_blocks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``A, B`` of every modal block and their ZOH ``Phi, Gamma`` over ``dt``.

        The same for every ``N`` of a design scan, so computed once per bank.
        """
        V, M = self.w.shape
        A = np.zeros((V, M, 2, 2))
        A[..., 0, 1] = 1.0
        A[..., 1, 0] = -(self.w**2)
        A[..., 1, 1] = -2.0 * self.z * self.w
        B = np.zeros((V, M, 2, 1))
        B[..., 1, 0] = self.r
        return (A, B, *zoh_pair(A, B, self.dt))

    def tail_maps(self, N: int, J: int) -> TailMaps:
        """Modal state at ``T = J h`` per input sample, as the rows of (R2)-(R3)."""
        V, M = self.w.shape
        A, B, Phi, Gam = self._modal_blocks
        T = J * self.dt / self.substeps
        E0, _ = zoh_pair(A, B, T - self.delay - N * self.dt)
        cols = np.empty((V, M, 2, N))
        # sample k = N-1 acts for T - Td - N dt after its hold; each earlier sample acts one
        # step longer: e^{A (tau + dt)} = Phi e^{A tau} (exponentials of one A commute)
        col = E0 @ Gam
        for k in range(N - 1, -1, -1):
            cols[..., k] = col[..., 0]
            col = Phi @ col
        rigid = np.where(((self.w == 0.0) & (self.r != 0.0))[..., None], cols[..., 0, :], 0.0)
        flex = (self.w > 0.0) & (self.r != 0.0)
        sigma = self.z * self.w
        wd = self.w * np.sqrt(np.clip(1.0 - self.z**2, 0.0, None))
        safe_wd = np.where(flex, wd, 1.0)[..., None]
        a = np.where(flex[..., None], cols[..., 0, :], 0.0)
        b = np.where(flex[..., None], (cols[..., 1, :] + sigma[..., None] * a) / safe_wd, 0.0)
        return TailMaps(rigid.sum(axis=1), a, b)
