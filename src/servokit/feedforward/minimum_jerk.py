"""Minimum-time (bang-bang) and minimum-jerk inputs for a rigid body (book §2.2.1-§2.2.3).

Implements

- the bang-bang minimum-time input (2.10) and its time ``Topt = 2 sqrt(r / umax)``;
- the continuous minimum-jerk input and trajectories (2.14)-(2.15)::

      p(t) = 60 r (tn^5/10 - tn^4/4 + tn^3/6),   v(t) = 30 r/T (tn^4 - 2 tn^3 + tn^2),
      a(t) = 60 r/T^2 (2 tn^3 - 3 tn^2 + tn) = 60 r/T^2 tn (2 tn - 1)(tn - 1),  tn = t/T;

- its digital implementation by sampling ``umjc(k tau)`` and holding it (Fig. 2.9) and
  the exact response of ``1/s^2`` to that held input (Fig. 2.10): the position is the
  double integral of a piecewise-constant signal, a piecewise quadratic evaluated
  exactly from the recursion (2.17).  When ``T = M tau`` the sampled minimum-jerk input
  is the order-3 sampled-data polynomial (2.24) divided by ``g`` of (2.25), so it stops
  at ``r (1 - 1/M^2)(1 - 4/M^2)`` with zero velocity (see ``tests/test_minimum_jerk.py``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitValueError, check_finite, check_positive
from servokit.feedforward.polynomial import rigid_body_zoh_states

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "RigidBodyTrajectory",
    "MinimumJerkZOHResponse",
    "bang_bang_time",
    "bang_bang_input",
    "bang_bang_trajectory",
    "minimum_jerk_input",
    "minimum_jerk_trajectory",
    "held_input_response",
    "minimum_jerk_zoh_response",
    "minimum_jerk_zoh_plot",
]


@dataclass(frozen=True)
class RigidBodyTrajectory:
    """Input and trajectory of the rigid body ``1/s^2`` on a time grid.

    Attributes
    ----------
    t : ndarray (Nt,)
        Time [s].
    position, velocity, acceleration : ndarray (Nt,)
        ``p(t)``, ``v(t)`` and the input ``a(t) = u(t)`` (target units, /s, /s^2).
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray


def bang_bang_time(target: float, u_max: float) -> float:
    """Minimum time ``Topt = 2 sqrt(|r| / umax)`` of the bang-bang input (2.10) [s].

    Parameters
    ----------
    target : float
        Target position ``r`` (either sign; only ``|r|`` matters).
    u_max : float
        Input (acceleration) limit ``umax`` > 0 [target units/s^2].

    Returns
    -------
    float
        ``Topt`` [s]; 0 for ``r = 0``.
    """
    r = float(check_finite("target", target))
    return 2.0 * np.sqrt(abs(r) / check_positive("u_max", u_max))


def bang_bang_input(t: float | np.ndarray, target: float, u_max: float) -> np.ndarray:
    """Bang-bang minimum-time input (2.10): ``+umax`` then ``-umax`` (sign of ``target``).

    Parameters
    ----------
    t : array_like
        Times [s].
    target : float
        Target position ``r``.
    u_max : float
        Input (acceleration) limit ``umax`` > 0.

    Returns
    -------
    ndarray, shape of ``t``
    """
    t = check_finite("t", t)
    t_opt = bang_bang_time(target, u_max)
    sign = np.sign(float(target))
    accelerating = (t >= 0) & (t < t_opt / 2)
    braking = (t >= t_opt / 2) & (t < t_opt)
    return np.where(accelerating, sign * u_max, np.where(braking, -sign * u_max, 0.0))


def bang_bang_trajectory(t: float | np.ndarray, target: float, u_max: float) -> RigidBodyTrajectory:
    """Closed-form position and velocity of ``1/s^2`` under the bang-bang input (2.10).

    Parameters
    ----------
    t : array_like
        Times [s].
    target : float
        Target position ``r``.
    u_max : float
        Input (acceleration) limit ``umax`` > 0.

    Returns
    -------
    RigidBodyTrajectory
        On ``t`` (as a 1-D array): position and velocity from rest, parabolic arcs meeting
        at ``Topt / 2``; at rest (0) before ``t = 0`` and at ``r`` after ``Topt``; the
        acceleration is :func:`bang_bang_input`.
    """
    t = np.atleast_1d(check_finite("t", t))
    t_opt = bang_bang_time(target, u_max)
    a = bang_bang_input(t, target, u_max)
    s = np.sign(float(target)) * u_max
    tc = np.clip(t, 0.0, t_opt)
    first = tc < t_opt / 2
    rest = t_opt - tc
    p = np.where(first, 0.5 * s * tc**2, float(target) - 0.5 * s * rest**2)
    v = np.where(first, s * tc, s * rest)
    return RigidBodyTrajectory(t=t, position=p, velocity=v, acceleration=a)


def minimum_jerk_input(t: float | np.ndarray, T: float, target: float) -> np.ndarray:
    """Minimum-jerk input ``umjc(t)`` of (2.14)-(2.15); zero outside ``[0, T]``.

    Parameters
    ----------
    t : array_like
        Times [s].
    T : float
        Final (move) time [s].
    target : float
        Target position ``r``.

    Returns
    -------
    ndarray, shape of ``t``
        ``umjc(t) = 60 r / T^2 tn (2 tn - 1)(tn - 1)`` with ``tn = t / T`` [target
        units/s^2].
    """
    t = check_finite("t", t)
    T = check_positive("T", T)
    tn = t / T
    u = 60.0 * float(target) / T**2 * tn * (2.0 * tn - 1.0) * (tn - 1.0)
    return np.where((tn >= 0) & (tn <= 1), u, 0.0)


def minimum_jerk_trajectory(t: float | np.ndarray, T: float, target: float) -> RigidBodyTrajectory:
    """Minimum-jerk position, velocity and acceleration of §2.2.2 (Fig. 2.8), at rest after T.

    Parameters
    ----------
    t : array_like
        Times [s].
    T : float
        Final (move) time [s], > 0.
    target : float
        Target position ``r``.

    Returns
    -------
    RigidBodyTrajectory
        On ``t`` (as a 1-D array): ``p(t)`` and ``v(t)`` of (2.14)-(2.15) (0 before
        ``t = 0``, ``r`` and 0 after ``T``) and the acceleration
        :func:`minimum_jerk_input`.
    """
    t = np.atleast_1d(check_finite("t", t))
    T = check_positive("T", T)
    r = float(target)
    tn = np.clip(t / T, 0.0, 1.0)
    p = 60.0 * r * (tn**5 / 10 - tn**4 / 4 + tn**3 / 6)
    v = 30.0 * r / T * (tn**4 - 2 * tn**3 + tn**2)
    return RigidBodyTrajectory(
        t=t, position=p, velocity=v, acceleration=minimum_jerk_input(t, T, r)
    )


def held_input_response(
    u: np.ndarray, dt: float, t: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Exact position and velocity of ``1/s^2`` from rest under held samples ``u`` (ZOH).

    The input is ``u[k]`` on ``[k dt, (k+1) dt)`` and 0 after the last sample, so the
    position is piecewise quadratic: ``p[k] + v[k] theta + u[k] theta^2 / 2`` with
    ``p[k], v[k]`` from the exact recursion (2.17).

    Parameters
    ----------
    u : ndarray (M,)
        Held samples.
    dt : float
        Hold period [s].
    t : array_like
        Times [s] at which the output is wanted (any, also between samples).

    Returns
    -------
    position, velocity : ndarray, shape of ``t``
    """
    u = check_finite("u", u).ravel()
    dt = check_positive("dt", dt)
    t = check_finite("t", t)
    p_s, v_s = rigid_body_zoh_states(u, dt)
    m = u.size
    k = np.clip(np.floor(t / dt).astype(int), 0, m)
    theta = np.maximum(t, 0.0) - k * dt
    uk = np.where(k < m, np.append(u, 0.0)[k], 0.0)
    pos = p_s[k] + v_s[k] * theta + 0.5 * uk * theta**2
    vel = v_s[k] + uk * theta
    return np.where(t > 0, pos, 0.0), np.where(t > 0, vel, 0.0)


@dataclass(frozen=True)
class MinimumJerkZOHResponse:
    """Rigid-body response to the sampled-and-held minimum-jerk input (Figs. 2.9-2.10).

    Attributes
    ----------
    T, target, tau : float
        Move time [s], target ``r`` and sampling period [s].
    u : ndarray (M,)
        Held samples ``umjc(k tau)``, ``k tau < T``.
    t, position, velocity : ndarray (Nt,)
        Exact output on the requested time grid.
    final_error : float
        ``y(T) - r`` (target units).
    final_velocity : float
        ``v(T)``; zero when ``T`` is a multiple of ``tau``.
    """

    T: float
    target: float
    tau: float
    u: np.ndarray
    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    final_error: float
    final_velocity: float


def minimum_jerk_zoh_response(
    T: float, target: float, tau: float, t: np.ndarray | None = None
) -> MinimumJerkZOHResponse:
    """Exact output of ``1/s^2`` driven by ``umjc(k tau)`` through a ZOH (Fig. 2.9, Fig. 2.10).

    Parameters
    ----------
    T : float
        Move time of the minimum-jerk input (2.14) [s].
    target : float
        Target position ``r``.
    tau : float
        Sampling period [s].
    t : ndarray, optional
        Output time grid [s]; default 0 to 1.2 T in 1201 points.

    Returns
    -------
    MinimumJerkZOHResponse
    """
    T = check_positive("T", T)
    tau = check_positive("tau", tau)
    r = float(check_finite("target", target))
    # samples k tau < T; the round-off guard keeps k tau == T (where umjc = 0) out
    m = int(np.ceil(T / tau - 1e-9))
    u = minimum_jerk_input(np.arange(m) * tau, T, r)
    grid = np.linspace(0.0, 1.2 * T, 1201) if t is None else np.asarray(t, dtype=float)
    pos, vel = held_input_response(u, tau, grid)
    p_end, v_end = held_input_response(u, tau, np.array([T]))
    return MinimumJerkZOHResponse(
        T=T,
        target=r,
        tau=tau,
        u=u,
        t=grid,
        position=pos,
        velocity=vel,
        final_error=float(p_end[0] - r),
        final_velocity=float(v_end[0]),
    )


def minimum_jerk_zoh_plot(responses: Sequence[MinimumJerkZOHResponse]) -> Figure:
    """Fig. 2.10: continuous minimum-jerk trajectory vs the outputs of its sampled versions.

    Parameters
    ----------
    responses : sequence of MinimumJerkZOHResponse
        At least one response of :func:`minimum_jerk_zoh_response`; the first one's
        ``T``, target and time grid set the continuous reference curve.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels: position (continuous and each sampled version, with its error at
        ``T``) and input (``umjc(t)`` and each held input) against time [s].  The caller
        saves and closes it.
    """
    import matplotlib.pyplot as plt

    if not responses:
        raise ServokitValueError("responses is empty; pass at least one minimum_jerk_zoh_response")
    fig, (ax_p, ax_u) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ref = responses[0]
    ideal = minimum_jerk_trajectory(ref.t, ref.T, ref.target)
    ax_p.plot(ideal.t, ideal.position, "k--", label="continuous umjc (2.14)")
    ax_u.plot(ideal.t, ideal.acceleration, "k--", label="umjc(t)")
    for res in responses:
        lbl = f"tau = {res.tau * 1e3:g} ms (error at T: {res.final_error:+.2e})"
        ax_p.plot(res.t, res.position, label=lbl)
        edges = np.arange(res.u.size + 1) * res.tau
        ax_u.stairs(res.u, edges, label=f"ZOH, tau = {res.tau * 1e3:g} ms")
    ax_p.set_ylabel("position y [target units]")
    ax_p.set_title("Minimum-jerk input through a ZOH (Fig. 2.10)")
    ax_p.legend(fontsize=8)
    ax_p.grid(True, alpha=0.3)
    ax_u.set_xlabel("time [s]")
    ax_u.set_ylabel("input u [units/s$^2$]")
    ax_u.legend(fontsize=8)
    ax_u.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig
