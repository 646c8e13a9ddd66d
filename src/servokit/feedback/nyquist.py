"""Closed-loop stability of ``1/(1 + L)`` from the Nyquist winding count, boundary poles indented.

Argument principle for ``F = 1 + L``: along the Nyquist contour (continuous: up the jω
axis and round the right half-plane clockwise; discrete: the unit circle counterclockwise,
the unstable region being outside), ``Z = P - Δ arg F / (2π)`` where ``Z`` is the number of
unstable closed-loop poles and ``P`` the number of unstable open-loop poles. (For the
discrete contour: ``F = (A + B)/A`` has as many zeros as poles, so the zeros minus poles
*inside*, ``Δ/(2π)``, equals ``P_out - Z_out``; the same formula.)

Open-loop poles on the boundary (integrators ``s = 0`` / ``z = 1``, the rigid body's double
pole, undamped modes) are excluded from ``P``: the contour makes a small half-turn round
each of them on the unstable side. Near a boundary pole of multiplicity ``m``,
``L ≈ r/(x - x0)^m`` and the half-turn rotates ``arg F = arg L`` by exactly ``-mπ``; the
grid stops just before and restarts just after the pole, and the phase jump between those
two points is taken as ``-mπ`` plus its (small) wrapped deviation.

Real loops are conjugate-symmetric, so the whole contour is twice the positive-frequency
half plus the half-turns at ``s = 0`` (or ``z = ±1``); above the last grid frequency of a
continuous loop ``|L| < 1``, ``F`` stays in the right half-plane and ends at ``F(∞) = 1``
(strictly proper loop, any delay), which closes the count.
"""

from __future__ import annotations

import numpy as np

from servokit.feedback.crossings import cut_intervals

__all__ = ["BoundaryPoles", "boundary_poles", "winding_verdict"]

#: Relative distance below which a pole counts as on the boundary (a Jordan block's
#: computed eigenvalues split by ~sqrt(eps) relative; a mode with ζ = 1e-9 stays inside).
_AT_ORIGIN = 1e-6
_ON_AXIS = 1e-11


class BoundaryPoles:
    """Poles of a loop on the stability boundary, grouped by frequency, and the unstable count.

    Attributes
    ----------
    unstable : int
        Open-loop poles strictly in the unstable region (``P``).
    at_zero : int
        Multiplicity at ``s = 0`` / ``z = 1``.
    at_nyquist : int
        Multiplicity at ``z = -1`` (discrete only).
    freqs_hz, mult : ndarray
        Other boundary poles (positive frequency [Hz]) and their multiplicities.
    """

    def __init__(
        self, unstable: int, at_zero: int, at_nyquist: int, freqs_hz: np.ndarray, mult: np.ndarray
    ) -> None:
        self.unstable = unstable
        self.at_zero = at_zero
        self.at_nyquist = at_nyquist
        self.freqs_hz = freqs_hz
        self.mult = mult


def boundary_poles(poles: np.ndarray, dt: float | None) -> BoundaryPoles:
    """Classify open-loop poles: unstable, at zero / Nyquist, elsewhere on the boundary.

    Parameters
    ----------
    poles : ndarray
        All poles of the loop (s-plane if ``dt`` is None, else z-plane).
    dt : float or None
        Sampling period [s].

    Returns
    -------
    BoundaryPoles
    """
    p = np.asarray(poles, dtype=complex)
    if dt is None:
        scale = max(1.0, float(np.max(np.abs(p)))) if p.size else 1.0
        zero = np.abs(p) <= _AT_ORIGIN * scale
        axis = ~zero & (np.abs(p.real) <= _ON_AXIS * np.abs(p))
        unstable = int(np.sum(~zero & ~axis & (p.real > 0)))
        nyq = np.zeros(p.size, dtype=bool)
        f_axis = np.abs(p.imag[axis]) / (2 * np.pi)
    else:
        zero = np.abs(p - 1.0) <= _AT_ORIGIN
        nyq = np.abs(p + 1.0) <= _AT_ORIGIN
        axis = ~zero & ~nyq & (np.abs(np.abs(p) - 1.0) <= _ON_AXIS)
        unstable = int(np.sum(~zero & ~nyq & ~axis & (np.abs(p) > 1.0)))
        f_axis = np.abs(np.angle(p[axis])) / (2 * np.pi * dt)
    # each conjugate pair counts once at its positive frequency
    f_pos = np.sort(f_axis)[::2] if f_axis.size else f_axis
    freqs, mult = _cluster(f_pos)
    return BoundaryPoles(unstable, int(zero.sum()), int(nyq.sum()), freqs, mult)


def _cluster(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if f.size == 0:
        return np.zeros(0), np.zeros(0, dtype=int)
    groups: list[list[float]] = [[float(f[0])]]
    for x in f[1:]:
        if x - groups[-1][-1] <= 1e-6 * x:
            groups[-1].append(float(x))
        else:
            groups.append([float(x)])
    return np.array([np.mean(g) for g in groups]), np.array([len(g) for g in groups])


def winding_verdict(f: np.ndarray, L: np.ndarray, bp: BoundaryPoles, discrete: bool) -> bool | None:
    """Whether ``1/(1+L)`` is stable, from ``L`` on an adapted grid over the whole contour half.

    Parameters
    ----------
    f : ndarray
        Adapted grid [Hz] from just above 0 to just below Nyquist (discrete) or to where
        ``|L| < 1`` for good (continuous), stepping round the boundary poles.
    L : ndarray
        The loop response on ``f``.
    bp : BoundaryPoles
        The loop's open-loop poles classified by :func:`boundary_poles`.
    discrete : bool
        Unit-circle contour if True.

    Returns
    -------
    bool or None
        True if no closed-loop pole is unstable or on the boundary; None if the count
        does not come out an integer (the grid did not resolve the loop).
    """
    F = 1.0 + L
    if np.any(np.abs(F) < 1e-10):
        return False  # a closed-loop pole on the boundary
    step = np.angle(F[1:] / F[:-1])
    cut = cut_intervals(f, bp.freqs_hz)
    for k in np.nonzero(cut)[0]:
        m = int(bp.mult[np.argmin(np.abs(bp.freqs_hz - 0.5 * (f[k] + f[k + 1])))])
        step[k] = -m * np.pi + np.angle(np.exp(1j * (step[k] + m * np.pi)))
    half = float(np.sum(step))
    if discrete:
        total = 2 * half - (bp.at_zero + bp.at_nyquist) * np.pi
    else:
        if abs(L[-1]) >= 1:
            return None
        total = 2 * (half - np.angle(F[-1])) - bp.at_zero * np.pi
    n = total / (2 * np.pi)
    if abs(n - round(n)) > 0.2:
        return None
    return bp.unstable - round(n) == 0
