"""Loops of the structure the book uses in §3.3 (its loops are not printed in full).

The book's HDD simulations (§3.3.1 Fig. 3.7, §3.3.2) use a second-order mechanical model
with the delay as a first-order Padé factor, under a zero-order hold, and a second-order
lead-lag controller; only the closed-loop poles and some zeros are printed. This module
builds that structure with the unknowns explicit:

- :func:`pade_double_integrator`: ``g / s^2 * (1 - s Td/2) / (1 + s Td/2)`` discretised
  exactly (ZOH), with the physical states ``[position, velocity, Padé state]``. Its two
  discrete zeros depend only on ``Td / dt``; :func:`fit_delay_ratio` recovers that ratio
  from printed plant zeros.
- :func:`place_controller`: the controller ``Nc / Dc`` of order m whose closed loop has the
  given poles, from the Diophantine equation ``Dp Dc + Np Nc = prod (z - p_i)`` (linear in
  the controller coefficients: n + m equations, 2m + 1 unknowns, square for m = n - 1).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_positive

__all__ = ["pade_double_integrator", "fit_delay_ratio", "place_controller", "lead_lag", "notch"]


def pade_double_integrator(
    dt: float, delay: float, gain: float = 1.0, damping: float = 0.0
) -> control.StateSpace:
    """ZOH discretisation of ``gain / s^2`` behind a first-order Padé delay.

    With ``damping = b > 0`` the mechanics is ``gain / (s (s + b))`` (viscous friction or
    a velocity loop: the rigid-body pole moves from 0 to -b).

    States ``[position, velocity, w]`` where ``w`` is the Padé state
    (``Td/2 w' = u - w``, delayed input ``2 w - u``): ``w = 0`` means no stored input.

    Parameters
    ----------
    dt : float
        Sampling period [s].
    delay : float
        Delay Td approximated by Padé [s] (> 0).
    gain : float
        Acceleration per unit input (e.g. [m/s^2/A]).
    damping : float
        Velocity damping ``b`` [1/s] of ``gain / (s (s + b))``; 0 is the double integrator.

    Returns
    -------
    control.StateSpace
        Discrete plant with states [position, velocity, Padé state].
    """
    dt = check_positive("dt", dt, "s")
    td = check_positive("delay", delay, "s")
    a = np.array([[0.0, 1.0, 0.0], [0.0, -damping, 2.0 * gain], [0.0, 0.0, -2.0 / td]])
    b = np.array([[0.0], [-gain], [2.0 / td]])
    c = np.array([[1.0, 0.0, 0.0]])
    return control.c2d(control.ss(a, b, c, 0), dt, "zoh")


def fit_delay_ratio(zeros: Sequence[float]) -> float:
    """``Td / dt`` whose discrete Padé double integrator has the printed ``zeros``.

    Fits in the bilinear coordinate ``(z - 1) / (z + 1)`` so a large zero (e.g. -56.79)
    and a small one weigh alike.

    Parameters
    ----------
    zeros : sequence of float
        The two discrete zeros of the plant (e.g. -56.79, -0.235).

    Returns
    -------
    float
        The fitted Td/dt.
    """
    target = np.sort(np.asarray(zeros, dtype=float))
    if target.size != 2:
        raise ServokitValueError("zeros must hold the plant's two discrete zeros")

    def miss(ratio: float) -> float:
        z = np.sort(np.real(control.zeros(pade_double_integrator(1.0, ratio))))
        return float(np.sum(((z - 1) / (z + 1) - (target - 1) / (target + 1)) ** 2))

    from scipy.optimize import minimize_scalar

    res = minimize_scalar(miss, bounds=(0.05, 0.99), method="bounded", options={"xatol": 1e-12})
    return float(res.x)


def place_controller(
    plant_d: control.StateSpace,
    poles: Sequence[complex],
    order: int = 2,
    fixed_poles: Sequence[complex] = (),
) -> control.TransferFunction:
    """Controller ``Nc/Dc`` of ``order`` placing the closed-loop poles (Diophantine equation).

    The loop is ``u = C (r - y)``, so the characteristic polynomial is
    ``Dp Dc + Np Nc`` (monic). ``Dc = F Dc'`` with the ``fixed_poles`` in F (e.g. an
    integrator at z = 1). Needs ``len(poles) == n + order`` and a unique solution
    (``order = n - 1 + len(fixed_poles)`` for coprime Np, Dp).

    Parameters
    ----------
    plant_d : control.StateSpace
        Discrete SISO plant.
    poles : sequence of complex
        The n + order closed-loop poles (conjugate pairs complete).
    order : int
        Controller order.
    fixed_poles : sequence of complex
        Controller poles imposed (e.g. an integrator at 1).

    Returns
    -------
    control.TransferFunction
        The controller Nc/Dc.
    """
    tf = control.ss2tf(plant_d)
    dp = np.asarray(tf.den[0][0], dtype=float)
    npoly = np.asarray(tf.num[0][0], dtype=float) / dp[0]
    dp = dp / dp[0]
    n = len(dp) - 1
    poles = np.asarray(poles, dtype=complex)
    if poles.size != n + order:
        raise ServokitValueError(
            f"give {n + order} closed-loop poles (n + order), got {poles.size}"
        )
    fixed = np.atleast_1d(np.real(np.poly(np.asarray(fixed_poles, dtype=complex))))
    free = order - (len(fixed) - 1)  # degree of Dc'
    dpf = np.convolve(dp, fixed)
    target = np.real(np.poly(poles))
    npoly = np.concatenate([np.zeros(n + 1 - len(npoly)), npoly])
    # unknowns: Dc' = z^free + c1 z^(free-1) + ... ; Nc = b0 z^order + ... + b_order
    cols = [np.convolve(dpf, np.eye(free + 1)[j]) for j in range(1, free + 1)]
    cols += [np.convolve(npoly, np.eye(order + 1)[j]) for j in range(order + 1)]
    M = np.array(cols).T[1:]
    rhs = (target - np.convolve(dpf, np.eye(free + 1)[0]))[1:]
    if M.shape[0] != M.shape[1] or np.linalg.matrix_rank(M) < M.shape[1]:
        raise ServokitValueError(
            "the poles do not fix the controller uniquely; use order = n - 1 + len(fixed_poles)"
        )
    sol = np.linalg.solve(M, rhs)
    den = np.convolve(fixed, np.concatenate([[1.0], sol[:free]]))
    return control.tf(sol[free:], den, plant_d.dt)


def lead_lag(
    plant_d: control.StateSpace, crossover_hz: float, lead_ratio: float = 3.0, *, lag: bool = True
) -> control.TransferFunction:
    """A second-order lead-lag controller with its gain crossover at ``crossover_hz``.

    Lead: zero at fc/r, pole at r fc with r = ``lead_ratio`` (53 deg of lead at fc for
    r = 3); lag: zero at fc/5, pole at fc/50 (integral-like gain at low frequency).
    Discretised by Tustin at the plant's dt; the gain puts ``|P C| = 1`` at fc with the
    exact discrete ``P``.

    Parameters
    ----------
    plant_d : control.StateSpace
        Discrete plant (sets dt and the gain normalisation).
    crossover_hz : float
        Gain crossover [Hz].
    lead_ratio : float
        Ratio r of the lead pole and zero to the crossover.
    lag : bool
        Include the lag pair (fc/5, fc/50).

    Returns
    -------
    control.TransferFunction
        The discrete controller.
    """
    fc = check_positive("crossover_hz", crossover_hz, "Hz")
    dt = float(plant_d.dt)
    if fc >= 0.5 / dt / 3:
        raise ServokitValueError(
            f"crossover_hz must be below a third of Nyquist ({0.5 / dt / 3:g} Hz)"
        )
    w = 2 * np.pi * fc
    s = control.tf("s")
    r = check_positive("lead_ratio", lead_ratio)
    shape = (s / (w / r) + 1) / (s / (r * w) + 1)
    if lag:  # without it: a first-order lead only (a PD with roll-off)
        shape = shape * (s / (w / 5) + 1) / (s / (w / 50) + 1)
    c = control.c2d(shape, dt, "tustin")
    z = np.exp(1j * w * dt)
    mag = abs(complex(control.evalfr(control.ss2tf(plant_d), z) * control.evalfr(c, z)))
    return c / mag


def notch(
    dt: float, freq_hz: float, zeta_zero: float, zeta_pole: float
) -> control.TransferFunction:
    """Discrete notch ``(s^2 + 2 zz w s + w^2)/(s^2 + 2 zp w s + w^2)`` (Tustin, prewarped).

    Parameters
    ----------
    dt : float
        Sampling period [s].
    freq_hz : float
        Notch frequency [Hz].
    zeta_zero, zeta_pole : float
        Damping of the zeros (depth) and of the poles (width).

    Returns
    -------
    control.TransferFunction
        The discrete notch (unit gain away from freq_hz).
    """
    w = 2 * np.pi * check_positive("freq_hz", freq_hz, "Hz")
    s = control.tf("s")
    cont = (s**2 + 2 * zeta_zero * w * s + w**2) / (s**2 + 2 * zeta_pole * w * s + w**2)
    return control.c2d(cont, check_positive("dt", dt, "s"), "tustin", prewarp_frequency=w)


def ipd_controller(
    dt: float,
    gain: float,
    bandwidth_hz: float,
    *,
    damping: float = 0.7,
    derivative_hz: float = 10e3,
    filters: control.TransferFunction | None = None,
) -> tuple[control.StateSpace, np.ndarray, np.ndarray]:
    """I-PD controller for ``gain / s^2``: integral on ``r - y``, P and D on ``-y`` only.

    The gains place the rigid-body loop ``s^3 + g Kd s^2 + g Kp s + g Ki`` at
    ``(s + w)(s^2 + 2 zeta w s + w^2)``, ``w = 2 pi bandwidth_hz``; the derivative is
    filtered at ``derivative_hz``; ``filters`` (e.g. notches) act on the output.
    Discretised by Tustin (the integrator by forward Euler, so r and y enter it alike).

    Returns
    -------
    (feedback, Bcr, Dcr)
        ``feedback``: the controller from ``-y`` to u (for :func:`switched_loop`);
        ``Bcr``, ``Dcr``: its reference path (for ``SwitchedLoop(..., Bcr=, Dcr=)``).
    """
    g = check_positive("gain", gain)
    w = 2 * np.pi * check_positive("bandwidth_hz", bandwidth_hz, "Hz")
    kd, kp, ki = (2 * damping * w + w) / g, (w**2 + 2 * damping * w**2) / g, w**3 / g
    s = control.tf("s")
    pd = control.ss(control.c2d(kp + kd * s / (s / (2 * np.pi * derivative_hz) + 1), dt, "tustin"))
    # v = xi - PD(y), xi+ = xi + ki dt (r - y): states [xi; xd], inputs (r, y)
    Ad, Bd, Cd, Dd = (np.asarray(M, dtype=float) for M in (pd.A, pd.B, pd.C, pd.D))
    nd = Ad.shape[0]
    A = np.block([[np.ones((1, 1)), np.zeros((1, nd))], [np.zeros((nd, 1)), Ad]])
    B = np.block([[np.array([[ki * dt, -ki * dt]])], [np.zeros((nd, 1)), Bd]])
    C = np.hstack([np.ones((1, 1)), -Cd])
    D = np.array([[0.0, -Dd[0, 0]]])
    if filters is not None:  # u = F v, in series
        f = control.ss(filters)
        Af, Bf, Cf, Df = (np.asarray(M, dtype=float) for M in (f.A, f.B, f.C, f.D))
        nf = Af.shape[0]
        A = np.block([[A, np.zeros((A.shape[0], nf))], [Bf @ C, Af]])
        B = np.vstack([B, Bf @ D])
        C = np.hstack([Df @ C, Cf])
        D = Df @ D
    # feedback part in the (3.13) form (driven by r - y, here by -y): Bc = -B_y, Dc = -D_y
    fb_neg = control.ss(A, -B[:, [1]], C, -D[:, [1]], dt)
    return fb_neg, B[:, [0]], D[:, [0]]
