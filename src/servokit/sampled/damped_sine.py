"""Exact extrema of a damped sinusoid on an interval (book §4.3, §4.4).

:func:`damped_sine_extrema` locates the max and min of ``exp(-decay u) sin(omega u +
phase)`` in closed form; the unobservable magnitude (:mod:`servokit.sampled.unobservable`,
eq. (4.48)) uses it for the continuous signal after the judgement samples and the shock
response spectrum (:mod:`servokit.sampled.srs`, eqs. (4.56)-(4.57)) inside each hold
interval.
"""

from __future__ import annotations

import numpy as np

__all__ = ["damped_sine_extrema"]

_TWO_PI = 2.0 * np.pi


def damped_sine_extrema(
    decay: np.ndarray, omega: np.ndarray, phase: np.ndarray, length: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray]:
    """Exact max and min of ``f(u) = exp(-decay u) sin(omega u + phase)`` on ``[0, length]``.

    The stationary points satisfy ``omega u + phase = gamma + k pi`` with
    ``gamma = atan2(omega, decay)``; maxima (even ``k``) and minima (odd ``k``) shrink
    along ``u`` for ``decay >= 0``, so only the first of each kind and the end points
    can be extreme.  Used for the continuous signal in (4.48) and for the shock response
    (4.56)-(4.57).

    Parameters
    ----------
    decay, omega, phase : ndarray
        Broadcastable arrays; ``decay >= 0``, ``omega > 0`` (rad per unit of ``u``).
    length : ndarray or float
        Interval length (``np.inf`` allowed).

    Returns
    -------
    (fmax, fmin) : tuple of ndarray
    """
    decay, omega, phase, length = np.broadcast_arrays(
        np.asarray(decay, float),
        np.asarray(omega, float),
        np.asarray(phase, float),
        np.asarray(length, float),
    )
    gamma = np.arctan2(omega, decay)
    peak = np.sin(gamma)
    u_max = np.mod(gamma - phase, _TWO_PI) / omega
    u_min = np.mod(gamma + np.pi - phase, _TWO_PI) / omega
    f0 = np.sin(phase)
    finite = np.isfinite(length)
    safe_len = np.where(finite, length, 0.0)
    f_end = np.where(finite, np.exp(-decay * safe_len) * np.sin(omega * safe_len + phase), f0)
    fmax = np.maximum(f0, f_end)
    fmin = np.minimum(f0, f_end)
    fmax = np.where(u_max <= length, np.maximum(fmax, np.exp(-decay * u_max) * peak), fmax)
    fmin = np.where(u_min <= length, np.minimum(fmin, -np.exp(-decay * u_min) * peak), fmin)
    return fmax, fmin
