"""Actuator saturation (amplitude and slew limits) with anti-windup, at the sample rate.

A saturated loop is not linear, so it cannot use the superposition of
:mod:`servokit.simulate._closed`; it is stepped sample by sample (vectorised over plant
variants) on the exact ZOH discretisation of each plant, delay included
(:meth:`ModalPlant.discretize`):

    x[k+1] = A x[k] + B u[k],   yd[k] = C x[k],
    v[k]  = Cc xc[k] + Dc e[k] + u_ff[k],   e[k] = r[k] - yd[k],
    u[k]  = sat(v[k]):  |u| <= u_max and |u[k] - u[k-1]| <= slew_max,

which is the same sampled loop as :func:`servokit.simulate.simulate` (identical outputs
at the samples when nothing saturates).  Anti-windup is the observer form of Astrom and
Rundqwist (1989): the controller state is corrected by the difference between the
applied and the demanded input,

    xc[k+1] = Ac xc[k] + Bc e[k] + L (u[k] - v[k]),

with ``L`` placing the poles of ``Ac - L Cc`` (the controller's dynamics while the
actuator is saturated) at ``observer_poles`` (default evenly in [0.3, 0.5]): an
integrator then stops charging during saturation.  Unsaturated, ``u = v`` and the
correction vanishes.  The conditioning technique (``L = Bc / Dc``, which puts those poles
at the controller zeros) was tried first and rejected: with the book's eq. (4.69)
controller it limit-cycles on a 10-track step where the observer form settles without
overshoot.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError, check_positive, check_work
from servokit.models.modal import ModalPlant

#: samples :func:`limit_input` walks one by one at most (~20 us each: about ten seconds)
_MAX_LIMITED_SAMPLES = 5e5

__all__ = ["Actuator", "SaturatedResult", "antiwindup_gain", "limit_input", "simulate_saturated"]


@dataclass(frozen=True)
class Actuator:
    """Limits of the actuator input and the anti-windup switch.

    Parameters
    ----------
    u_max : float
        Largest ``|u|`` [plant input unit]; ``inf`` for none.
    slew_max : float, optional
        Largest ``|u[k] - u[k-1]|`` per sample [plant input unit]; none if omitted.
    anti_windup : bool
        Correct the controller state by the applied input (module docstring).
    observer_poles : sequence of float, optional
        Poles of the controller's dynamics while saturated (one per controller state,
        distinct, inside the unit circle); default evenly spaced in [0.3, 0.5].
    """

    u_max: float = np.inf
    slew_max: float | None = None
    anti_windup: bool = True
    observer_poles: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not self.u_max > 0:
            raise ServokitValueError(f"u_max must be > 0 (got {self.u_max})")
        if self.slew_max is not None:
            check_positive("slew_max", self.slew_max)


@dataclass(frozen=True)
class SaturatedResult:
    """Output of :func:`simulate_saturated` at the sampling instants.

    Parameters
    ----------
    td : numpy.ndarray
        Sampling instants [s], shape ``(K,)``.
    yd : numpy.ndarray
        Output at the samples, ``(V, K)``.
    u : numpy.ndarray
        Applied (limited) input, ``(V, K)``.
    v : numpy.ndarray
        Demanded input (controller plus feedforward), ``(V, K)``.
    """

    td: np.ndarray
    yd: np.ndarray
    u: np.ndarray
    v: np.ndarray

    @property
    def peak_input(self) -> float:
        """Largest applied ``|u|``."""
        return float(np.max(np.abs(self.u)))

    @property
    def saturated_fraction(self) -> float:
        """Fraction of samples where the applied input differs from the demand."""
        return float(np.mean(~np.isclose(self.u, self.v, rtol=1e-12, atol=0.0)))


def _plant_matrices(plants: Sequence[ModalPlant], dt: float):
    mats = [p.discretize(dt) for p in plants]
    n = {m.nstates for m in mats}
    if len(n) != 1:
        raise ServokitValueError(
            "plants must share one state dimension (same modes and delay steps) to be "
            "simulated together; simulate them separately"
        )
    A = np.stack([np.asarray(m.A) for m in mats])
    B = np.stack([np.asarray(m.B)[:, 0] for m in mats])
    C = np.stack([np.asarray(m.C)[0] for m in mats])
    return A, B, C


def _controller(controller: Any, dt: float, act: Actuator):
    """``(Ac, Bc, Cc, Dc, L)`` of the controller; ``L`` the anti-windup gain (zeros if off)."""
    import control

    ss = control.ss(controller)
    if ss.dt is None or ss.dt == 0 or not np.isclose(ss.dt, dt, rtol=1e-9):
        raise ServokitValueError(f"controller must be discrete with dt = {dt:g} s")
    Ac, Bc = np.asarray(ss.A), np.asarray(ss.B)[:, 0]
    Cc, Dc = np.asarray(ss.C)[0], float(np.asarray(ss.D)[0, 0])
    if not act.anti_windup or Ac.shape[0] == 0:
        return Ac, Bc, Cc, Dc, np.zeros(Ac.shape[0])
    return Ac, Bc, Cc, Dc, antiwindup_gain(Ac, Cc, act.observer_poles)


def antiwindup_gain(
    Ac: np.ndarray, Cc: np.ndarray, poles: Sequence[float] | None = None
) -> np.ndarray:
    """Observer anti-windup gain ``L``: ``x <- A x + B e + L (u_applied - y)``.

    While unsaturated ``u_applied = y`` and the controller is unchanged; while saturated
    its state evolves with ``A - L C``, whose poles are ``poles`` (module docstring).

    Parameters
    ----------
    Ac : numpy.ndarray
        Controller state matrix, ``(nc, nc)``.
    Cc : numpy.ndarray
        Controller output row, ``(nc,)``.
    poles : sequence of float, optional
        Poles of ``A - L C`` (distinct, inside the unit circle); default evenly spaced in
        [0.3, 0.5].

    Returns
    -------
    numpy.ndarray
        ``L``, shape ``(nc,)``.
    """
    from scipy.signal import place_poles

    nc = Ac.shape[0]
    poles = np.linspace(0.3, 0.5, nc) if poles is None else poles
    poles = np.asarray(poles, dtype=float)
    if poles.size != nc or np.any(np.abs(poles) >= 1) or np.unique(poles).size != nc:
        raise ServokitValueError(
            f"observer_poles must be {nc} distinct values inside the unit circle"
        )
    try:
        return place_poles(Ac.T, np.asarray(Cc).reshape(-1, 1), poles).gain_matrix.T[:, 0]
    except (ValueError, np.linalg.LinAlgError):
        raise ServokitValueError(
            "anti_windup: the controller realisation is not observable from its output; "
            "pass a minimal controller or switch anti_windup off"
        ) from None


def _limit(v: np.ndarray, u_prev: np.ndarray, act: Actuator) -> np.ndarray:
    u = np.clip(v, -act.u_max, act.u_max)
    if act.slew_max is not None:
        u = np.clip(u, u_prev - act.slew_max, u_prev + act.slew_max)
    return u


def simulate_saturated(
    plants: ModalPlant | Sequence[ModalPlant],
    *,
    dt: float,
    n_samples: int,
    actuator: Actuator,
    controller: Any = None,
    reference: np.ndarray | Sequence[float] | None = None,
    feedforward: np.ndarray | Sequence[float] | None = None,
) -> SaturatedResult:
    """Simulate a sampled loop with a limited actuator (equations in the module docstring).

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Variants run together (same state dimension).
    dt : float
        Sampling (hold) period [s].
    n_samples : int
        Samples simulated.
    actuator : Actuator
        Amplitude and slew limits, anti-windup.
    controller : python-control LTI, optional
        Discrete SISO controller ``C(z)`` on ``e = r - yd`` with period ``dt``.
    reference : array_like, optional
        ``r[k]`` (held at its last value beyond its length); zero if omitted.
    feedforward : array_like, optional
        ``u_ff[k]`` added to the controller output (zero beyond its length).

    Returns
    -------
    SaturatedResult
        Output, applied and demanded input at the samples.
    """
    plist = [plants] if isinstance(plants, ModalPlant) else list(plants)
    dt = check_positive("dt", dt, "s")
    K = int(n_samples)
    if K < 1:
        raise ServokitValueError(f"n_samples must be >= 1 (got {n_samples})")
    A, B, C = _plant_matrices(plist, dt)
    r = _padded(reference, K, hold=True)
    uff = _padded(feedforward, K, hold=False)
    V = len(plist)
    x = np.zeros((V, A.shape[1]))
    yd, u_out, v_out = (np.empty((V, K)) for _ in range(3))
    ctrl = None if controller is None else _controller(controller, dt, actuator)
    xc = np.zeros((V, 0 if ctrl is None else ctrl[0].shape[0]))
    u_prev = np.zeros(V)
    for k in range(K):
        y = np.einsum("vn,vn->v", C, x)
        v = np.full(V, uff[k])
        if ctrl is not None:
            Ac, Bc, Cc, Dc, L = ctrl
            e = r[k] - y
            v = v + xc @ Cc + Dc * e
        u = _limit(v, u_prev, actuator)
        if ctrl is not None:
            xc = xc @ Ac.T + e[:, None] * Bc + (u - v)[:, None] * L
        x = np.einsum("vmn,vn->vm", A, x) + B * u[:, None]
        yd[:, k], u_out[:, k], v_out[:, k], u_prev = y, u, v, u
    return SaturatedResult(np.arange(K) * dt, yd, u_out, v_out)


def _padded(values: Any, K: int, *, hold: bool) -> np.ndarray:
    if values is None:
        return np.zeros(K)
    a = np.asarray(values, dtype=float).ravel()
    if a.size == 0 or not np.all(np.isfinite(a)):
        raise ServokitValueError("reference/feedforward must be non-empty and finite")
    if a.size >= K:
        return a[:K]
    return np.concatenate([a, np.full(K - a.size, a[-1] if hold else 0.0)])


def limit_input(u: np.ndarray, actuator: Actuator) -> tuple[np.ndarray, int]:
    """An open-loop held input as the actuator applies it (amplitude, then slew limit).

    The input is at rest (zero) before the first sample and returns to zero after the
    last; a slew limit may need extra samples to get there, which are appended.

    Parameters
    ----------
    u : numpy.ndarray
        Demanded held input ``u[k]``, shape ``(N,)``.
    actuator : Actuator
        The limits (``anti_windup`` is irrelevant: there is no controller).

    Returns
    -------
    applied : numpy.ndarray
        The applied input, shape ``(N + extra,)``.
    n_limited : int
        Samples where the applied input differs from the demand.
    """
    u = np.asarray(u, dtype=float).ravel()
    extra = 0
    if actuator.slew_max is not None:  # from +-peak back to zero at the slew rate
        # from rest the applied input cannot pass N slew steps: extra <= 2 N + 1
        peak = min(
            float(np.max(np.abs(u), initial=0.0)), actuator.u_max, u.size * actuator.slew_max
        )
        steps = np.ceil(2 * peak / actuator.slew_max) + 1
        # the return to rest is walked sample by sample: bound it before allocating
        check_work(
            u.size + steps,
            what=f"slew_max {actuator.slew_max:g} (a peak of {peak:g} returns to rest in "
            f"{steps:.3g} samples)",
            limit=_MAX_LIMITED_SAMPLES,
            about="about ten seconds; raise slew_max",
        )
        extra = int(steps)
    demand = np.concatenate([u, np.zeros(extra)])
    applied, prev = np.empty_like(demand), np.zeros(1)
    for k, v in enumerate(demand):
        prev = _limit(np.array([v]), prev, actuator)
        applied[k] = prev[0]
    n_limited = int(np.sum(applied != demand))
    last = max(u.size, int(np.flatnonzero(applied)[-1]) + 1 if applied.any() else 0)
    return applied[:last], n_limited
