"""Unobservable magnitude of oscillations in sampled-data positioning (book §4.3, §4.5.3).

A controller sees the position ``yc(t)`` only at the samples ``yd[n]``; the part of the
displacement it cannot see is the *unobservable magnitude*.  With the time normalised
by the sampling period ``tau`` the oscillation and its samples are

    yc(t)      = exp(-zeta wn t) sin(wd t)                          eqs. (4.39), (4.46)
    yd[n, ds]  = yc(tau (n + ds)),  0 <= ds < 1                     eqs. (4.40), (4.47)

and, for ``Ns`` judgement samples ``n = 1..Ns`` and the displacement that follows them,

    yup[ds] = sup_{t >= Ns tau} yc(t) - max_n yd[n, ds]
    yum[ds] = inf_{t >= Ns tau} yc(t) - min_n yd[n, ds]
    yu[ds]  = max(0, yup[ds], -yum[ds])                             eq. (4.48)
    yuw     = sup_ds yu[ds]                                         eqs. (4.42), (4.51)
    Ep(n)   = 100 m_n / m_a,  0.1 (n - 1) <= yu < 0.1 n             eqs. (4.49)-(4.50)
    yui     = sqrt(int_0^1 yu[ds]^2 d ds)                           eq. (4.52)

For an undamped oscillation the case analysis of (4.48) reduces to (4.41).  Without
``n_samples`` (the steady state of §4.3.1) the samples run over ``n = 0, 1, ...``; this
is evaluated with :data:`STEADY_STATE_SAMPLES` samples, which is exact whenever the
ratio of oscillation to sampling frequency is ``p/q`` with ``q`` up to that number.

Undamped magnitudes are computed exactly from the sorted sample phases (the largest
distance of ``+-pi/2`` to a sample phase); damped ones from the exact extrema of the
damped sinusoid after ``Ns tau`` (:func:`damped_sine_extrema`).  ``yuw`` and the
minimum are refined around the best phase of the grid; ``yui`` uses the rectangle rule
on the uniform phase grid.  The grid evaluation itself lives in
:mod:`servokit.sampled._unobservable_grid` (with :data:`STEADY_STATE_SAMPLES`),
:func:`damped_sine_extrema` in :mod:`servokit.sampled.damped_sine`; both public names
are re-exported here.

This module holds the public API: the result types (:class:`UnobservableMagnitude`,
:class:`SamplingInterval`, :class:`MeasurementTimeRequirement`), the argument checks,
the magnitude and its RMS, the sweeps below and :func:`unobservable_plot`.

Sweeps over the oscillation frequency (Figs. 4.3, 4.20-4.23), the sampling frequency
(Figs. 4.24, 4.54: :func:`unacceptable_sampling_frequencies`) and the measurement time
``tau * Ns`` (Figs. 4.25, 4.55: :func:`required_measurement_time`) are vectorised:
``freq_hz`` and ``dt`` broadcast against each other.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from servokit._figures import save_figure
from servokit.errors import ServokitTypeError, ServokitValueError, check_finite
from servokit.sampled._unobservable_grid import _TWO_PI, STEADY_STATE_SAMPLES, _refine, _yu_of
from servokit.sampled.damped_sine import damped_sine_extrema

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "STEADY_STATE_SAMPLES",
    "UnobservableMagnitude",
    "SamplingInterval",
    "MeasurementTimeRequirement",
    "damped_sine_extrema",
    "unobservable_magnitude",
    "unobservable_rms",
    "unacceptable_sampling_frequencies",
    "required_measurement_time",
    "unobservable_plot",
]


@dataclass(frozen=True)
class UnobservableMagnitude:
    """Unobservable magnitudes over the sampling phase, eqs. (4.41)-(4.52).

    Arrays have the broadcast shape ``S`` of ``freq_hz`` and ``dt`` (``yu``: ``S + (P,)``).

    Attributes
    ----------
    freq_hz, dt : ndarray
        Damped oscillation frequency [Hz] and sampling period [s], broadcast to ``S``.
    damping : float
        Damping ratio ``zeta`` of (4.46).
    n_samples : int or None
        Judgement samples ``Ns`` of (4.48); ``None`` for the steady state of (4.41).
    delta_s : ndarray, shape (P,)
        Sampling phases ``k / P``.
    yu : ndarray
        ``yu[ds]`` of (4.41)/(4.48) on ``delta_s``.
    worst, worst_delta_s : ndarray
        ``yuw`` of (4.42)/(4.51) and the phase where it occurs.
    minimum, minimum_delta_s : ndarray
        Smallest ``yu`` and its phase.
    rms : ndarray
        Index ``yui`` of (4.52).
    """

    freq_hz: np.ndarray
    dt: np.ndarray
    damping: float
    n_samples: int | None
    delta_s: np.ndarray
    yu: np.ndarray
    worst: np.ndarray
    worst_delta_s: np.ndarray
    minimum: np.ndarray
    minimum_delta_s: np.ndarray
    rms: np.ndarray

    def histogram(self, bin_width: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
        """Event probability ``Ep(n)`` in percent of the phase grid, eqs. (4.49)-(4.50).

        Returns
        -------
        (edges, percent) : tuple of ndarray
            Bin edges ``0, w, 2w, ...`` and ``percent`` with shape ``S + (n_bins,)``.
        """
        if not bin_width > 0:
            raise ServokitValueError(f"bin_width must be > 0, got {bin_width}")
        n_bins = int(np.floor(self.yu.max() / bin_width)) + 1
        edges = bin_width * np.arange(n_bins + 1)
        idx = np.floor(self.yu / bin_width).astype(int)
        counts = (idx[..., None] == np.arange(n_bins)).sum(axis=-2)
        return edges, 100.0 * counts / self.delta_s.size


def _check_samples(n_samples: object) -> int | None:
    if n_samples is None:
        return None
    if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer):
        raise ServokitTypeError(f"n_samples must be a positive integer or None, got {n_samples!r}")
    if n_samples < 1:
        raise ServokitValueError(f"n_samples must be >= 1, got {n_samples}")
    return int(n_samples)


def _check_damping(damping: float) -> float:
    zeta = float(check_finite("damping", damping))
    if not 0.0 <= zeta < 1.0:
        raise ServokitValueError(f"damping must lie in [0, 1), got {zeta}")
    return zeta


def _grid_yu(freq_hz, dt, damping, n_samples, n_phases):  # noqa: ANN001, ANN202
    """Checked arguments of :func:`unobservable_magnitude` and ``yu`` on the phase grid:
    ``(f, tau, Ns, zeta, grid, yu_of, yu)`` (``yu_of``: ``ds -> yu`` of the rows)."""
    f = check_finite("freq_hz", freq_hz)
    tau = check_finite("dt", dt)
    if np.any(f <= 0):
        raise ServokitValueError("freq_hz must be > 0 (the damped oscillation frequency in Hz)")
    if np.any(tau <= 0):
        raise ServokitValueError("dt must be > 0 (the sampling period in seconds)")
    zeta = _check_damping(damping)
    ns = _check_samples(n_samples)
    if ns is None and zeta > 0:
        raise ServokitValueError(
            "a damped oscillation (damping > 0) needs n_samples (eq. 4.48); pass n_samples=Ns"
        )
    if isinstance(n_phases, bool) or not isinstance(n_phases, int | np.integer) or n_phases < 4:
        raise ServokitValueError(f"n_phases must be an integer >= 4, got {n_phases!r}")
    f, tau = np.broadcast_arrays(f, tau)
    b = (_TWO_PI * f * tau).ravel()
    # zeta * wn = zeta * wd / sqrt(1 - zeta^2) because freq_hz is the damped frequency.
    a = b * zeta / np.sqrt(1.0 - zeta**2)
    grid = np.arange(n_phases) / n_phases
    yu_of = _yu_of(b, a, ns)
    yu = yu_of(np.broadcast_to(grid, (b.size, n_phases)))
    return f, tau, ns, zeta, grid, yu_of, yu


def unobservable_magnitude(
    freq_hz: float | np.ndarray,
    dt: float | np.ndarray,
    *,
    damping: float = 0.0,
    n_samples: int | None = None,
    n_phases: int = 720,
) -> UnobservableMagnitude:
    """Unobservable magnitude of an oscillation between the samples, eqs. (4.39)-(4.52).

    Parameters
    ----------
    freq_hz : float or array_like
        Damped natural frequency ``wd / 2 pi`` of the oscillation [Hz], > 0.
    dt : float or array_like
        Sampling period ``tau`` [s], > 0; broadcasts against ``freq_hz``.
    damping : float
        Damping ratio ``zeta`` in [0, 1) of (4.46).
    n_samples : int, optional
        Number of judgement samples ``Ns`` of (4.48).  ``None`` is the undamped steady
        state of (4.41)-(4.42) and requires ``damping == 0``.
    n_phases : int
        Size ``P`` of the uniform sampling-phase grid ``ds = k / P`` (the RMS (4.52) is the
        rectangle rule on it; ``yuw`` and the minimum are refined off the grid).

    Returns
    -------
    UnobservableMagnitude
    """
    f, tau, ns, zeta, grid, yu_of, yu = _grid_yu(freq_hz, dt, damping, n_samples, n_phases)
    shape = f.shape
    worst, worst_ds = _refine(yu_of, grid, yu, 1.0)
    minimum, minimum_ds = _refine(yu_of, grid, yu, -1.0)
    rms = np.sqrt(np.mean(yu**2, axis=1))
    out = {
        "worst": worst,
        "worst_delta_s": worst_ds,
        "minimum": minimum,
        "minimum_delta_s": minimum_ds,
        "rms": rms,
    }
    for name, value in out.items():
        if not np.all(np.isfinite(value)):
            raise ServokitValueError(f"unobservable magnitude: non-finite {name}; check the inputs")
    return UnobservableMagnitude(
        freq_hz=f.copy(),
        dt=tau.copy(),
        damping=zeta,
        n_samples=ns,
        delta_s=grid,
        yu=yu.reshape(shape + (n_phases,)),
        **{k: v.reshape(shape) for k, v in out.items()},
    )


def unobservable_rms(
    freq_hz: float | np.ndarray,
    dt: float | np.ndarray,
    *,
    damping: float = 0.0,
    n_samples: int | None = None,
    n_phases: int = 720,
) -> np.ndarray:
    """RMS unobservable magnitude ``yui`` (4.52) alone, for sweeps that need nothing else.

    The same values as ``unobservable_magnitude(...).rms`` (the rectangle rule on the same
    phase grid), without refining ``yuw`` and the minimum off the grid.

    Parameters
    ----------
    freq_hz : float or array_like
        Damped natural frequency of the oscillation [Hz], > 0.
    dt : float or array_like
        Sampling period [s], > 0; broadcasts against ``freq_hz``.
    damping : float
        Damping ratio in [0, 1).
    n_samples : int, optional
        Judgement samples ``Ns``; ``None`` is the undamped steady state.
    n_phases : int
        Size of the uniform sampling-phase grid.

    Returns
    -------
    ndarray
        ``yui`` with the broadcast shape of ``freq_hz`` and ``dt``.
    """
    f, _, _, _, _, _, yu = _grid_yu(freq_hz, dt, damping, n_samples, n_phases)
    rms = np.sqrt(np.mean(yu**2, axis=1))
    if not np.all(np.isfinite(rms)):
        raise ServokitValueError("unobservable magnitude: non-finite rms; check the inputs")
    return rms.reshape(f.shape)


@dataclass(frozen=True)
class SamplingInterval:
    """A band of sampling frequencies where ``yui`` exceeds the acceptable level (Figs 4.24, 4.54).

    ``low_hz``/``high_hz`` are the level crossings (or the ends of the searched range),
    ``peak_hz`` and ``peak_rms`` the largest ``yui`` found inside.
    """

    low_hz: float
    high_hz: float
    peak_hz: float
    peak_rms: float

    def __contains__(self, fs_hz: float) -> bool:
        return self.low_hz <= float(fs_hz) <= self.high_hz


def _rms_at_fs(
    freq_hz: float, fs: np.ndarray, damping: float, n_samples: int, n_phases: int
) -> np.ndarray:
    return unobservable_rms(
        freq_hz, 1.0 / fs, damping=damping, n_samples=n_samples, n_phases=n_phases
    )


def unacceptable_sampling_frequencies(
    freq_hz: float,
    damping: float,
    n_samples: int,
    level: float,
    fs_range: tuple[float, float],
    *,
    n_points: int = 3000,
    n_phases: int = 360,
) -> list[SamplingInterval]:
    """Sampling frequencies whose RMS unobservable magnitude ``yui`` (4.52) exceeds ``level``.

    Scans ``yui`` over a logarithmic grid of sampling frequencies (as in Figs. 4.24 and
    4.54), then locates each level crossing by bisection.

    Parameters
    ----------
    freq_hz : float
        Damped resonance frequency [Hz].
    damping : float
        Damping ratio of the resonance.
    n_samples : int
        Judgement samples ``Ns``.
    level : float
        Acceptable ``yui`` (fraction of the oscillation amplitude).
    fs_range : (float, float)
        Sampling frequencies searched [Hz], ``0 < low < high``.
    n_points : int
        Grid points of the scan (narrow bands between them can be missed).
    n_phases : int
        Phase grid of :func:`unobservable_magnitude`.

    Returns
    -------
    list of SamplingInterval
        Sorted by frequency.
    """
    lo, hi = (float(v) for v in check_finite("fs_range", fs_range))
    if not 0 < lo < hi:
        raise ServokitValueError(
            f"fs_range must be (low, high) with 0 < low < high, got {fs_range}"
        )
    if not level > 0:
        raise ServokitValueError(f"level must be > 0, got {level}")
    ns = _check_samples(n_samples)
    if ns is None:
        raise ServokitValueError("n_samples is required (the judgement sample count Ns)")
    fs = np.geomspace(lo, hi, int(n_points))
    rms = _rms_at_fs(freq_hz, fs, damping, ns, n_phases)
    above = rms > level
    # Rising/falling edges between grid points, then bisection on log(fs).
    change = np.flatnonzero(np.diff(above.astype(int)))
    left, right = np.log(fs[change]), np.log(fs[change + 1])
    for _ in range(40):
        mid = 0.5 * (left + right)
        if mid.size == 0:
            break
        mid_above = _rms_at_fs(freq_hz, np.exp(mid), damping, ns, n_phases) > level
        same_as_left = mid_above == above[change]
        left = np.where(same_as_left, mid, left)
        right = np.where(same_as_left, right, mid)
    crossing = np.exp(0.5 * (left + right))
    pairs = list(zip(crossing, change, strict=True))
    starts = ([lo] if above[0] else []) + [c for c, i in pairs if above[i + 1]]
    ends = [c for c, i in pairs if above[i]] + ([hi] if above[-1] else [])
    out = []
    for s, e in zip(starts, ends, strict=True):
        inside = (fs >= s) & (fs <= e)
        if np.any(inside):
            k = np.flatnonzero(inside)[np.argmax(rms[inside])]
            peak_hz, peak = float(fs[k]), float(rms[k])
        else:
            peak_hz = float(np.sqrt(s * e))
            peak = float(_rms_at_fs(freq_hz, np.array([peak_hz]), damping, ns, n_phases)[0])
        out.append(SamplingInterval(float(s), float(e), peak_hz, peak))
    return out


@dataclass(frozen=True)
class MeasurementTimeRequirement:
    """Smallest judgement window keeping ``yui`` below a level (Figs. 4.25, 4.55).

    ``n_samples`` is the smallest ``Ns`` with ``yui <= level`` for every ``Ns`` up to
    ``rms.size`` (``None`` if none), ``time_s = dt * n_samples``; ``crossing_time_s`` is
    where the curve ``yui(tau Ns)`` drawn through the integer ``Ns`` (as in the figures)
    crosses the level for the last time (linear interpolation).  ``rms[i]`` is ``yui``
    for ``Ns = i + 1``.
    """

    dt: float
    level: float
    n_samples: int | None
    time_s: float
    crossing_time_s: float
    rms: np.ndarray


def required_measurement_time(
    freq_hz: float,
    dt: float,
    damping: float,
    level: float,
    *,
    max_samples: int = 100,
    n_phases: int = 360,
    on_sample: Callable[[int], object] | None = None,
) -> MeasurementTimeRequirement:
    """Measurement time ``tau * Ns`` needed for ``yui <= level`` (§4.3.2.3, §4.5.3).

    Parameters
    ----------
    freq_hz : float
        Damped resonance frequency [Hz].
    dt : float
        Sampling period ``tau`` [s].
    damping : float
        Damping ratio of the resonance.
    level : float
        Acceptable ``yui``.
    max_samples : int
        Largest ``Ns`` examined.
    n_phases : int
        Phase grid of :func:`unobservable_magnitude`.
    on_sample : callable, optional
        Called with ``Ns`` after each ``Ns`` is evaluated (the work of one is about
        proportional to ``Ns``): a progress hook for long scans.

    Returns
    -------
    MeasurementTimeRequirement
    """
    if not level > 0:
        raise ServokitValueError(f"level must be > 0, got {level}")
    n_max = _check_samples(max_samples)
    if n_max is None:
        raise ServokitValueError("max_samples must be a positive integer")
    rms = np.empty(n_max)
    for ns in range(1, n_max + 1):
        rms[ns - 1] = unobservable_rms(
            freq_hz, dt, damping=damping, n_samples=ns, n_phases=n_phases
        )
        if on_sample is not None:
            on_sample(ns)
    bad = np.flatnonzero(rms > level)
    n_req: int | None
    if bad.size == 0:
        n_req = 1
    elif bad[-1] + 1 >= n_max:
        n_req = None
    else:
        n_req = int(bad[-1] + 2)
    tau = float(dt)
    if n_req is None:
        time_s = crossing = float("inf")
    elif n_req == 1:
        time_s = crossing = tau
    else:
        # rms[n_req - 2] > level >= rms[n_req - 1]: interpolate between Ns = n_req - 1, n_req.
        hi, lo = rms[n_req - 2], rms[n_req - 1]
        crossing = tau * (n_req - 1 + (hi - level) / (hi - lo))
        time_s = tau * n_req
    return MeasurementTimeRequirement(tau, float(level), n_req, time_s, crossing, rms)


def unobservable_plot(
    x: np.ndarray,
    curves: dict[str, np.ndarray],
    *,
    xlabel: str,
    ylabel: str,
    title: str,
    level: float | None = None,
    path: str | Path | None = None,
    logx: bool = False,
) -> Figure:
    """Draw ``yuw``/``yui`` curves against frequency or time (Figs. 4.3, 4.20-4.25, 4.54-4.55).

    Parameters
    ----------
    x : ndarray
        Abscissa (already in display units, e.g. kHz or ms).
    curves : dict
        Legend label -> ordinate array.
    xlabel, ylabel, title : str
        Axis labels (with units) and title.
    level : float, optional
        Acceptable level drawn as a horizontal line.
    path : path-like, optional
        Save the figure as PNG there (and close it).
    logx : bool
        Logarithmic abscissa.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    styles: Sequence[str] = ("-", "--", "-.", ":")
    fig, ax = plt.subplots(figsize=(7, 4))
    for i, (label, y) in enumerate(curves.items()):
        ax.plot(x, y, styles[i % len(styles)], label=label)
    if level is not None:
        ax.axhline(level, color="k", lw=0.8, ls=":", label=f"level {level:g}")
    if logx:
        ax.set_xscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    if path is not None:  # save_figure lays the figure out once
        save_figure(fig, path)
    else:
        fig.tight_layout()
    return fig
