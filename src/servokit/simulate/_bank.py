"""A bank of modal plants discretised on a fine grid, batched over variants and modes.

Every plant variant ``v`` and mode ``m`` is the second-order system

    q'' + 2 zeta w q' + w^2 q = K A u(t - Td),     y = sum_m q_m,

discretised exactly under a zero-order hold on the fine step ``h`` with the delay split
as ``Td = dd*h + frac`` (see :func:`servokit.models._zoh.delayed_zoh`):

    x[j+1] = Phi x[j] + Gnew u[j-dd] + Gold u[j-dd-1].

Everything is built in closed form per 2x2 modal block
(:func:`servokit.models._zoh.modal_zoh`): one vectorised expression over variants and
modes instead of a matrix exponential per block (30x faster for 1000 HDD variants,
same values to 1e-15 relative).  The powers ``Phi^i`` are elementwise products of the
one-step matrices (rounding ``i eps``).

The model at a multiple ``dt = S h`` of the fine step (the sample-rate plant the
controller sees) is not discretised again: over one period the held input enters through
the block maps ``Phi^(S-1-s) G`` of the fine model, and grouping them by the sample they
read gives the sample-rate ``Gnew``/``Gold`` with ``Phi^S`` as transition (exact: the sum
of the sub-interval integrals; rounding ``S eps``).  One discretisation per plant and
rate (issue 24: ``modal_delayed_zoh`` at both rates was 44 % of a one-plant loop).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from servokit.errors import ServokitValueError
from servokit.models._zoh import modal_delayed_zoh
from servokit.models.convert import as_modal_plants
from servokit.models.modal import ModalPlant

__all__ = ["PlantBank", "as_plant_list", "bank_for"]

#: up to this many plants a discretisation is kept for the next call (a user re-running
#: one loop with another reference or controller: issue 24's "one discretisation per
#: plant and rate"); larger sets are built afresh and not held in memory
_REUSE_MAX_PLANTS = 4


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


def modal_arrays(plants: Sequence[ModalPlant]) -> tuple[np.ndarray, ...]:
    """``(w, zeta, r, real)`` of shape (V, M): modes zero-padded, ``real`` marks true modes."""
    n_modes = max(len(p.modes) for p in plants)
    V = len(plants)
    # plain lists: ModalPlant.arrays() per plant costs 20 us, 2 s for 10^5 variants
    rows = [
        [(m.freq_hz, m.damping, p.gain * m.residue) for m in p.modes]
        + [(0.0, 0.0, 0.0)] * (n_modes - len(p.modes))
        for p in plants
    ]
    out = np.array(rows, dtype=float).reshape(V, n_modes, 3)
    real = np.arange(n_modes)[None, :] < np.array([len(p.modes) for p in plants])[:, None]
    return 2.0 * np.pi * out[..., 0], out[..., 1], out[..., 2], real


@dataclass(frozen=True)
class PlantBank:
    """Exact fine-step models of ``V`` plant variants with ``M`` modes each (zero-padded)."""

    w: np.ndarray  # (V, M) natural frequencies [rad/s]
    zeta: np.ndarray  # (V, M)
    r: np.ndarray  # (V, M) input gains; padded modes have zero gain and do nothing
    real: np.ndarray  # (V, M) bool: False for padding
    delay: float
    Phi: np.ndarray  # (V, M, 2, 2) one fine step
    Gnew: np.ndarray  # (V, M, 2)
    Gold: np.ndarray  # (V, M, 2)
    dd: int  # whole fine steps of delay
    h: float
    # transition rows and block maps per sub-step count, shared by discrete() and the
    # simulation kernel (read-only arrays)
    _cache: dict = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def build(cls, plants: Sequence[ModalPlant], h: float) -> PlantBank:
        return cls.from_arrays(*modal_arrays(plants), plants[0].delay, h)

    @classmethod
    def from_arrays(
        cls, w: np.ndarray, zeta: np.ndarray, r: np.ndarray, real: np.ndarray, delay: float,
        h: float,
    ) -> PlantBank:  # fmt: skip
        """The bank of modal arrays (V, M) directly, e.g. from
        :func:`servokit.models.variation_arrays.modal_arrays_from_draws`."""
        Phi, Gnew, Gold, dd = modal_delayed_zoh(w, zeta, r, h, delay)
        return cls(w, zeta, r, real, delay, Phi, Gnew, Gold, dd, h)

    @property
    def shape(self) -> tuple[int, int]:
        return self.Phi.shape[0], self.Phi.shape[1]

    def transition_rows(self, S: int) -> np.ndarray:
        """Entries of ``Phi^i``, ``i = 0..S``: array (4, S+1, V, M) of ``p00, p01, p10, p11``.

        Products of the closed-form one-step matrix written elementwise (12 flops per
        mode and step; a closed form at every ``t = i h`` costs three transcendental
        calls each, 10x more); the rounding grows as ``i eps``, below 1e-13 for
        hundreds of sub-steps.  Time-major so that every step and the block maps built
        from them are contiguous.  Computed once per ``S`` (cached; do not modify).
        """
        key = ("rows", S)
        if key in self._cache:
            return self._cache[key]
        V, M = self.shape
        f00, f01, f10, f11 = (self.Phi[..., i, j] for i in range(2) for j in range(2))
        out = np.empty((4, S + 1, V, M))
        out[:, 0] = np.array([1.0, 0.0, 0.0, 1.0])[:, None, None]
        for i in range(S):
            a, b, c, d = out[:, i]
            out[0, i + 1] = a * f00 + b * f10
            out[1, i + 1] = a * f01 + b * f11
            out[2, i + 1] = c * f00 + d * f10
            out[3, i + 1] = c * f01 + d * f11
        out.flags.writeable = False  # shared by every later call on this cached bank
        self._cache[key] = out
        return out

    def block_maps(self, S: int) -> np.ndarray:
        """``B2`` (2S, V, 2M): effect of each delayed input of a period on the end state.

        ``B2[s] = Phi^(S-1-s) Gnew`` for the new inputs (``s < S``), ``Phi^(2S-1-s) Gold``
        for the old ones, written with the entries of ``Phi^i`` (:meth:`transition_rows`).
        Input-major, so that a shared input drives all variants with one GEMM.  Cached.
        """
        key = ("maps", S)
        if key in self._cache:
            return self._cache[key]
        V, M = self.shape
        rows = self.transition_rows(S)
        p00, p01, p10, p11 = rows[:, S - 1 :: -1] if S > 1 else rows[:, :1]
        out = np.empty((2, S, V, M, 2))
        for n, G in enumerate((self.Gnew, self.Gold)):
            g0, g1 = G[..., 0], G[..., 1]
            out[n, ..., 0] = p00 * g0 + p01 * g1
            out[n, ..., 1] = p10 * g0 + p11 * g1
        out = out.reshape(2 * S, V, 2 * M)
        out.flags.writeable = False  # shared by every later call on this cached bank
        self._cache[key] = out
        return out

    def _period_model(self, S: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """``(Phi, Gnew, Gold, d)`` at ``dt = S h`` from the fine model (module docstring).

        Fine input ``j`` is sample ``j // S``; in period ``k`` the new input of sub-step
        ``s`` is fine input ``kS + s - dd``, i.e. sample ``k - ceil((dd - s) / S)``, the
        old one sample ``k - ceil((dd + 1 - s) / S)``: lags ``d = dd // S`` or ``d + 1``.
        """
        V, M = self.shape
        rows = self.transition_rows(S)
        Phi = rows[:, S].transpose(1, 2, 0).reshape(V, M, 2, 2)
        maps = self.block_maps(S).reshape(2, S, V, M, 2)
        s = np.arange(S)
        lags = np.stack([-((s - self.dd) // S), -((s - self.dd - 1) // S)])  # ceil
        d = self.dd // S
        Gnew = maps[lags == d].sum(axis=0)
        Gold = maps[lags == d + 1].sum(axis=0)
        return Phi, Gnew, Gold, d

    def discrete(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Stacked exact ZOH models at ``dt`` with delay states, like ``ModalPlant.discretize``.

        Returns ``A`` (V, N, N), ``B`` (V, N) and ``C`` (N,) with the ``2M`` modal states
        first and the delay line ``u[k-1], u[k-2], ...`` last.  Padded modes get
        ``Phi = 0`` so that they add only poles at ``z = 0``.
        """
        V, M = self.shape
        S = round(dt / self.h)
        if dt == self.h:  # a sample-rate bank (substeps=1): already discretised
            Phi, Gnew, Gold, d = self.Phi, self.Gnew, self.Gold, self.dd
        elif S >= 1 and abs(S * self.h - dt) <= 1e-12 * dt:  # a multiple: from the fine maps
            Phi, Gnew, Gold, d = self._period_model(S)
        else:
            Phi, Gnew, Gold, d = modal_delayed_zoh(self.w, self.zeta, self.r, dt, self.delay)
        Phi = np.where(self.real[..., None, None], Phi, 0.0)
        n = 2 * M
        has_old = bool(np.any(Gold != 0.0))
        n_del = d + 1 if has_old else d
        N = n + n_del
        A = np.zeros((V, N, N))
        B = np.zeros((V, N))
        blocks = np.arange(M)
        for i in range(2):
            for j in range(2):
                A[:, 2 * blocks + i, 2 * blocks + j] = Phi[..., i, j]
        if n_del:
            B[:, n] = 1.0
            A[:, n + np.arange(1, n_del), n + np.arange(n_del - 1)] = 1.0
        gn, go = Gnew.reshape(V, n), Gold.reshape(V, n)
        if d == 0:
            B[:, :n] = gn
        else:
            A[:, :n, n + d - 1] = gn
        if has_old:
            A[:, :n, n + d] = go
        C = np.zeros(N)
        C[:n:2] = 1.0
        return A, B, C


@lru_cache(maxsize=8)
def _reused_bank(plants: tuple[ModalPlant, ...], h: float) -> PlantBank:
    bank = PlantBank.build(plants, h)
    for arr in (bank.w, bank.zeta, bank.r, bank.real, bank.Phi, bank.Gnew, bank.Gold):
        arr.flags.writeable = False  # shared between calls: nobody may change it
    return bank


def bank_for(plants: Sequence[ModalPlant], h: float) -> PlantBank:
    """:meth:`PlantBank.build`, reused for a few plants seen before at the same step.

    ModalPlant is frozen, so equal plants have equal exact discretisations; the bank of
    at most ``_REUSE_MAX_PLANTS`` plants is kept (8 most recent, read-only arrays; with
    their transition rows and block maps, a few MB at most).

    Parameters
    ----------
    plants : sequence of ModalPlant
        The variants (sharing one delay).
    h : float
        Fine step [s].

    Returns
    -------
    PlantBank
    """
    if len(plants) <= _REUSE_MAX_PLANTS:
        try:
            return _reused_bank(tuple(plants), float(h))
        except TypeError:  # a plant with an unhashable field: no reuse
            pass
    return PlantBank.build(plants, h)
