"""Adaptive non-model-based strain feedback with SSA (book §5.4.4, eqs. 5.70-5.78).

Plant: a PZT-actuated cantilever (Fig. 5.26) in modal form, ``n`` bending modes with
unit modal mass::

    q_i'' + 2 zeta_i w_i q_i' + w_i^2 q_i = b_i uM,   yM = sum c_i q_i,   f = sum g_i q_i,

``yM`` the arm displacement, ``f`` the SSA strain signal (root curvature, eq. 5.70).  The
energy balance (5.71)-(5.72) ``dE/dt = uM dyM/dt`` holds only for a collocated pair,
``b = c``, and an undamped structure; with modal damping servokit uses
``dE/dt = uM dyM/dt - sum 2 zeta_i w_i q_i'^2``.

Controller (5.73)-(5.75)::

    uM  = -kp yM - k0^2 int yM - Ys^2 f int f,          (ki = k0^2, kf = Ys^2)
    Ys' = alpha Ys yM' f int f - beta Ys,
    k0' = gamma k0 yM' int yM,

and the Lyapunov function (5.76)
``V = E + kp yM^2 / 2 + Ys^2 / (2 alpha) + k0^2 / (2 gamma)`` has (5.77)-(5.78)
``V' = -beta Ys^2 / alpha - sum 2 zeta_i w_i q_i'^2 <= 0``: the adaptation terms cancel
exactly, which :func:`simulate_adaptive` checks along the run.

The default beam uses the clamped-free mode shapes: tip participation ``c_i = 2 (-1)^(i+1)``
(normalised shapes) and root curvature ``g_i`` proportional to ``(beta_i L)^2`` =
1.875^2, 4.694^2, 7.855^2, with the first mode at 5.4 kHz as in Fig. 5.33 (the book's
higher modes are not those of a uniform beam; they are not reproduced).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError, check_positive

__all__ = ["BeamModel", "cantilever_beam", "AdaptiveGains", "AdaptiveRun", "simulate_adaptive"]

_BETA_L = np.array([1.8751, 4.6941, 7.8548, 10.9955])


@dataclass(frozen=True)
class BeamModel:
    """Modal PZT-actuated arm: frequencies [Hz], damping, collocated tip weights ``c`` (= b),
    strain weights ``g``."""

    freq_hz: np.ndarray
    damping: np.ndarray
    tip: np.ndarray
    strain: np.ndarray

    @property
    def omega(self) -> np.ndarray:
        return 2 * np.pi * np.asarray(self.freq_hz, dtype=float)


def cantilever_beam(n_modes: int = 3, first_hz: float = 5400.0, damping: float = 0.01) -> BeamModel:
    """Uniform clamped-free beam, ``n_modes`` <= 4 modes (see the module docstring).

    Parameters
    ----------
    n_modes : int
        Number of bending modes, 1 to 4.
    first_hz : float
        Frequency of the first mode [Hz] (5.4 kHz as in Fig. 5.33); mode ``i`` is at
        ``first_hz (beta_i L / beta_1 L)^2``.
    damping : float
        Modal damping ratio, the same for every mode.

    Returns
    -------
    BeamModel
        ``freq_hz`` [Hz], ``damping``, collocated tip weights ``tip = 2 (-1)^(i+1)`` (also
        the input weights ``b``) and root-curvature strain weights
        ``strain = (beta_i L / beta_1 L)^2`` (1 for the first mode).
    """
    if not 1 <= int(n_modes) <= 4:
        raise ServokitValueError(f"n_modes must be 1..4 (got {n_modes})")
    check_positive("first_hz", first_hz, "Hz")
    check_positive("damping", damping)
    bl = _BETA_L[: int(n_modes)]
    return BeamModel(
        freq_hz=first_hz * (bl / bl[0]) ** 2,
        damping=np.full(bl.size, float(damping)),
        tip=2.0 * (-1.0) ** np.arange(bl.size),
        strain=(bl / bl[0]) ** 2,
    )


@dataclass(frozen=True)
class AdaptiveGains:
    """Gains of (5.73)-(5.75): ``kp``, update rates ``alpha``, ``gamma``, leakage ``beta``
    and the initial adaptive gains ``ys0`` (``kf = Ys^2``) and ``k00`` (``ki = k0^2``)."""

    kp: float = 1.0e8
    alpha: float = 1.0e22
    beta: float = 200.0
    gamma: float = 1.0e16
    ys0: float = 1.0e4
    k00: float = 1.0e4
    adaptive: bool = True


@dataclass(frozen=True)
class AdaptiveRun:
    """Time history of one run: ``t`` [s], ``y`` (tip), ``u``, ``V`` (5.76), ``Ys``, ``k0``
    and ``dissipation`` = ``-V'`` predicted by (5.78) with modal damping."""

    t: np.ndarray
    y: np.ndarray
    u: np.ndarray
    V: np.ndarray
    Ys: np.ndarray
    k0: np.ndarray
    dissipation: np.ndarray

    def max_increase(self) -> float:
        """Largest step-to-step increase of ``V`` relative to ``V[0]`` (0 if none)."""
        return float(max(np.max(np.diff(self.V)), 0.0) / self.V[0])

    def amplitude_ratio(self, window: float = 0.1) -> float:
        """Peak |y| over the last ``window`` fraction of the run over that of the first."""
        k = max(int(window * self.t.size), 2)
        return float(np.abs(self.y[-k:]).max() / np.abs(self.y[:k]).max())


def _split(x: np.ndarray, n: int):
    return x[:n], x[n : 2 * n], x[2 * n], x[2 * n + 1], x[2 * n + 2], x[2 * n + 3]


def _control(beam: BeamModel, g: AdaptiveGains, x: np.ndarray) -> tuple[float, float, float]:
    """``uM`` of (5.73), ``yM`` and ``f`` at the state ``x`` (Python floats)."""
    n = beam.tip.size
    q = x[:n]
    y, f = float(beam.tip @ q), float(beam.strain @ q)
    iy, i_f, ys, k0 = x[2 * n : 2 * n + 4].tolist()
    kf = ys * ys if g.adaptive else 0.0
    return -g.kp * y - k0 * k0 * iy - kf * f * i_f, y, f


def _rhs(beam: BeamModel, g: AdaptiveGains):
    """The right-hand side of the modal equations with (5.73)-(5.75).

    The solver calls it some 30 000 times per run on a 10-state vector, where the fixed
    cost of each numpy operation (about 1 us) was most of the time: the weighted sums
    stay numpy dot products (their fused multiply-adds decide the last bit), everything
    else is the same arithmetic in the same order on Python floats (issue 24).
    """
    tip = beam.tip
    # 2 zeta w and w^2 per mode, formed as the numpy expression did: (2 z) w, w w
    zw2 = (2 * beam.damping * beam.omega).tolist()
    w2 = (beam.omega * beam.omega).tolist()
    n = tip.size
    tips = tip.tolist()

    def rhs(_t: float, x: np.ndarray) -> list[float]:
        u, y, f = _control(beam, g, x)
        yd = float(tip @ x[n : 2 * n])
        xs = x.tolist()
        q, qd, iy, i_f, ys, k0 = _split(xs, n)
        dys = g.alpha * ys * yd * f * i_f - g.beta * ys if g.adaptive else 0.0
        dk0 = g.gamma * k0 * yd * iy
        qdd = [c * u - a * v - b * p for c, a, v, b, p in zip(tips, zw2, qd, w2, q, strict=True)]
        return [*qd, *qdd, y, f, dys, dk0]

    return rhs


def lyapunov(beam: BeamModel, g: AdaptiveGains, x: np.ndarray) -> np.ndarray:
    """``V`` of (5.76) for states ``x`` (columns are time steps)."""
    n = beam.tip.size
    q, qd = x[:n], x[n : 2 * n]
    ys, k0 = x[2 * n + 2], x[2 * n + 3]
    energy = 0.5 * np.sum(qd**2 + (beam.omega[:, None] * q) ** 2, axis=0)
    y = beam.tip @ q
    adapt = 0.5 * ys**2 / g.alpha if g.adaptive else 0.0
    return energy + 0.5 * g.kp * y**2 + adapt + 0.5 * k0**2 / g.gamma


def simulate_adaptive(
    beam: BeamModel,
    gains: AdaptiveGains = AdaptiveGains(),
    *,
    tip0: float = 1.0e-6,
    duration: float = 5.0e-3,
    n_out: int = 4000,
    rtol: float = 1e-10,
) -> AdaptiveRun:
    """Free vibration from a static tip deflection ``tip0`` [m] under (5.73)-(5.75).

    Integrated by :func:`scipy.integrate.solve_ivp` (DOP853); ``V`` of (5.76) is
    evaluated on ``n_out`` output points.

    Parameters
    ----------
    beam : BeamModel
        Modal cantilever, e.g. from :func:`cantilever_beam`.
    gains : AdaptiveGains
        ``kp``, ``alpha``, ``beta``, ``gamma`` and the initial ``Ys``, ``k0``; with
        ``adaptive=False`` the strain term is off (``kf = 0``, ``Ys`` frozen) and only the
        PI part with adaptive ``k0`` acts.
    tip0 : float
        Initial static tip deflection [m] (non-zero; the modes start in the static shape
        under a tip load, at rest, with zero integrator states).
    duration : float
        Simulated time [s].
    n_out : int
        Number of output points, evenly spaced on ``[0, duration]``.
    rtol : float
        Relative tolerance of the integrator.

    Returns
    -------
    AdaptiveRun
        On the ``n_out`` points: ``t`` [s], tip displacement ``y`` [m], control ``u``
        (5.73), Lyapunov function ``V`` (5.76), adaptive gains ``Ys`` and ``k0``, and
        ``dissipation``, the ``-V'`` that (5.78) predicts with modal damping
        (``beta Ys^2 / alpha + sum 2 zeta_i w_i q_i'^2``, the first term only when
        ``gains.adaptive``).

    Raises
    ------
    ServokitValueError
        If the integration fails or gives non-finite values (gains too high).
    """
    check_positive("duration", duration, "s")
    check_positive("tip0", abs(tip0), "m")
    n = beam.tip.size
    # static shape under a tip load: q_i proportional to c_i / w_i^2, scaled to tip0
    shape = beam.tip / beam.omega**2
    x0 = np.concatenate(
        [tip0 * shape / (beam.tip @ shape), np.zeros(n), [0.0, 0.0, gains.ys0, gains.k00]]
    )
    t = np.linspace(0.0, duration, n_out)
    from scipy.integrate import solve_ivp

    sol = solve_ivp(
        _rhs(beam, gains),
        (0.0, duration),
        x0,
        method="DOP853",
        t_eval=t,
        rtol=rtol,
        atol=1e-14 * max(1.0, abs(tip0) * 1e6),
    )
    if not sol.success or not np.all(np.isfinite(sol.y)):
        raise ServokitValueError(f"the adaptive run failed ({sol.message}); lower the gains")
    u = np.array([_control(beam, gains, col)[0] for col in sol.y.T])
    ys, qd = sol.y[2 * n + 2], sol.y[n : 2 * n]
    damping = 2 * (beam.damping * beam.omega) @ qd**2
    leak = gains.beta * ys**2 / gains.alpha if gains.adaptive else 0.0 * ys
    v = lyapunov(beam, gains, sol.y)
    return AdaptiveRun(t, beam.tip @ sol.y[:n], u, v, ys, sol.y[2 * n + 3], leak + damping)
