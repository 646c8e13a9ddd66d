"""Pole-aware frequency grids: never step over a lightly damped resonance or anti-resonance.

A logarithmic grid of ``n`` points spaces neighbours by ``f ln(f_max/f_min)/n``; a mode of
damping ζ at ``f0`` has a half-power half-width of ``ζ f0``, so a 20 000-point grid over ten
decades is coarser than every mode with ζ < 6e-4 and can step over a whole resonance peak
(or over two crossings of it). Here every pole and zero of the loop factors is turned into
a frequency ``f0 = |s|/2π`` and a damping ``ζ = -Re s / |s|`` (discrete poles are mapped by
``s = ln(z)/dt`` first), and the grid is packed around each: points at ``f0 + t ζ f0`` with
``t`` spaced like ``sinh`` from ``-K`` to ``K`` half-widths, dense (about a dozen points)
inside the half-power band and geometric outside it, until the packing meets the
logarithmic background. ζ is floored at 1e-9, so even undamped modes get a dense neighbourhood.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError, check_count

__all__ = ["critical_frequencies", "factor_frequencies", "frequency_grid", "pack_around"]

#: Floor on the damping used for packing (an undamped pole still gets a finite width).
_MIN_DAMPING = 1e-9


def _dt(sys: Any) -> float | None:
    dt = getattr(sys, "dt", None)
    if dt is None or dt is False or dt is True or dt == 0:
        return None
    return float(dt)


def _roots_of(sys: Any) -> np.ndarray:
    """Poles and zeros of an LTI or ModalPlant factor (empty for anything else)."""
    from servokit.models.rational import RationalTF, StateSpaceData

    if isinstance(sys, RationalTF | StateSpaceData):  # numpy-only: python-control unloaded
        return np.r_[sys.poles(), _zeros(sys)].astype(complex)
    import control

    if isinstance(sys, control.LTI):
        return np.r_[np.asarray(sys.poles()), _zeros(sys)].astype(complex)
    if hasattr(sys, "modes") and hasattr(sys, "to_statespace"):
        w, z, _ = sys.arrays()
        poles = -z * w + 1j * w * np.sqrt(np.clip(1.0 - z * z, 0.0, None))
        return np.r_[poles, _zeros(sys.to_statespace())]
    return np.zeros(0, dtype=complex)


def _zeros(sys: Any) -> np.ndarray:
    """Transmission zeros, or none if the generalised eigenproblem fails (repeated
    undamped modes can make QZ give up; the adaptive refinement still resolves them)."""
    try:
        with np.errstate(all="ignore"):
            return np.asarray(sys.zeros(), dtype=complex)
    except np.linalg.LinAlgError:
        return np.zeros(0, dtype=complex)


def critical_frequencies(system: Any) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios of a factor's poles and zeros.

    Parameters
    ----------
    system : LTI, RationalTF, StateSpaceData or ModalPlant
        A python-control system (continuous or discrete) or its numpy-only form, or a
        :class:`~servokit.models.ModalPlant`; anything else has no known critical points.

    Returns
    -------
    freq_hz, damping : ndarray
        One entry per pole or zero with a finite, non-zero frequency (discrete roots are
        mapped to ``s = ln(z)/dt``; roots at z = 0 are skipped).
    """
    return _natural(_roots_of(system), _dt(system))


def factor_frequencies(
    poles: np.ndarray, zeros: np.ndarray, dt: float | None
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`critical_frequencies` from poles and zeros already at hand.

    Parameters
    ----------
    poles, zeros : ndarray
        Roots in s (continuous) or z (discrete).
    dt : float or None
        Sampling period [s].

    Returns
    -------
    freq_hz, damping : ndarray
    """
    return _natural(np.r_[poles, zeros].astype(complex), dt)


def _natural(roots: np.ndarray, dt: float | None) -> tuple[np.ndarray, np.ndarray]:
    roots = roots[np.isfinite(roots)]
    if dt is not None:
        roots = roots[np.abs(roots) > 1e-300]
        roots = np.log(roots) / dt
    mag = np.abs(roots)
    keep = mag > 0
    f0 = mag[keep] / (2 * np.pi)
    zeta = np.abs(roots[keep].real) / mag[keep]
    return f0, zeta


def pack_around(
    f0: np.ndarray, damping: np.ndarray, *, points: int = 25, reach: float = 1e4
) -> np.ndarray:
    """Points packed around each critical frequency: ``f0 (1 + ζ t)`` with sinh-spaced ``t``.

    Parameters
    ----------
    f0 : ndarray
        Critical frequencies [Hz].
    damping : ndarray
        Their damping ratios (floored at 1e-9).
    points : int
        Points per lightly damped (ζ < 0.05) critical frequency (odd puts one on ``f0``);
        better damped ones get 11.
    reach : float
        The packing spans ``|t| <= min(reach, 0.9/ζ)`` half-widths.

    Returns
    -------
    ndarray
        The packed frequencies [Hz] (positive, unsorted).
    """
    f0 = np.asarray(f0, dtype=float)
    z = np.maximum(np.asarray(damping, dtype=float), _MIN_DAMPING)
    if f0.size == 0:
        return np.zeros(0)
    # a well damped root is broad: the logarithmic background and 11 points resolve it
    light = z < 0.05
    parts = [_packed(f0[light], z[light], points, reach), _packed(f0[~light], z[~light], 11, reach)]
    out = np.concatenate(parts)
    return out[out > 0]


def _packed(f0: np.ndarray, z: np.ndarray, points: int, reach: float) -> np.ndarray:
    if f0.size == 0:
        return np.zeros(0)
    k = np.minimum(reach, 0.9 / z)
    u = np.linspace(-1.0, 1.0, points)
    # sinh spacing: a step of about 0.15 half-widths near f0, geometric growth outside
    a = np.arcsinh(k / 0.15)
    t = 0.15 * np.sinh(a[:, None] * u[None, :])
    return (f0[:, None] * (1.0 + z[:, None] * t)).ravel()


def frequency_grid(systems: Any, f_min: float, f_max: float, n: int = 2000) -> np.ndarray:
    """Logarithmic grid on ``[f_min, f_max]`` packed around every lightly damped pole/zero.

    The same grid serves margins, Bode plots, sensitivity plots and report figures, so no
    resonance peak is clipped: the packed points resolve the half-power band of every
    mode down to a damping of 1e-9.

    Parameters
    ----------
    systems : LTI, ModalPlant, callable or iterable of them
        Loop factors; only LTI and ModalPlant ones contribute critical frequencies.
    f_min, f_max : float
        Band [Hz], ``0 < f_min < f_max``.
    n : int
        Points of the logarithmic background.

    Returns
    -------
    ndarray
        Sorted, unique frequencies [Hz] within ``[f_min, f_max]`` (both ends included).
    """
    lo, hi = float(f_min), float(f_max)
    if not (0 < lo < hi) or not np.isfinite(hi):
        raise ServokitValueError(f"need 0 < f_min < f_max (got f_min={lo:g}, f_max={hi:g})")
    n = check_count("n", n, lo=2, hi=50_000_000)
    items: Iterable[Any] = systems if isinstance(systems, list | tuple) else [systems]
    f0s, zs = [], []
    for sys in items:
        f0, z = critical_frequencies(sys)
        f0s.append(f0)
        zs.append(z)
    f0 = np.concatenate(f0s) if f0s else np.zeros(0)
    z = np.concatenate(zs) if zs else np.zeros(0)
    packed = pack_around(f0, z)
    f = np.concatenate([np.geomspace(lo, hi, n), packed[(packed > lo) & (packed < hi)]])
    return np.unique(f)
