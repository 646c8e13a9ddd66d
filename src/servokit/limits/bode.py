"""Bode sensitivity integrals and the waterbed bound (book §6.3.2, eqs. 6.17-6.22).

Continuous (6.17): for a stable open loop ``L`` with a stable unity-feedback loop,
``int_0^inf ln|S(jw)| dw = -pi/2 Ks`` with ``Ks = lim_{s->inf} s L(s)`` (0 when the
relative degree is 2 or more, Corollary 1).

Discrete (6.18): ``int_{-pi}^{pi} ln|S(e^{j phi})| d phi = -2 pi ln|1 + Kz|`` with
``Kz = lim_{z->inf} L(z)``.  Derivation (Jensen / Poisson): ``S = 1/(1+L)`` is analytic and
free of zeros on and outside the unit circle (its poles are the closed-loop poles, its
zeros the open-loop poles, both inside), so the mean of ``ln|S|`` over the circle equals
``ln|S(inf)| = -ln|1 + Kz|``.  Minimum phase, which the book assumes, is not needed: zeros
of ``L`` are zeros of ``T``, not of ``S``.  The sign cases follow: strictly proper
``Kz = 0`` gives 0 (Corollary 2, 6.19); ``Kz < -2`` or ``Kz > 0`` gives ``|1+Kz| > 1`` and a
negative integral (Corollary 3, 6.21); ``-2 < Kz < 0`` a positive one (Corollary 4, 6.22).

Unstable open-loop poles (the general form, which the book's (6.17)/(6.18) leave out): each
open-loop pole ``p`` outside the stability region is a zero of ``S`` there, and Jensen's
formula (discrete) / the Poisson integral of ``ln|S|`` over the right half-plane
(continuous) add its contribution:

* continuous ``int_0^inf ln|S(jw)| dw = pi sum Re p - pi/2 Ks`` (Freudenberg-Looze);
* discrete ``int_{-pi}^{pi} ln|S| d phi = 2 pi sum ln|p| - 2 pi ln|1 + Kz|`` (i.e.
  ``pi sum ln|p|`` per half circle ``[0, pi]``), ``|p| > 1``.

Both added terms are positive: unstable poles raise the waterbed. By hand, ``L = k/(s - a)``
with ``k > a > 0``: ``int_0^inf (1/2) ln((w^2 + a^2)/(w^2 + (k - a)^2)) dw = pi (a - (k - a))/2
= pi a - pi k/2`` (``Ks = k``); ``L = k/(z - a)`` with ``|a| > 1 > |a - k|``: the circle mean
of ``ln|z - a|`` is ``ln|a|`` and of ``ln|z - (a - k)|`` is 0, so the integral is
``2 pi ln|a|``. Both are tests.

Waterbed (6.20): if ``|S| <= alpha < 1`` on ``|phi| <= phi1`` and the integral is 0, then
``2 phi1 ln(alpha) + 2 (pi - phi1) ln||S||_inf >= 0``, i.e.
``||S||_inf >= (1/alpha)^(phi1/(pi - phi1))`` as printed.  The book's example (-40 dB
below 1 kHz at 25 kHz sampling) gives 3.478 dB (printed 3.5 dB).

Every function takes a python-control LTI object or a :class:`RationalLoop` (numpy
coefficients; the CLI's path, which never imports python-control); both are read as
``num/den`` with ``den + num`` giving the closed-loop poles.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_positive
from servokit.limits.rational import RationalLoop, as_rational

if TYPE_CHECKING:
    import control

__all__ = [
    "BodeIntegral",
    "continuous_bode_integral",
    "discrete_bode_integral",
    "high_frequency_gain",
    "waterbed_lower_bound",
    "waterbed_phi1",
]


@dataclass(frozen=True)
class BodeIntegral:
    """A numerically evaluated Bode sensitivity integral and its theoretical value.

    Attributes
    ----------
    integral : float
        The numerical integral of ``ln|S|`` [rad/s for continuous, rad for discrete].
    theory : float
        The right-hand side of (6.17) or (6.18).
    limit_gain : float
        ``Ks`` (continuous, [rad/s]) or ``Kz`` (discrete).
    corollary : str
        Which corollary of §6.3.2 the loop falls under.
    """

    integral: float
    theory: float
    limit_gain: float
    corollary: str

    @property
    def error(self) -> float:
        """``integral - theory``."""
        return self.integral - self.theory


def high_frequency_gain(
    loop: RationalLoop | control.TransferFunction | control.StateSpace,
) -> float:
    """``Kz = lim_{z->inf} L(z)`` (discrete) or ``Ks = lim_{s->inf} s L(s)`` (continuous).

    Raises for a continuous loop that is not strictly proper (``Ks`` infinite).

    Parameters
    ----------
    loop : RationalLoop or SISO LTI
        Open loop.

    Returns
    -------
    float
    """
    tf = as_rational(loop)
    num, den = tf.num, tf.den
    rel = len(den) - len(num)
    if rel < 0:
        raise ServokitValueError("loop is improper (more zeros than poles); give a proper loop")
    if tf.isdtime():
        return float(num[0] / den[0]) if rel == 0 else 0.0
    if rel == 0:
        raise ServokitValueError(
            "a continuous loop must be strictly proper for (6.17): Ks = lim s L(s) is infinite"
        )
    return float(num[0] / den[0]) if rel == 1 else 0.0


def _evaluate(loop: object, x: np.ndarray) -> np.ndarray:
    """``loop(x)`` flattened: a RationalLoop with numpy, a python-control object through
    :func:`~servokit.models.lti_response.lti_response` (vectorised, its own values)."""
    if isinstance(loop, RationalLoop):
        return loop(x).ravel()
    from servokit.models.lti_response import lti_response

    return np.asarray(lti_response(loop, x)).ravel()


def _real_loop(loop: object, tf: RationalLoop) -> bool:
    """Whether ``loop`` has real coefficients (its response is conjugate-symmetric)."""
    parts = [tf.num, tf.den, *(getattr(loop, name, 0.0) for name in ("A", "B", "C", "D"))]
    return all(np.isrealobj(np.asarray(p)) for p in parts)


def _unstable_poles(loop: RationalLoop) -> np.ndarray:
    """Open-loop poles strictly outside the stability region (boundary poles excluded)."""
    ol = np.asarray(loop.poles())
    tol = 1e-4  # repeated poles on the boundary (integrators) are found only to ~eps^(1/m)
    return ol[np.abs(ol) > 1.0 + tol] if loop.isdtime() else ol[ol.real > tol]


def _check_stable(loop: RationalLoop) -> None:
    """The theorem needs a stable closed loop; unstable open-loop poles enter the theory."""
    poles = loop.closed_loop_poles()
    bad = np.abs(poles) >= 1.0 if loop.isdtime() else poles.real >= 0.0
    if np.any(bad):
        raise ServokitValueError(
            "the closed loop 1/(1+L) is unstable; the Bode integral theorem needs a stable "
            "closed loop"
        )


def _corollary(kz: float, discrete: bool) -> str:
    if not discrete:
        return "Corollary 1 (relative degree >= 2: integral 0)" if kz == 0 else "Theorem 1"
    if kz == 0:
        return "Corollary 2 (strictly proper: integral 0, eq. 6.19)"
    if kz < -2 or kz > 0:
        return "Corollary 3 (Kz < -2 or Kz > 0: integral < 0, eq. 6.21)"
    return "Corollary 4 (-2 < Kz < 0: integral > 0, eq. 6.22)"


def discrete_bode_integral(
    loop: RationalLoop | control.TransferFunction | control.StateSpace, *, n_freq: int = 1 << 16
) -> BodeIntegral:
    """``int_{-pi}^{pi} ln|S(e^{j phi})| d phi`` numerically, against (6.18).

    The integrand is smooth and 2 pi-periodic, so the trapezoidal rule on a uniform grid
    converges geometrically; ``n_freq`` points resolve resonances down to a damping of
    about ``10 / n_freq``.

    Parameters
    ----------
    loop : discrete RationalLoop or SISO LTI
        Open loop ``L(z) = C(z) P(z)`` with a stable closed loop; unstable open-loop poles
        add ``2 pi sum ln|p|`` to the theory.
    n_freq : int
        Number of grid points on ``[-pi, pi)``.

    Returns
    -------
    BodeIntegral
    """
    tf = as_rational(loop)
    if not tf.isdtime():
        raise ServokitValueError("loop must be discrete (dt set); use continuous_bode_integral")
    n = check_count("n_freq", n_freq, lo=64, hi=1 << 24)
    kz = high_frequency_gain(tf)
    if abs(1.0 + kz) < 1e-9:
        raise ServokitValueError(
            "Kz = L(inf) = -1: the feedback loop is ill-posed (1 + L(inf) = 0)"
        )
    _check_stable(tf)
    # midpoint grid: never evaluates an integrator's pole z = 1 itself
    z = np.exp(1j * (-np.pi + 2.0 * np.pi * (np.arange(n) + 0.5) / n))
    if n % 2 == 0 and _real_loop(loop, tf):
        # |S(conj z)| = |S(z)| for real coefficients and the grid is symmetric about 0:
        # the mean over the upper half is the mean over the circle (half the solves)
        z = z[n // 2 :]
    # evaluate the object as given: a state space near its integrators is far more
    # accurate than the expanded polynomial of its transfer function
    ln_s = np.log(np.abs(1.0 / (1.0 + _evaluate(loop, z))))
    # open-loop poles on the unit circle are zeros of S: ln|S| has log singularities there.
    # Remove them: the mean of ln|z - p| over the circle is ln max(1, |p|) = 0 for |p| = 1
    # (Jensen), so subtracting them leaves a smooth periodic integrand with the same integral.
    poles = np.asarray(loop.poles())
    for p in poles[np.abs(np.abs(poles) - 1.0) < 1e-4]:
        angle = np.angle(p)
        angle = 0.0 if abs(angle) < 1e-4 else angle  # a repeated integrator splits ~eps^(1/m)
        ln_s -= np.log(np.abs(z - np.exp(1j * angle)))
    integral = float(2.0 * np.pi * np.mean(ln_s))
    unstable = _unstable_poles(tf)
    theory = float(2.0 * np.pi * (np.sum(np.log(np.abs(unstable))) - np.log(abs(1.0 + kz))))
    note = _corollary(kz, discrete=True) if unstable.size == 0 else _GENERAL
    return BodeIntegral(integral, theory, kz, note)


def continuous_bode_integral(
    loop: RationalLoop | control.TransferFunction | control.StateSpace, *, n_freq: int = 200_000
) -> BodeIntegral:
    """``int_0^inf ln|S(jw)| dw`` numerically, against (6.17).

    Trapezoidal rule on a logarithmic grid spanning six decades beyond the loop's poles
    and zeros; below the grid ``ln|S|`` is taken constant, above it the ``1/w^2`` tail of a
    strictly proper loop is added analytically (``w_max |ln S(j w_max)|``).

    Parameters
    ----------
    loop : continuous RationalLoop or SISO LTI
        Strictly proper open loop with a stable closed loop; unstable open-loop poles add
        ``pi sum Re p`` to the theory.
    n_freq : int
        Grid points.

    Returns
    -------
    BodeIntegral
    """
    tf = as_rational(loop)
    if tf.isdtime():
        raise ServokitValueError("loop must be continuous; use discrete_bode_integral")
    n = check_count("n_freq", n_freq, lo=1000, hi=1 << 24)
    ks = high_frequency_gain(tf)
    _check_stable(tf)
    roots = np.abs(np.r_[np.asarray(tf.poles()), np.asarray(tf.zeros()), abs(ks)])
    roots = roots[roots > 0]
    lo = (roots.min() if roots.size else 1.0) * 1e-6
    hi = (roots.max() if roots.size else 1.0) * 1e6
    w = np.geomspace(lo, hi, n)
    f = np.log(np.abs(1.0 / (1.0 + tf(1j * w))))
    integral = float(np.trapezoid(f, w) + lo * f[0] + hi * f[-1])
    unstable = _unstable_poles(tf)
    theory = float(np.pi * np.sum(unstable.real) - np.pi / 2.0 * ks)
    note = _corollary(ks, discrete=False) if unstable.size == 0 else _GENERAL
    return BodeIntegral(integral, theory, ks, note)


#: The corollary named when the open loop has unstable poles.
_GENERAL = "general form with unstable open-loop poles (pi sum Re p / 2 pi sum ln|p| added)"


def waterbed_phi1(bandwidth_hz: float, sampling_hz: float) -> float:
    """Normalised frequency ``phi1 = 2 pi f_b / f_s`` [rad] of a sensitivity bandwidth.

    Parameters
    ----------
    bandwidth_hz : float
        Sensitivity bandwidth [Hz].
    sampling_hz : float
        Sampling frequency [Hz].

    Returns
    -------
    float
    """
    fb = check_positive("bandwidth_hz", bandwidth_hz, "Hz")
    fs = check_positive("sampling_hz", sampling_hz, "Hz")
    if fb >= fs / 2:
        raise ServokitValueError(
            f"bandwidth_hz ({fb:g}) must be below the Nyquist frequency {fs / 2:g} Hz"
        )
    return 2.0 * np.pi * fb / fs


def waterbed_lower_bound(alpha: float, phi1: float) -> float:
    """Lower bound of ``||S||_inf`` (linear ratio) from (6.20).

    Parameters
    ----------
    alpha : float
        Upper bound of ``|S|`` on ``|phi| <= phi1``; ``0 < alpha < 1`` (linear, not dB).
    phi1 : float
        Band edge ``omega T`` [rad], ``0 < phi1 < pi``.

    Returns
    -------
    float
        ``(1/alpha) ** (phi1 / (pi - phi1))`` (>= 1).
    """
    a = check_positive("alpha", alpha)
    if a >= 1:
        raise ServokitValueError(f"alpha must be < 1 (a linear ratio, got {a}); -40 dB is 0.01")
    p = check_positive("phi1", phi1, "rad")
    if p >= np.pi:
        raise ServokitValueError(f"phi1 must be < pi rad (got {p})")
    return float((1.0 / a) ** (p / (np.pi - p)))
