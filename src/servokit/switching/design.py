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

Each builder has a ``*_data`` twin returning servokit's numpy LTI data
(:class:`~servokit.models.rational.StateSpaceData`, :class:`~servokit.models.rational.RationalTF`)
with python-control's arithmetic reproduced bit for bit (``c2d`` ZOH, ``ss2tf``, transfer
function algebra, Tustin), so the switching commands start without importing
python-control (issue 23); the python-control versions convert those.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_positive
from servokit.models.rational import RationalTF, StateSpaceData, as_state_space_data

__all__ = [
    "pade_double_integrator",
    "pade_double_integrator_data",
    "fit_delay_ratio",
    "place_controller",
    "place_controller_data",
    "lead_lag",
    "lead_lag_data",
    "notch",
]


def pade_double_integrator(
    dt: float, delay: float, gain: float = 1.0, damping: float = 0.0
) -> control.StateSpace:
    """ZOH discretisation of ``gain / s^2`` behind a first-order Padé delay.

    Parameters
    ----------
    dt, delay, gain, damping
        As :func:`pade_double_integrator_data`.

    Returns
    -------
    control.StateSpace
        Discrete plant with states [position, velocity, Padé state].
    """
    return pade_double_integrator_data(dt, delay, gain, damping).to_control()


def pade_double_integrator_data(
    dt: float, delay: float, gain: float = 1.0, damping: float = 0.0
) -> StateSpaceData:
    """ZOH discretisation of ``gain / s^2`` behind a first-order Padé delay, as numpy arrays
    (:func:`pade_double_integrator` without python-control).

    With ``damping = b > 0`` the mechanics is ``gain / (s (s + b))`` (viscous friction or
    a velocity loop: the rigid-body pole moves from 0 to -b).

    States ``[position, velocity, w]`` where ``w`` is the Padé state
    (``Td/2 w' = u - w``, delayed input ``2 w - u``): ``w = 0`` means no stored input.
    The ZOH is ``expm([[A, B], [0, 0]] dt)`` (:func:`~servokit.models._zoh.zoh_pair`), the
    arithmetic of python-control's ``c2d(sys, dt, "zoh")``: the same matrices bit for bit.

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
    StateSpaceData
        Discrete plant with states [position, velocity, Padé state].
    """
    from servokit.models._zoh import zoh_pair

    dt = check_positive("dt", dt, "s")
    td = check_positive("delay", delay, "s")
    a = np.array([[0.0, 1.0, 0.0], [0.0, -damping, 2.0 * gain], [0.0, 0.0, -2.0 / td]])
    b = np.array([[0.0], [-gain], [2.0 / td]])
    c = np.array([[1.0, 0.0, 0.0]])
    phi, gam = zoh_pair(a, b, dt)
    return StateSpaceData(phi, gam, c, np.zeros((1, 1)), dt)


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
        z = np.sort(np.real(pade_double_integrator_data(1.0, ratio).zeros()))
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

    Parameters
    ----------
    plant_d, poles, order, fixed_poles
        As :func:`place_controller_data`.

    Returns
    -------
    control.TransferFunction
        :func:`place_controller_data`'s controller, converted.
    """
    return place_controller_data(plant_d, poles, order, fixed_poles).to_control()


def _ss2tf(plant_d: object) -> RationalTF:
    """A SISO state space as coefficients: ``den = det(zI - A)``,
    ``num = det(zI - A + B C) + (D - 1) den`` (SciPy's ``ss2tf``, which python-control
    calls without slycot: the same coefficients bit for bit)."""
    ss = as_state_space_data(plant_d)
    den = np.poly(ss.A)
    num = np.poly(ss.A - ss.B @ ss.C[:1]) + (ss.D[0, 0] - 1.0) * den
    return RationalTF(num, den, ss.dt)


def place_controller_data(
    plant_d: object,
    poles: Sequence[complex],
    order: int = 2,
    fixed_poles: Sequence[complex] = (),
) -> RationalTF:
    """:func:`place_controller` as numpy coefficients (python-control left unloaded).

    The loop is ``u = C (r - y)``, so the characteristic polynomial is
    ``Dp Dc + Np Nc`` (monic). ``Dc = F Dc'`` with the ``fixed_poles`` in F (e.g. an
    integrator at z = 1). Needs ``len(poles) == n + order`` and a unique solution
    (``order = n - 1 + len(fixed_poles)`` for coprime Np, Dp).

    Parameters
    ----------
    plant_d : StateSpaceData or control.StateSpace
        Discrete SISO plant.
    poles : sequence of complex
        The n + order closed-loop poles (conjugate pairs complete).
    order : int
        Controller order.
    fixed_poles : sequence of complex
        Controller poles imposed (e.g. an integrator at 1).

    Returns
    -------
    RationalTF
        The controller Nc/Dc at the plant's period.
    """
    tf = _ss2tf(plant_d)
    dp = tf.denominator
    npoly = tf.numerator / dp[0]
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
    return RationalTF(sol[free:], den, tf.dt)


def lead_lag(
    plant_d: control.StateSpace, crossover_hz: float, lead_ratio: float = 3.0, *, lag: bool = True
) -> control.TransferFunction:
    """A second-order lead-lag controller with its gain crossover at ``crossover_hz``.

    Parameters
    ----------
    plant_d, crossover_hz, lead_ratio, lag
        As :func:`lead_lag_data`.

    Returns
    -------
    control.TransferFunction
        :func:`lead_lag_data`'s controller, converted.
    """
    return lead_lag_data(plant_d, crossover_hz, lead_ratio, lag=lag).to_control()


def _corner(w: float) -> RationalTF:
    """``s / w + 1`` as python-control's ``tf("s") / w + 1`` computes it (``[1, w] / [w]``)."""
    return RationalTF([1.0, 0.0], [1.0]) * RationalTF([1.0], [w]) + 1.0


def _over(a: RationalTF, b: RationalTF) -> RationalTF:
    """``a / b`` with python-control's coefficients (``num_a den_b / (den_a num_b)``)."""
    return a * RationalTF(b.denominator, b.numerator, b.dt)


def lead_lag_data(
    plant_d: object, crossover_hz: float, lead_ratio: float = 3.0, *, lag: bool = True
) -> RationalTF:
    """:func:`lead_lag` as numpy coefficients (python-control left unloaded).

    Lead: zero at fc/r, pole at r fc with r = ``lead_ratio`` (53 deg of lead at fc for
    r = 3); lag: zero at fc/5, pole at fc/50 (integral-like gain at low frequency).
    Discretised by Tustin at the plant's dt; the gain puts ``|P C| = 1`` at fc with the
    exact discrete ``P``.

    Parameters
    ----------
    plant_d : StateSpaceData or control.StateSpace
        Discrete plant (sets dt and the gain normalisation).
    crossover_hz : float
        Gain crossover [Hz].
    lead_ratio : float
        Ratio r of the lead pole and zero to the crossover.
    lag : bool
        Include the lag pair (fc/5, fc/50).

    Returns
    -------
    RationalTF
        The discrete controller.
    """
    fc = check_positive("crossover_hz", crossover_hz, "Hz")
    plant = _ss2tf(plant_d)
    dt = plant.dt
    if fc >= 0.5 / dt / 3:
        raise ServokitValueError(
            f"crossover_hz must be below a third of Nyquist ({0.5 / dt / 3:g} Hz)"
        )
    w = 2 * np.pi * fc
    r = check_positive("lead_ratio", lead_ratio)
    # the coefficient arithmetic of python-control's (s/(w/r) + 1)/(s/(r w) + 1) ..., so
    # the controller (and the IVC gains on its states) are the same bit for bit
    shape = _over(_corner(w / r), _corner(r * w))
    if lag:  # without it: a first-order lead only (a PD with roll-off)
        shape = _over(shape * _corner(w / 5), _corner(w / 50))
    c = shape.tustin(dt)
    z = np.exp(1j * w * dt)
    mag = abs(complex(plant(z) * c(z)))
    return RationalTF(c.numerator, c.denominator * mag, dt)


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
