"""Figures of the limits of §6.3: ``ln|S|`` areas (Bode integral) and the waterbed bound."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit._lazy import control
from servokit.limits.bode import waterbed_lower_bound
from servokit.models.lti_response import lti_response

__all__ = ["bode_integral_plot", "variance_plot", "waterbed_plot"]


def bode_integral_plot(
    loop: control.TransferFunction | control.StateSpace, path: str | Path, *, n_freq: int = 4000
) -> Path:
    """``ln|S|`` against frequency with the negative and positive areas shaded (§6.3.2).

    Parameters
    ----------
    loop : SISO LTI
        Open loop.
    path : str or Path
        Figure file.
    n_freq : int
        Grid points.

    Returns
    -------
    Path
    """
    import matplotlib.pyplot as plt

    if loop.isdtime():
        f = np.linspace(0.0, 0.5 / loop.dt, n_freq)[1:]
        s = 1.0 / (1.0 + lti_response(loop, np.exp(2j * np.pi * f * loop.dt)))
        xlabel, xscale = "frequency [Hz] (up to Nyquist)", "linear"
    else:
        from servokit.models.frequency_grid import frequency_grid

        top = 10 * max(1.0, float(np.max(np.abs(loop.poles())))) / (2 * np.pi)
        f = frequency_grid(loop, top * 1e-5, top * 10, n_freq)  # no resonance clipped
        s = 1.0 / (1.0 + lti_response(loop, 2j * np.pi * f))
        xlabel, xscale = "frequency [Hz]", "log"
    ln_s = np.log(np.abs(s))
    fig, ax = plt.subplots(figsize=(7, 3.6))
    ax.plot(f, ln_s, "k", lw=1, label="ln|S|")
    ax.fill_between(f, ln_s, 0, where=ln_s < 0, color="tab:blue", alpha=0.4, label="ln|S| < 0")
    ax.fill_between(f, ln_s, 0, where=ln_s > 0, color="tab:red", alpha=0.4, label="ln|S| > 0")
    ax.set(xscale=xscale, xlabel=xlabel, ylabel="ln|S| [Np]")
    ax.set_title("Bode sensitivity integral: areas of ln|S| (book eqs. 6.17-6.19)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save_figure(fig, path)


def waterbed_plot(alpha: float, sampling_hz: float, path: str | Path, *, mark_hz: float) -> Path:
    """Lower bound (6.20) of ``||S||inf`` [dB] against the sensitivity bandwidth.

    Parameters
    ----------
    alpha : float
        Bound of ``|S|`` below the bandwidth (linear).
    sampling_hz : float
        Sampling frequency [Hz].
    path : str or Path
        Figure file.
    mark_hz : float
        Bandwidth to mark [Hz].

    Returns
    -------
    Path
    """
    import matplotlib.pyplot as plt

    fb = np.linspace(sampling_hz * 1e-3, sampling_hz * 0.3, 400)
    bound = [20 * np.log10(waterbed_lower_bound(alpha, 2 * np.pi * f / sampling_hz)) for f in fb]
    mark = 20 * np.log10(waterbed_lower_bound(alpha, 2 * np.pi * mark_hz / sampling_hz))
    fig, ax = plt.subplots(figsize=(6, 3.6))
    ax.plot(fb, bound, label=f"|S| <= {20 * np.log10(alpha):.0f} dB below the bandwidth")
    ax.plot([mark_hz], [mark], "o", label=f"{mark_hz:g} Hz: {mark:.3f} dB")
    ax.set(xlabel="sensitivity bandwidth [Hz]", ylabel="lower bound of ||S||inf [dB]")
    ax.set_title(f"Waterbed bound (book eq. 6.20), sampling {sampling_hz:g} Hz")
    ax.grid(True, alpha=0.3)
    ax.legend()
    return save_figure(fig, path)


def variance_plot(
    loop: control.TransferFunction | control.StateSpace,
    disturbance: control.TransferFunction | control.StateSpace,
    bandwidth_hz: float,
    path: str | Path,
    *,
    n_freq: int = 2000,
) -> Path:
    """``|D|^2`` and ``|S D|^2`` (the integrand of 6.13) with the bandwidth of (6.14) marked.

    Parameters
    ----------
    loop, disturbance : LTI
        Open loop and disturbance shaping filter (both continuous, or both discrete).
    bandwidth_hz : float
        ``Omega / (2 pi)`` [Hz] to mark.
    path : str or Path
        Figure file.
    n_freq : int
        Grid points.

    Returns
    -------
    Path
    """
    import matplotlib.pyplot as plt

    from servokit.models.frequency_grid import frequency_grid

    # pole-aware grids: every lightly damped peak of |S| and of the disturbance resolved
    if loop.isdtime():
        f = frequency_grid([loop, disturbance], 1e-4 / loop.dt, 0.5 / loop.dt, n_freq)
        x = np.exp(2j * np.pi * f * loop.dt)
    else:
        f = frequency_grid([loop, disturbance], bandwidth_hz * 1e-3, bandwidth_hz * 1e3, n_freq)
        x = 2j * np.pi * f
    d2 = np.abs(np.asarray(disturbance(x)).ravel()) ** 2
    s2 = np.abs(1.0 / (1.0 + np.asarray(lti_response(loop, x)).ravel())) ** 2
    fig, ax = plt.subplots(figsize=(7, 3.6))
    ax.loglog(f, d2, "--", label="|D|^2 (open loop)")
    ax.loglog(f, s2 * d2, label="|S D|^2 (closed loop)")
    ax.axvline(bandwidth_hz, color="k", ls=":", label=f"Omega = {bandwidth_hz:.3g} Hz (6.14)")
    ax.set(xlabel="frequency [Hz]", ylabel="power density [unit^2 s/rad]")
    ax.set_title("Output variance integrand (book eqs. 6.13-6.16)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save_figure(fig, path)
