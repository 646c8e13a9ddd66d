"""Linear time-varying (LTV) peak filter, eqs. (5.47)-(5.56), in a digital loop.

The filter keeps the structure of (5.17) and schedules its gain K and damping ζ1 as
``θ(t) = θ̄ [1 + (θ(0)/θ̄ − 1) e^{−γ t}]`` (5.49), sampled per control period as (5.50).
The printed (5.56), ``θ(t) = θs [1 + (θi/θs) e^{−γt}]``, misses the "− 1": it starts at
θs + θi instead of θi. :func:`schedule` uses (5.49)'s form.

Realisation (it matters for an LTV system): q̈ + 2ζ1(t) ω1 q̇ + ω1² q = e,
F-output ``K(t) [cos φ (e − 2ζ1 ω1 q̇ − ω1² q) + ω1 sin φ q̇]``, i.e. the output map carries
K and the state matrix carries ζ1, so a frozen parameter set is exactly (5.17). Each
period the state equation is discretised exactly (zero-order hold on e, matrix
exponential of the frozen matrices at the start of the period).

The loop is that of Fig. 5.11 in discrete time: ``u = C (1 + F) e``, ``e = −(y + d)``
with the plant discretised exactly under the zero-order hold and the disturbance d
added at the output, so the samples are exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_finite, check_positive
from servokit.models._zoh import expm_batched

__all__ = ["LtvPeakFilter", "LoopResponse", "schedule", "simulate_peak_filter_loop", "decay_time"]


def schedule(initial: float, final: float, gamma: float, t: np.ndarray) -> np.ndarray:
    """θ(t) = θ̄ [1 + (θ(0)/θ̄ − 1) e^{−γt}], eq. (5.49).

    Parameters
    ----------
    initial : float
        θ(0) (> 0).
    final : float
        θ̄, the lower bound reached as t → ∞ (> 0).
    gamma : float
        Decay rate γ [1/s] (>= 0).
    t : numpy.ndarray
        Times [s].

    Returns
    -------
    numpy.ndarray
        θ at ``t``.
    """
    final = check_positive("final", final)
    initial = check_positive("initial", initial)
    gamma = float(check_finite("gamma", gamma))
    if gamma < 0:
        raise ServokitValueError(f"gamma must be >= 0 1/s (got {gamma})")
    return final * (1.0 + (initial / final - 1.0) * np.exp(-gamma * np.asarray(t, dtype=float)))


@dataclass(frozen=True)
class LtvPeakFilter:
    """Peak filter (5.17) with K and ζ1 scheduled by (5.49); LTI when initial == final."""

    freq_hz: float
    phi: float
    gain: tuple[float, float]  #: (K(0), K̄)
    damping: tuple[float, float]  #: (ζ1(0), ζ̄1)
    gamma: float = 0.0  #: decay rate γ [1/s]

    @classmethod
    def lti(cls, freq_hz: float, damping: float, gain: float, phi: float) -> LtvPeakFilter:
        return cls(freq_hz, phi, (gain, gain), (damping, damping), 0.0)

    def parameters(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """K(t), ζ1(t) at the times ``t`` [s]."""
        return (
            schedule(self.gain[0], self.gain[1], self.gamma, t),
            schedule(self.damping[0], self.damping[1], self.gamma, t),
        )

    def frozen(self, t: float) -> control.TransferFunction:
        """The LTI filter (5.17) with the parameters of time ``t``."""
        from servokit.feedback.filters import peak_filter

        k, z = self.parameters(np.array([t]))
        return peak_filter(self.freq_hz, float(z[0]), float(k[0]), self.phi)

    def discrete_matrices(self, dt: float, n: int) -> tuple[np.ndarray, ...]:
        """Per-period (Ad, Bd, C, D) of the exactly discretised LTV filter, n periods."""
        w1 = 2 * np.pi * check_positive("freq_hz", self.freq_hz, "Hz")
        t = dt * np.arange(n)
        k, z = self.parameters(t)
        A = np.zeros((n, 2, 2))
        A[:, 0, 1] = 1.0
        A[:, 1, 0] = -w1 * w1
        A[:, 1, 1] = -2 * z * w1
        aug = np.zeros((n, 3, 3))
        aug[:, :2, :2] = A * dt
        aug[:, 1, 2] = dt
        E = expm_batched(aug)
        c, s = np.cos(self.phi), np.sin(self.phi)
        C = np.stack([-k * c * w1 * w1, k * (w1 * s - 2 * z * w1 * c)], axis=1)
        return E[:, :2, :2], E[:, :2, 2], C, k * c


@dataclass(frozen=True)
class LoopResponse:
    """Sampled error e_k of the loop and its time axis."""

    t: np.ndarray
    e: np.ndarray


def _ss(sys: control.LTI, dt: float) -> tuple[np.ndarray, ...]:
    ss = control.ss(sys)
    if ss.dt is None or not ss.dt or abs(float(ss.dt) - dt) > 1e-9 * dt:
        raise ServokitValueError(f"the discrete systems must all have dt = {dt:g} s")
    return tuple(np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C, ss.D))


def simulate_peak_filter_loop(
    plant_d: control.LTI,
    controller: control.LTI,
    flt: LtvPeakFilter | None,
    disturbance: np.ndarray,
) -> LoopResponse:
    """Error samples of ``u = C (1 + F) e``, ``e = −(y + d)``, (5.15)-(5.16) in discrete time.

    Parameters
    ----------
    plant_d : control.LTI
        Discrete plant (e.g. ``ModalPlant.discretize(dt)``), strictly proper.
    controller : control.LTI
        Discrete baseline controller C with the same ``dt``.
    flt : LtvPeakFilter or None
        The (LTV) peak filter; ``None`` runs the baseline loop.
    disturbance : numpy.ndarray
        Output disturbance d_k at the samples.

    Returns
    -------
    LoopResponse
        Times and error samples e_k.
    """
    dt = float(controller.dt)
    d = check_finite("disturbance", disturbance).ravel()
    n = check_count("len(disturbance)", d.size, lo=2)
    Ap, Bp, Cp, Dp = _ss(plant_d, dt)
    Ac, Bc, Cc, Dc = _ss(controller, dt)
    if abs(Dp[0, 0]) > 0:
        raise ServokitValueError("plant_d must be strictly proper (a sampled continuous plant)")
    xp, xc, xf = np.zeros(Ap.shape[0]), np.zeros(Ac.shape[0]), np.zeros(2)
    Fa, Fb, Fc, Fd = flt.discrete_matrices(dt, n) if flt is not None else (None,) * 4
    e = np.empty(n)
    for k in range(n):
        ek = -(Cp @ xp)[0] - d[k]
        v = ek
        if Fa is not None:
            v = ek + Fc[k] @ xf + Fd[k] * ek
            xf = Fa[k] @ xf + Fb[k] * ek
        u = (Cc @ xc)[0] + Dc[0, 0] * v
        xc = Ac @ xc + Bc[:, 0] * v
        xp = Ap @ xp + Bp[:, 0] * u
        e[k] = ek
    return LoopResponse(t=dt * np.arange(n), e=e)


def decay_time(resp: LoopResponse, freq_hz: float, level: float = 0.1) -> float:
    """Time after which the one-period envelope of |e| stays below ``level`` times its
    value over the first period (Fig. 5.25's transient, measured).

    Parameters
    ----------
    resp : LoopResponse
        A simulated error.
    freq_hz : float
        Disturbance frequency [Hz] (sets the envelope window).
    level : float
        Fraction of the initial envelope.

    Returns
    -------
    float
        The time [s]; ``inf`` if the envelope never settles below the level.
    """
    dt = resp.t[1] - resp.t[0]
    m = max(1, int(np.ceil(1.0 / (freq_hz * dt))))
    if resp.e.size < 2 * m:
        raise ServokitValueError("the response is shorter than two disturbance periods")
    env = np.array([np.max(np.abs(resp.e[i : i + m])) for i in range(resp.e.size - m + 1)])
    above = np.flatnonzero(env > level * env[0])
    if above.size and above[-1] == env.size - 1:
        return float("inf")
    return float(resp.t[above[-1] + 1]) if above.size else 0.0
