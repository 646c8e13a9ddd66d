"""Limits on positioning accuracy (book §6.1.1 and §6.3.1.4, eqs. 6.13-6.16).

Output variance (6.13): with the disturbances lumped into a shaping filter ``D`` driven by
unit white noise, ``var(y) = (1/pi) int_0^W |S D|^2 dw`` with ``W = inf`` for a continuous
loop, and ``W = pi/T`` in ``phi = w T`` units for a discrete one (the same derivation holds
on ``[0, pi]`` because the discrete Bode integral of a strictly proper loop is 0, 6.19).

Lower bound (6.16), derived here because the printed form is ambiguous and, as printed,
not a bound.  With ``|L| <= delta (Omega/w)^(k+1)`` for ``w >= Omega`` (6.14) and ``delta < 1``:

* ``[Omega, W]``: (6.15) gives ``|S| >= 1/(1 + delta (Omega/w)^(k+1))``, so
  ``(1/pi) int_Omega^W |D|^2 / (1 + delta (Omega/w)^(k+1))^2 dw``.  The book's exponent
  ``ke`` (k or k+1 by parity) only weakens this, since ``(Omega/w)^k >= (Omega/w)^(k+1)``;
  servokit uses ``k + 1`` directly from (6.15).
* ``[0, Omega]``: Jensen's inequality gives ``(1/Omega) int |SD|^2 >= exp((1/Omega) int
  ln|SD|^2) = exp(beta + (2/Omega) int_0^Omega ln|S|)``, and the Bode integral (= 0)
  with (6.15) gives ``int_0^Omega ln|S| = -int_Omega^W ln|S| >= -Omega gamma`` where
  ``gamma = (1/Omega) int_Omega^W -ln(1 - delta (Omega/w)^(k+1)) dw``.  Hence
  **(Omega/pi) e^(beta - 2 gamma)**: the printed ``e^beta`` drops the factor
  ``e^(-2 gamma)`` (for delta = 0.5, k = 1, ``e^(-2 gamma) = 0.55``) and can exceed the
  true variance.  ``beta = (1/Omega) int_0^Omega ln|D|^2 dw`` as printed.

Dynamic range (§6.1.1): positioning accuracy divided by actuator stroke (about 1e-7 for a
recent HDD, Fig. 6.1).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from servokit._lazy import scipy_integrate as integrate
from servokit.errors import ServokitTypeError, ServokitValueError, check_count, check_positive
from servokit.limits.rational import RationalLoop

if TYPE_CHECKING:
    import control

__all__ = [
    "VarianceComparison",
    "variance_against_bound",
    "VarianceBound",
    "dynamic_range",
    "output_variance",
    "rolloff_bandwidth",
    "variance_lower_bound",
]

Response = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class VarianceBound:
    """Lower bound of ``var(y)`` (6.16) and its parts.

    Attributes
    ----------
    bound : float
        ``low + high`` (the corrected bound).
    low, high : float
        Contributions of ``[0, Omega]`` and ``[Omega, W]``.
    beta, gamma : float
        ``beta`` of (6.16) and the waterbed term ``gamma`` derived in the module docstring.
    printed : float
        The book's expression as printed: ``(Omega/pi) e^beta`` plus the ``ke`` tail.
    """

    bound: float
    low: float
    high: float
    beta: float
    gamma: float
    printed: float


def _response(system: object, dt: float | None) -> Response:
    """``w [rad/s] -> complex response`` of an LTI object or a ``freq_hz`` callable."""
    if isinstance(system, RationalLoop) or _is_lti(system):
        if system.isdtime() != (dt is not None):
            raise ServokitValueError(
                "disturbance and loop must both be continuous or both discrete (same dt)"
            )
        evaluate = _evaluator(system)
        if dt is None:
            return lambda w: np.asarray(evaluate(1j * np.asarray(w)), dtype=complex)
        return lambda w: np.asarray(evaluate(np.exp(1j * np.asarray(w) * dt)), dtype=complex)
    if callable(system):
        return lambda w: np.asarray(system(np.asarray(w) / (2 * np.pi)), dtype=complex)
    raise ServokitTypeError(
        "expected a RationalLoop, a python-control LTI object or a callable of freq_hz, "
        f"got {type(system).__name__}"
    )


def _evaluator(system: object) -> Callable[[np.ndarray], np.ndarray]:
    """``x -> system(x)``: a RationalLoop evaluates itself (numpy); a python-control object
    through :func:`~servokit.models.lti_response.lti_response` (vectorised, same values)."""
    if isinstance(system, RationalLoop):
        return system
    from servokit.models.lti_response import lti_response

    return lambda x: lti_response(system, x)


def _is_lti(system: object) -> bool:
    """A python-control LTI object (python-control is imported only if it already is)."""
    control = sys.modules.get("control")
    return control is not None and isinstance(system, control.TransferFunction | control.StateSpace)


def _closed_loop_poles(loop: object) -> np.ndarray:
    """Poles of unity negative feedback around ``loop``."""
    if isinstance(loop, RationalLoop):
        return loop.closed_loop_poles()
    import control

    return np.asarray(control.feedback(loop, 1).poles())


def _upper(dt: float | None) -> float:
    return np.inf if dt is None else np.pi / dt


def _quad(f: Callable[[float], float], a: float, b: float, points: list[float]) -> float:
    inner = [p for p in sorted(points) if a < p < b] if np.isfinite(b) else None
    val, _ = integrate.quad(f, a, b, limit=1000, points=inner or None)
    return float(val)


def _gamma(delta: float, k: int, omega: float, w_max: float) -> float:
    x_max = w_max / omega
    val, _ = integrate.quad(lambda x: -np.log1p(-delta * x ** (-(k + 1))), 1.0, x_max, limit=500)
    return float(val)


def variance_lower_bound(
    disturbance: object,
    bandwidth_hz: float,
    *,
    delta: float = 0.5,
    k: int = 1,
    dt: float | None = None,
    breakpoints_hz: tuple[float, ...] = (),
) -> VarianceBound:
    """Lower bound (6.16), corrected, of the output variance for a loop meeting (6.14).

    Parameters
    ----------
    disturbance : RationalLoop, LTI or callable
        Shaping filter ``D`` of unit-intensity white noise (continuous, or discrete with
        ``dt`` and unit-variance white input), or a callable ``freq_hz -> D``.
    bandwidth_hz : float
        ``Omega / (2 pi)`` of (6.14) [Hz].
    delta, k : float, int
        Roll-off constants of (6.14): ``0 < delta < 1``, ``k >= 1``.
    dt : float, optional
        Sampling period [s] of a discrete loop; integrals then stop at Nyquist.
    breakpoints_hz : tuple of float
        Frequencies of sharp disturbance peaks, to guide the quadrature [Hz].

    Returns
    -------
    VarianceBound
    """
    f_b = check_positive("bandwidth_hz", bandwidth_hz, "Hz")
    d = check_positive("delta", delta)
    if d >= 1:
        raise ServokitValueError(f"delta must be < 1 (got {d}); the book uses delta < 0.5")
    kk = check_count("k", k, lo=1, hi=50)
    resp = _response(disturbance, dt)
    omega, w_max = 2 * np.pi * f_b, _upper(dt)
    if omega >= w_max:
        raise ServokitValueError(f"bandwidth_hz ({f_b:g}) must be below the Nyquist frequency")
    pts = [2 * np.pi * f for f in breakpoints_hz]
    scale = 1.0 if dt is None else dt  # phi = w T for a discrete loop

    def mag2(w: float) -> float:
        return float(np.abs(resp(np.array([w]))[0]) ** 2)

    beta = _quad(lambda w: np.log(mag2(w)), 0.0, omega, pts) / omega
    gamma = _gamma(d, kk, omega, w_max)
    low = scale * omega / np.pi * np.exp(beta - 2.0 * gamma)

    def tail(power: int) -> float:
        return (scale / np.pi) * _quad(
            lambda w: mag2(w) / (1.0 + d * (omega / w) ** power) ** 2, omega, w_max, pts
        )

    high = tail(kk + 1)
    ke = kk + 1 if kk % 2 else kk
    # for odd k the printed exponent is k + 1: the same quadrature, not done twice
    printed = scale * omega / np.pi * np.exp(beta) + (high if ke == kk + 1 else tail(ke))
    return VarianceBound(low + high, low, high, beta, gamma, printed)


def output_variance(
    loop: RationalLoop | control.TransferFunction | control.StateSpace,
    disturbance: object,
    *,
    breakpoints_hz: tuple[float, ...] = (),
) -> float:
    """``var(y) = (1/pi) int_0^W |S D|^2 dw`` (6.13) by quadrature.

    ``loop`` and ``disturbance`` are both continuous, or both discrete with the loop's
    ``dt`` (unit-variance white input; the integral then runs over ``phi`` in ``[0, pi]``).

    Parameters
    ----------
    loop : RationalLoop or LTI
        Open loop ``L``.
    disturbance : RationalLoop, LTI or callable
        Shaping filter ``D`` or ``freq_hz -> D``.
    breakpoints_hz : tuple of float
        Sharp peaks, to guide the quadrature [Hz].

    Returns
    -------
    float
        ``var(y)`` [output unit^2].
    """
    dt = float(loop.dt) if loop.isdtime() else None
    d_resp, l_resp = _response(disturbance, dt), _response(loop, dt)
    scale = 1.0 if dt is None else dt
    pts = [2 * np.pi * f for f in breakpoints_hz]

    def integrand(w: float) -> float:
        x = np.array([w])
        return float(np.abs(d_resp(x)[0] / (1.0 + l_resp(x)[0])) ** 2)

    return scale / np.pi * _quad(integrand, 0.0, _upper(dt), pts)


def rolloff_bandwidth(
    loop: RationalLoop | control.TransferFunction | control.StateSpace,
    *,
    delta: float = 0.5,
    k: int = 1,
    n_freq: int = 20_000,
) -> float:
    """Smallest ``Omega`` [Hz] with ``|L(jw)| <= delta (Omega/w)^(k+1)`` for all ``w >= Omega``.

    On a logarithmic grid: with ``g(w) = w (|L|/delta)^(1/(k+1))`` the condition reads
    ``sup_{w >= Omega} g <= Omega``, so ``Omega = min_i max(w_i, max_{j >= i} g_j)``.
    The tail maximum ``T_i = max_{j >= i} g_j`` does not increase with ``i`` and ``w_i``
    increases, so once a suffix ``i >= s`` of the grid has ``T_s >= w_s``, every term
    before it is ``>= T_s`` and the minimum lies in the suffix: ``|L|`` is evaluated on
    suffixes of 1/16, 1/8, ... of the grid until one holds the minimum (each point is its
    own solve, so the value is that of the whole grid; only a NaN response before the
    suffix, which the whole grid would return as NaN, is not seen).

    Parameters
    ----------
    loop : RationalLoop or LTI
        Open loop ``L`` (continuous or discrete).
    delta, k : float, int
        Constants of (6.14).
    n_freq : int
        Grid points.

    Returns
    -------
    float
        ``Omega / (2 pi)`` [Hz].
    """
    d = check_positive("delta", delta)
    kk = check_count("k", k, lo=1, hi=50)
    n = check_count("n_freq", n_freq, lo=100, hi=10_000_000)
    dt = float(loop.dt) if loop.isdtime() else None
    resp = _response(loop, dt)
    top = np.pi / dt if dt else 1e3 * max(1.0, float(np.max(np.abs(loop.poles()))))
    w = np.geomspace(top * 1e-8, top * (1 - 1e-9), n)
    g = np.empty(n)
    lo = n
    for start in (n - n // 16, n - n // 8, n - n // 4, n - n // 2, 0):
        g[start:lo] = w[start:lo] * (np.abs(resp(w[start:lo])) / d) ** (1.0 / (kk + 1))
        lo = start
        tail_max = np.maximum.accumulate(g[lo:][::-1])[::-1]
        if lo == 0 or tail_max[0] >= w[lo]:
            break
    return float(np.min(np.maximum(w[lo:], tail_max)) / (2 * np.pi))


@dataclass(frozen=True)
class VarianceComparison:
    """The output variance (6.13) beside its lower bound (6.16); see
    :func:`variance_against_bound`."""

    bandwidth_hz: float  #: roll-off bandwidth Omega of (6.14) [Hz]
    variance: float  #: var(y) of (6.13) [output unit^2]
    bound: VarianceBound  #: the corrected bound and the printed form


def variance_against_bound(
    loop: RationalLoop | control.TransferFunction | control.StateSpace,
    disturbance: RationalLoop | control.TransferFunction | control.StateSpace,
    *,
    delta: float = 0.5,
    k: int = 1,
    started: Callable[[str], None] | None = None,
) -> VarianceComparison:
    """The roll-off bandwidth of ``loop``, the output variance under ``disturbance`` and its
    lower bound, (6.13)-(6.16).

    Parameters
    ----------
    loop : RationalLoop or LTI
        Open loop ``L`` (continuous, or discrete with its ``dt``).
    disturbance : RationalLoop or LTI
        Shaping filter ``D`` of unit-variance white noise, with the loop's time base.
    delta, k : float, int
        Roll-off constants of (6.14).
    started : callable, optional
        Called with a one-line description once the loop is checked (stable) and its
        roll-off bandwidth found, before the quadratures (whose SciPy import is most of a
        short run: a command's start line, issue 23).

    Returns
    -------
    VarianceComparison

    Raises
    ------
    ServokitValueError
        When the variance is not a finite non-negative number: a disturbance filter that
        is not strictly proper (white noise in, unbounded power out) or an unstable
        closed loop makes the integral (6.13) diverge.
    """
    dt = float(loop.dt) if loop.isdtime() else None
    poles = _closed_loop_poles(loop)
    worst = poles[np.argmax(np.abs(poles) if dt else poles.real)] if poles.size else 0.0
    if poles.size and (abs(worst) >= 1 if dt else worst.real >= 0):
        # (6.13) integrates |S D|^2 on the boundary, which stays finite for an unstable
        # loop: the number would look like a variance of an output that diverges
        raise ServokitValueError(
            f"disturbance and loop give no output variance: the closed-loop system is "
            f"unstable (pole at {complex(worst):.4g})"
        )
    omega_hz = rolloff_bandwidth(loop, delta=delta, k=k)
    if started is not None:
        started(f"roll-off bandwidth {omega_hz:.4g} Hz; integrating (6.13) and (6.16)")
    try:
        vb = variance_lower_bound(disturbance, omega_hz, delta=delta, k=k, dt=dt)
    except ServokitValueError as exc:
        msg = str(exc).replace("bandwidth_hz", "the roll-off bandwidth")
        raise ServokitValueError(msg) from None
    var = output_variance(loop, disturbance)
    if not (np.isfinite(var) and var >= 0):
        raise ServokitValueError(
            f"disturbance and loop give an unbounded output variance (computed {var:.3g}); "
            "the disturbance filter must be strictly proper and the closed-loop system stable"
        )
    return VarianceComparison(omega_hz, float(var), vb)


def dynamic_range(stroke_m: float, accuracy_m: float) -> float:
    """Dynamic range of §6.1.1: ``accuracy / stroke`` (Fig. 6.1; about 1e-7 for an HDD).

    Parameters
    ----------
    stroke_m : float
        Actuator stroke [m].
    accuracy_m : float
        Positioning accuracy [m].

    Returns
    -------
    float
    """
    s = check_positive("stroke_m", stroke_m, "m")
    a = check_positive("accuracy_m", accuracy_m, "m")
    if a > s:
        raise ServokitValueError(f"accuracy_m ({a:g}) must not exceed stroke_m ({s:g})")
    ratio = a / s
    if ratio < np.finfo(float).tiny:  # 0.0 or subnormal: the quotient lost its digits
        raise ServokitValueError(
            f"accuracy_m / stroke_m = {a:g} / {s:g} underflows double precision (below "
            f"{np.finfo(float).tiny:.3g}); give both in metres (an HDD: 3e-9 / 0.03)"
        )
    return ratio
