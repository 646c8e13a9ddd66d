"""Figures of FRF loop shaping: Bode of L and the Nyquist plot for every plant of the set."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.feedback.plots import loop_phase_deg

__all__ = ["loopshape_plot"]


def _draw_set(ax_mag, ax_ph, ax_ny, f, L, color, label):
    """One line per plant on each axes, as one collection per axes (54 plants x 3 axes
    were 162 line artists per set, a quarter of the figure's CPU)."""
    from matplotlib.collections import LineCollection

    curves = (
        (ax_mag, np.broadcast_to(f, L.shape), 20 * np.log10(np.abs(L))),
        (ax_ph, np.broadcast_to(f, L.shape), loop_phase_deg(L)),
        (ax_ny, L.real, L.imag),
    )
    for ax, x, y in curves:
        lines = LineCollection(
            np.stack([x, y], axis=-1), colors=color, linewidths=0.6, alpha=0.6, label=label
        )
        ax.add_collection(lines)


def _magnitude_range(responses: np.ndarray, controllers: dict) -> tuple[float, float]:
    """|L| axis limits [dB] holding the curves (notch floors and dc poles aside: the
    0.5th to 99.5th percentile), 5 dB of room, never narrower than -40..60 dB."""
    mags = [20 * np.log10(np.abs(responses * K[None, :])) for K in controllers.values()]
    finite = np.concatenate([m[np.isfinite(m)] for m in mags])
    lo, hi = np.percentile(finite, [0.5, 99.5]) if finite.size else (-40.0, 60.0)
    return min(-40.0, float(lo) - 5.0), max(60.0, float(hi) + 5.0)


def loopshape_plot(
    freq_hz: np.ndarray,
    responses: np.ndarray,
    controllers: dict[str, np.ndarray],
    *,
    s_max_db: float,
    path: str | Path,
    title: str,
) -> Path:
    """Bode magnitude and phase of ``L = P K`` and its Nyquist plot, every plant drawn.

    Parameters
    ----------
    freq_hz : ndarray
        Grid [Hz].
    responses : ndarray
        Plant FRFs, shape ``(M, n)``.
    controllers : dict of str to ndarray
        Label -> controller response on the grid (e.g. initial and designed).
    s_max_db : float
        Sensitivity bound [dB]: the Nyquist plot shows the circle ``|1 + L| = 1/s_max``.
    path : str or Path
        Figure file (.png or .svg).
    title : str
        Figure title.

    Returns
    -------
    Path
        The written figure.
    """
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    fig = plt.figure(figsize=(12, 7))
    ax_mag = fig.add_subplot(2, 2, 1)
    ax_ph = fig.add_subplot(2, 2, 3, sharex=ax_mag)
    ax_ny = fig.add_subplot(1, 2, 2)
    ax_mag.set_xscale("log")
    colors = ("tab:gray", "tab:blue", "tab:orange") if len(controllers) > 1 else ("tab:blue",)
    for (label, K), color in zip(controllers.items(), colors, strict=False):
        _draw_set(ax_mag, ax_ph, ax_ny, freq_hz, responses * K[None, :], color, label)
    r = 10 ** (-s_max_db / 20)
    t = np.linspace(0, 2 * np.pi, 361)
    ax_ny.plot(
        -1 + r * np.cos(t),
        r * np.sin(t),
        "r--",
        lw=1.2,
        label=f"|1 + L| = 1/s_max ({s_max_db:.2f} dB)",
    )
    ax_ny.plot([-1], [0], "r+", ms=10)
    ax_ny.set_xlim(-3, 1.5)
    ax_ny.set_ylim(-2.5, 2)
    ax_ny.set_aspect("equal")
    ax_ny.set_xlabel("Re L")
    ax_ny.set_ylabel("Im L")
    ax_ny.set_title("Nyquist plot (zoom on -1)")
    ax_ny.legend(loc="lower right", fontsize=8)
    ax_ny.grid(True, alpha=0.3)
    ax_mag.axhline(0.0, color="k", lw=0.6)
    ax_mag.set_ylabel("|L| [dB]")
    ax_mag.set_ylim(*_magnitude_range(responses, controllers))
    ax_mag.set_title("Open loop L = P K, every plant")
    ax_mag.legend(fontsize=8)
    ax_ph.set_ylabel("arg L [deg]")
    ax_ph.set_xlabel("Frequency [Hz]")
    ax_ph.axhline(-180.0, color="k", lw=0.6)
    # ticks on multiples of 45 deg; the lag a delay piles up near Nyquist is cut at two
    # turns, as the Nyquist panel zooms on -1
    ax_ph.yaxis.set_major_locator(MaxNLocator(nbins=8, steps=[1.8, 4.5, 9, 10]))
    lo, hi = ax_ph.dataLim.y0, ax_ph.dataLim.y1
    ax_ph.set_ylim(max(lo, -720.0) - 10.0, hi + 10.0)
    for ax in (ax_mag, ax_ph):
        ax.grid(True, which="both", alpha=0.3)
    fig.suptitle(title)
    return save_figure(fig, path)
