"""Shock response spectrum of acceleration inputs (book §4.4, §4.5.4.3).

The input ``usrs`` (4.53) drives the relative-acceleration model

    Psrs(s) = s^2 / (s^2 + 2 zeta w s + w^2),   w = 2 pi fsrs          eq. (4.54)

whose output ``ysrs = L^-1[Psrs] * usrs`` (4.55) is summarised by the initial and the
residual shock response

    gsrs(f) = sup_{t >= 0}    |ysrs(t)|                                 eq. (4.56)
    gsrs(f) = sup_{t >= Tsrs} |ysrs(t)|                                 eq. (4.57)

Exact computation.  With ``lambda = -zeta w + j wd`` and the complex modal state
``q(t) = int_0^t exp(lambda (t - s)) u(s) ds`` the oscillator position is
``Im(q) / wd`` and the relative acceleration is

    ysrs(t) = u(t) + Im(lambda^2 q(t)) / wd.

For an input held constant at ``u_k`` over ``[k h, (k + 1) h)`` (ZOH (4.59), polynomial
wave (4.60)-(4.61)) the recursion ``q_{k+1} = e^{lambda h} q_k + u_k (e^{lambda h} - 1) /
lambda`` is exact, and inside each hold interval ``ysrs`` is the damped sinusoid
``Im(c_k e^{lambda t})`` with ``c_k = (lambda^2 q_k + lambda u_k) / wd``, whose extrema
are known in closed form (:func:`damped_sine_extrema`); after the input ends
(``c_N = lambda^2 q_N / wd``) it is the free vibration giving (4.57).  For a
continuous input (callable, e.g. the half-sine (4.58)) ``q`` is integrated panel by
panel with 12-node Gauss-Legendre quadrature, exact to rounding for inputs smooth on
the panels; the initial spectrum of a continuous input is the maximum over the panel
ends (``points_per_period`` per period of the fastest oscillator, relative error about
``(pi / points_per_period)^2 / 2``).

For ``zeta = 0`` the residual spectrum is ``w |U(j w)|`` with ``U`` the Fourier transform
of the input, which relates it to the amplitude spectrum (DFT) of Fig. 4.37:
:func:`amplitude_spectrum`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from servokit._figures import save_figure
from servokit.errors import ServokitTypeError, ServokitValueError, check_finite, check_positive
from servokit.sampled.damped_sine import damped_sine_extrema

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "ShockResponseSpectrum",
    "shock_response_spectrum",
    "shock_response",
    "amplitude_spectrum",
    "half_sine",
    "spectrum_in_chunks",
    "held_samples",
    "polynomial_wave",
    "spectrum_peaks",
    "srs_plot",
]

Accel = np.ndarray | Sequence[float] | Callable[[np.ndarray], np.ndarray]
_GL_NODES = 12


@dataclass(frozen=True)
class ShockResponseSpectrum:
    """Initial (4.56) or residual (4.57) shock response spectrum.

    Attributes
    ----------
    freq_hz : ndarray
        Oscillator frequencies ``fsrs`` [Hz].
    magnitude : ndarray
        ``gsrs(fsrs)`` in the units of the input acceleration.
    damping : float
        ``zeta_srs`` of (4.54).
    kind : {"residual", "initial"}
    duration : float
        ``Tsrs`` [s], the end of the input.
    """

    freq_hz: np.ndarray
    magnitude: np.ndarray
    damping: float
    kind: str
    duration: float

    def at(self, freq_hz: float) -> float:
        """Magnitude interpolated (linearly) at ``freq_hz``."""
        return float(np.interp(freq_hz, self.freq_hz, self.magnitude))


def half_sine(duration: float, amplitude: float = 1.0) -> Callable[[np.ndarray], np.ndarray]:
    """Half-sine acceleration ``uc(t) = amplitude sin(pi t / Tsrs)``, ``0 <= t <= Tsrs`` (4.58).

    Parameters
    ----------
    duration : float
        Pulse length ``Tsrs`` [s], > 0.
    amplitude : float
        Peak acceleration (any acceleration unit).

    Returns
    -------
    callable
        ``uc(t)`` of a time array [s]: the half-sine on ``[0, Tsrs]``, zero elsewhere; pass
        it to :func:`shock_response_spectrum` with ``duration=Tsrs``.
    """
    T = float(check_finite("duration", duration))
    if T <= 0:
        raise ServokitValueError(f"duration must be > 0 s, got {duration}")
    amp = float(check_finite("amplitude", amplitude))

    def uc(t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.where((t >= 0) & (t <= T), amp * np.sin(np.pi * t / T), 0.0)

    return uc


def held_samples(accel: Callable[[np.ndarray], np.ndarray], duration: float, dt_hold: float):
    """Samples ``uc(n Tzoh)``, ``n = 0..round(Tsrs / Tzoh) - 1``, of a ZOH input (4.59).

    Parameters
    ----------
    accel : callable
        Continuous acceleration ``uc(t)`` of a time array [s] (e.g. :func:`half_sine`).
    duration : float
        Input length ``Tsrs`` [s], > 0; a whole number of ``dt_hold``.
    dt_hold : float
        Hold period ``Tzoh`` [s], > 0.

    Returns
    -------
    ndarray (round(Tsrs / Tzoh),)
        ``uc(n Tzoh)`` as floats, each to be held for ``Tzoh``.

    Raises
    ------
    ServokitValueError
        If ``duration`` is not a whole number (>= 1) of ``dt_hold``.
    """
    check_positive("dt_hold", dt_hold, "seconds")
    check_positive("duration", duration, "seconds")
    n = int(round(float(duration) / float(dt_hold)))
    if n < 1 or not np.isclose(n * dt_hold, duration, rtol=1e-9, atol=0.0):
        raise ServokitValueError(
            f"duration ({duration} s) must be a whole number of dt_hold ({dt_hold} s)"
        )
    return np.asarray(accel(np.arange(n) * float(dt_hold)), dtype=float)


def polynomial_wave(N: int, dt_hold: float, target: float = 1.0) -> np.ndarray:
    """Held samples ``Fpoly(0..N-1)`` of the 6th-order sampled-data polynomial (4.60)-(4.61).

    (4.60) is the sixth-order entry of Table 2.1, computed by
    :func:`servokit.feedforward.sampled_polynomial`; ``Fpoly(N) = 0`` is dropped because
    the input ends at ``Tsrs = N dt_hold``.

    Parameters
    ----------
    N : int
        Number of held samples (steps of the move), >= 3.
    dt_hold : float
        Hold period [s].
    target : float
        Distance the rigid body ``1/s^2`` travels, from rest to rest, under the wave.

    Returns
    -------
    ndarray (N,)
        Acceleration samples ``Fpoly(0..N-1)`` [target units / s^2], ``Fpoly(0) = 0``.
    """
    from servokit.feedforward import sampled_polynomial

    return np.asarray(sampled_polynomial(6, N, dt_hold, target), dtype=float)[:N]


def _expm1_complex(z: np.ndarray) -> np.ndarray:
    """``exp(z) - 1`` without cancellation for small ``|z|``."""
    a, b = z.real, z.imag
    return (np.expm1(a) * np.cos(b) - 2.0 * np.sin(0.5 * b) ** 2) + 1j * np.exp(a) * np.sin(b)


def _oscillators(freq_hz: object, damping: object) -> tuple[np.ndarray, float, np.ndarray]:
    f = check_finite("freq_hz", freq_hz)
    if f.ndim > 1 or f.size == 0 or np.any(f <= 0):
        raise ServokitValueError("freq_hz must be a non-empty 1-D array of frequencies > 0 Hz")
    zeta = float(check_finite("damping", damping))
    if not 0.0 <= zeta < 1.0:
        raise ServokitValueError(f"damping must lie in [0, 1), got {zeta}")
    w = 2.0 * np.pi * np.atleast_1d(f)
    lam = w * (-zeta + 1j * np.sqrt(1.0 - zeta**2))
    return np.atleast_1d(f), zeta, lam


def _sup_abs(c: np.ndarray, lam: np.ndarray, length: float | np.ndarray) -> np.ndarray:
    """``sup |Im(c e^{lam t})|`` for ``t`` in ``[0, length]``."""
    fmax, fmin = damped_sine_extrema(-lam.real, lam.imag, np.angle(c), length)
    return np.abs(c) * np.maximum(fmax, -fmin)


def _held_states(u: np.ndarray, dt_hold: float, lam: np.ndarray) -> np.ndarray:
    """``q_k`` at the hold instants ``k = 0..N`` (rows: oscillators)."""
    e = np.exp(lam * dt_hold)
    g = _expm1_complex(lam * dt_hold) / lam
    q = np.zeros((lam.size, u.size + 1), dtype=complex)
    for k, uk in enumerate(u):
        q[:, k + 1] = e * q[:, k] + g * uk
    return q


def _held_response(
    u: np.ndarray, dt_hold: float, lam: np.ndarray, track_peak: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Final ``q_N`` and, if ``track_peak``, ``sup |ysrs|`` over the input (blocks of holds)."""
    wd = lam.imag
    q = np.zeros(lam.size, dtype=complex)
    peak = np.zeros(lam.size)
    block = max(1, 2_000_000 // lam.size)
    for k0 in range(0, u.size, block):
        ub = u[k0 : k0 + block]
        states = _held_states(ub, dt_hold, lam) + (
            np.exp(np.outer(lam, np.arange(ub.size + 1) * dt_hold)) * q[:, None]
        )
        if track_peak:
            c = (lam[:, None] ** 2 * states[:, :-1] + lam[:, None] * ub[None, :]) / wd[:, None]
            peak = np.maximum(peak, _sup_abs(c, lam[:, None], dt_hold).max(axis=1))
        q = states[:, -1]
    return q, peak


def _continuous_response(
    accel: Callable[[np.ndarray], np.ndarray],
    duration: float,
    lam: np.ndarray,
    n_panels: int,
    track_peak: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Final ``q(Tsrs)`` and ``max |ysrs|`` over the panel ends (if ``track_peak``).

    ``q`` advances panel by panel, ``q_{j+1} = e^{lam h} q_j + int_0^h e^{lam (h - s)} u``,
    the integral by Gauss-Legendre; panels are processed in blocks to bound memory.
    """
    h = duration / n_panels
    x, w = np.polynomial.legendre.leggauss(_GL_NODES)
    s = 0.5 * h * (x + 1.0)
    kernel = np.exp(np.outer(lam, h - s)) * (0.5 * h * w)
    e = np.exp(lam * h)
    wd = lam.imag
    q = np.zeros(lam.size, dtype=complex)
    peak = np.zeros(lam.size)
    block = max(1, 4_000_000 // (lam.size * _GL_NODES))
    for j0 in range(0, n_panels, block):
        t0 = np.arange(j0, min(j0 + block, n_panels)) * h
        u = np.asarray(accel((t0[:, None] + s[None, :]).ravel()), dtype=float)
        contrib = kernel @ check_finite("accel(t)", u).reshape(t0.size, _GL_NODES).T
        u_end = np.asarray(accel(t0 + h), dtype=float) if track_peak else None
        for j in range(t0.size):
            q = e * q + contrib[:, j]
            if track_peak:
                y = u_end[j] + (lam**2 * q).imag / wd
                peak = np.maximum(peak, np.abs(y))
    return q, peak


def _input(accel: Accel, dt_hold: float | None, duration: float | None):
    """Normalise the input to ``("held", samples, dt)`` or ``("continuous", fn, T)``."""
    if callable(accel):
        if duration is None:
            raise ServokitValueError("a callable accel needs duration=Tsrs (seconds)")
        T = float(check_finite("duration", duration))
        if T <= 0:
            raise ServokitValueError(f"duration must be > 0 s, got {duration}")
        if dt_hold is None:
            return "continuous", accel, T
        return "held", held_samples(accel, T, float(dt_hold)), float(dt_hold)
    if isinstance(accel, str | bytes):
        raise ServokitTypeError("accel must be an array of held samples or a callable accel(t)")
    u = check_finite("accel", accel)
    if u.ndim != 1 or u.size == 0:
        raise ServokitValueError("accel must be a non-empty 1-D array of held samples")
    if dt_hold is None:
        raise ServokitValueError("held samples need dt_hold (the hold period in seconds)")
    h = float(check_finite("dt_hold", dt_hold))
    if h <= 0:
        raise ServokitValueError(f"dt_hold must be > 0 s, got {dt_hold}")
    if duration is not None and not np.isclose(duration, u.size * h, rtol=1e-9):
        raise ServokitValueError(
            f"duration={duration} disagrees with len(accel) * dt_hold = {u.size * h}; omit it"
        )
    return "held", u, h


def shock_response_spectrum(
    accel: Accel,
    dt_hold: float | None,
    freq_hz: np.ndarray | Sequence[float] | float,
    damping: float,
    *,
    kind: Literal["residual", "initial"] = "residual",
    duration: float | None = None,
    points_per_period: int = 64,
) -> ShockResponseSpectrum:
    """Shock response spectrum of an acceleration input, eqs. (4.53)-(4.57).

    Parameters
    ----------
    accel : array_like or callable
        Held samples ``u[k]`` (each held for ``dt_hold``), or a function ``accel(t)`` of a
        time array.  A callable with ``dt_hold`` is sampled and held as in (4.59); without
        ``dt_hold`` it is the continuous input (4.58).  The input is zero after ``Tsrs``.
    dt_hold : float or None
        Hold period ``Tzoh`` [s], ``None`` for a continuous input.
    freq_hz : array_like
        Oscillator frequencies ``fsrs`` [Hz], > 0.
    damping : float
        ``zeta_srs`` in [0, 1).
    kind : {"residual", "initial"}
        (4.57) or (4.56).
    duration : float, optional
        ``Tsrs`` [s]; required for a callable, implied by held samples.
    points_per_period : int
        Continuous input only: panels per period of the fastest oscillator (the
        residual spectrum is exact to rounding with the default; the initial one is
        read at panel ends).

    Returns
    -------
    ShockResponseSpectrum
    """
    if kind not in ("residual", "initial"):
        raise ServokitValueError(f"kind must be 'residual' or 'initial', got {kind!r}")
    f, zeta, lam = _oscillators(freq_hz, damping)
    mode, u, h = _input(accel, dt_hold, duration)
    wd = lam.imag
    if mode == "held":
        T = u.size * h
        q_end, inner = _held_response(u, h, lam, kind == "initial")
    else:
        T = h
        # Half a period of the fastest oscillator per panel keeps 12-node Gauss-Legendre
        # at rounding level; the initial spectrum needs the finer read-out grid.
        per_period = points_per_period if kind == "initial" else 2
        n_panels = max(32, int(np.ceil(per_period * f.max() * T)))
        q_end, inner = _continuous_response(u, T, lam, n_panels, kind == "initial")
    mag = _sup_abs(lam**2 * q_end / wd, lam, np.inf)
    if kind == "initial":
        mag = np.maximum(mag, inner)
    if not np.all(np.isfinite(mag)):
        raise ServokitValueError("shock response spectrum is not finite; check the input")
    return ShockResponseSpectrum(f, mag, zeta, kind, float(T))


def spectrum_in_chunks(
    accel: Accel,
    dt_hold: float | None,
    freq_hz: np.ndarray,
    damping: float,
    *,
    kind: Literal["residual", "initial"] = "residual",
    duration: float | None = None,
    chunk: int = 500,
    progress: Callable[[], None] | None = None,
) -> ShockResponseSpectrum:
    """:func:`shock_response_spectrum` over ``freq_hz`` in chunks of ``chunk`` oscillators
    (bounded memory), calling ``progress()`` after each chunk.

    Parameters
    ----------
    accel, dt_hold, damping, kind, duration
        As for :func:`shock_response_spectrum`.
    freq_hz : ndarray
        Oscillator frequencies [Hz].
    chunk : int
        Oscillators per call.
    progress : callable, optional
        Called once per chunk.

    Returns
    -------
    ShockResponseSpectrum
        The spectrum over all of ``freq_hz``.
    """
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    parts = []
    for i in range(0, f.size, chunk):
        parts.append(
            shock_response_spectrum(
                accel, dt_hold, f[i : i + chunk], damping, kind=kind, duration=duration
            )
        )
        if progress is not None:
            progress()
    first = parts[0]
    return ShockResponseSpectrum(
        np.concatenate([q.freq_hz for q in parts]),
        np.concatenate([q.magnitude for q in parts]),
        first.damping,
        first.kind,
        first.duration,
    )


def shock_response(
    accel: np.ndarray | Sequence[float],
    dt_hold: float,
    freq_hz: float,
    damping: float,
    t: np.ndarray,
) -> np.ndarray:
    """Exact shock response ``ysrs(t)`` (4.55) of one oscillator to held samples (Figs. 4.30, 4.36).

    Parameters
    ----------
    accel : array_like
        Held samples, each held for ``dt_hold`` [s], zero afterwards.
    dt_hold : float
        Hold period [s].
    freq_hz, damping : float
        ``fsrs`` [Hz] and ``zeta_srs`` of (4.54).
    t : ndarray
        Times [s], ``>= 0``.

    Returns
    -------
    ndarray
        ``ysrs(t)``; at a hold instant the value just after it.
    """
    _, _, lam = _oscillators([freq_hz], damping)
    _, u, h = _input(accel, dt_hold, None)
    t = check_finite("t", t)
    if np.any(t < 0):
        raise ServokitValueError("t must be >= 0 s")
    q = _held_states(u, h, lam)[0]
    lam0 = lam[0]
    k = np.minimum(np.floor(t / h).astype(int), u.size)
    uk = np.where(k < u.size, u[np.minimum(k, u.size - 1)], 0.0)
    c = (lam0**2 * q[k] + lam0 * uk) / lam0.imag
    return (c * np.exp(lam0 * (t - k * h))).imag


def amplitude_spectrum(
    accel: np.ndarray | Sequence[float], dt_hold: float, freq_hz: np.ndarray
) -> np.ndarray:
    """``|U(j w)|`` of the held input, the limit of its zero-padded DFT (Fig. 4.37).

    ``U(j w) = (1 - e^{-j w h}) / (j w) * sum_k u_k e^{-j w k h}``: the hold's low-pass
    factor times the periodic spectrum of the samples.

    Parameters
    ----------
    accel : array_like
        Held samples ``u_k``, each held for ``dt_hold``, zero afterwards.
    dt_hold : float
        Hold period ``h`` [s].
    freq_hz : ndarray
        Frequencies [Hz] (``f = 0`` gives ``|h sum_k u_k|``).

    Returns
    -------
    ndarray
        Amplitude spectrum [input units x s] at ``freq_hz``.
    """
    _, u, h = _input(accel, dt_hold, None)
    f = check_finite("freq_hz", freq_hz)
    w = 2.0 * np.pi * np.atleast_1d(f)
    phase = np.exp(-1j * np.outer(w, np.arange(u.size) * h))
    dtft = phase @ u
    hold = np.where(w > 0, -_expm1_complex(-1j * w * h) / (1j * np.where(w > 0, w, 1.0)), h)
    return np.abs(hold * dtft)


def spectrum_peaks(
    freq_hz: np.ndarray, magnitude: np.ndarray, *, rel_height: float = 0.5
) -> np.ndarray:
    """Frequencies of the local maxima at least ``rel_height`` times the global maximum.

    Parameters
    ----------
    freq_hz : ndarray (F,)
        Frequency grid [Hz].
    magnitude : ndarray (F,)
        Spectrum on that grid (e.g. ``ShockResponseSpectrum.magnitude``).
    rel_height : float
        Smallest peak kept, as a fraction of ``magnitude.max()``.

    Returns
    -------
    ndarray
        Ascending frequencies [Hz] of the interior grid points larger than the point
        before and not smaller than the point after (the first point of a flat top), with
        at least ``rel_height`` times the maximum; the two ends are never peaks.
    """
    m = np.asarray(magnitude, dtype=float)
    inner = (m[1:-1] > m[:-2]) & (m[1:-1] >= m[2:]) & (m[1:-1] >= rel_height * m.max())
    return np.asarray(freq_hz, dtype=float)[1:-1][inner]


def srs_plot(
    spectra: ShockResponseSpectrum | Sequence[ShockResponseSpectrum],
    labels: Sequence[str] | None = None,
    *,
    title: str = "Shock response spectrum",
    normalize: bool = False,
    path: str | Path | None = None,
    reference: tuple[np.ndarray, np.ndarray, str] | None = None,
    unit: str = "input units",
    marks_hz: Sequence[float] = (),
) -> Figure:
    """Draw shock response spectra against ``fsrs`` in kHz (Figs. 4.28-4.37, 4.61).

    Parameters
    ----------
    spectra : ShockResponseSpectrum or sequence of them
    labels : sequence of str, optional
        Legend entries.
    title : str
    normalize : bool
        Show each curve in dB relative to its maximum (as in Fig. 4.37).
    path : path-like, optional
        Save as PNG there and close the figure.
    reference : (freq_hz, magnitude, label), optional
        Extra curve (e.g. the amplitude spectrum of Fig. 4.37), drawn first.
    unit : str
        Unit of the magnitude (that of the input acceleration).
    marks_hz : sequence of float
        Frequencies marked by vertical lines (e.g. a resonance).

    Returns
    -------
    matplotlib.figure.Figure
    """
    import matplotlib.pyplot as plt

    items = [spectra] if isinstance(spectra, ShockResponseSpectrum) else list(spectra)
    labels = (
        list(labels) if labels is not None else [f"{s.kind}, zeta={s.damping:g}" for s in items]
    )
    fig, ax = plt.subplots(figsize=(7, 4))

    def show(fz: np.ndarray, m: np.ndarray, label: str, style: str) -> None:
        # Exact zeros of the undamped spectrum would dominate the dB scale: floor -120 dB.
        y = 20 * np.log10(np.maximum(m / m.max(), 1e-6)) if normalize else m
        ax.plot(fz / 1e3, y, style, label=label)

    if reference is not None:
        show(np.asarray(reference[0]), np.asarray(reference[1]), reference[2], "-")
    for i, (s, lab) in enumerate(zip(items, labels, strict=True)):
        show(s.freq_hz, s.magnitude, lab, ("--", "-.", ":", "-")[i % 4])
    for fm in marks_hz:
        ax.axvline(fm / 1e3, color="k", lw=0.8, ls=":")
    ax.set_xlabel("Oscillator frequency fsrs [kHz]")
    ax.set_ylabel("Normalised magnitude [dB]" if normalize else f"Magnitude [{unit}]")
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    ax.legend()
    if path is not None:  # save_figure lays the figure out once
        save_figure(fig, path)
    else:
        fig.tight_layout()
    return fig
