"""Figures of a seek: input, its spectrum and the outputs of every plant (Figs. 2.14-2.21)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.seek.outcome import BAND, SeekOutcome
from servokit.simulate.metrics import READOUT_SUBSTEPS

__all__ = ["seek_plot"]


def seek_plot(
    outcome: SeekOutcome,
    target: float,
    title: str,
    path: Path,
    *,
    resonances_hz: Sequence[float] = (),
    bands: Sequence[tuple[float, float, float, int]] = (),
    band: float = BAND,
    unit: str = "track",
) -> Path:
    """Input, its spectrum (2.51) and all plants' outputs near the target (Figs. 2.14-2.21).

    Parameters
    ----------
    outcome : SeekOutcome
        Simulated seek (:func:`~servokit.seek.simulate_seek`).
    target : float
        Seek distance, in ``unit``.
    title : str
        Figure title.
    path : pathlib.Path
        Image file to write (its directory must exist).
    resonances_hz : sequence of float
        Mode frequencies [Hz] marked by dotted lines on the spectrum.
    bands : sequence of (float, float, float, int)
        Band weights (as :func:`~servokit.seek.hdd.table_2_4_weights`); the bands with
        ``q > 0`` are shaded.
    band : float
        Half-width of the settling band drawn around the target, in ``unit``.
    unit : str
        Position unit of the axis labels.

    Returns
    -------
    pathlib.Path
        ``path``.  Four panels: held input against time [ms], ``|Uc(f)|`` to 20 kHz, all
        outputs, and the outputs within 3 bands of the target with the worst seek time.
    """
    import matplotlib.pyplot as plt

    ff = outcome.ff
    fig, axes = plt.subplots(2, 2, figsize=(11, 7))
    t_in, u_in = ff.time_response(READOUT_SUBSTEPS, n_after=2)
    ax = axes[0, 0]
    ax.step(t_in * 1e3, u_in, where="post", color="C0")
    ax.set(
        xlabel="Time [ms]",
        ylabel="Input u_c [plant input unit]",
        title=f"Feedforward input, N = {ff.N}",
    )
    ax.grid(alpha=0.3)

    ax = axes[0, 1]
    f = np.linspace(0.0, 20e3, 2001)
    ax.plot(f * 1e-3, np.abs(ff.spectrum(f)), color="C0", label="|U_c(f)|, eq. (2.51)")
    for lo, hi, q, _ in bands:
        if q > 0:
            ax.axvspan(lo * 1e-3, hi * 1e-3, color="C1", alpha=0.25)
    for fr in resonances_hz:
        ax.axvline(fr * 1e-3, color="grey", ls=":", lw=0.8)
    # the key of the marks drawn, no more
    marks = ["shaded: weighted bands"] if any(q > 0 for _, _, q, _ in bands) else []
    marks += ["dotted: modes"] if len(resonances_hz) else []
    ax.set(
        xlabel="Frequency [kHz]",
        ylabel="Spectrum [unit s]",
        title="Input spectrum" + (f" ({'; '.join(marks)})" if marks else ""),
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")

    ms = outcome.t * 1e3
    ax = axes[1, 0]
    ax.plot(ms, outcome.y.T, lw=0.7)
    ax.axhline(target, color="k", lw=0.6)
    ax.set(
        xlabel="Time [ms]",
        ylabel=f"Position [{unit}]",
        title=f"{outcome.y.shape[0]} plant(s), Max(y) = {outcome.y.max():.6f} {unit}",
    )
    ax.grid(alpha=0.3)

    ax = axes[1, 1]
    ax.plot(ms, outcome.y.T, lw=0.7)
    for s in (-band, band):
        ax.axhline(target + s, color="k", ls="--", lw=0.8)
    ax.axvline(
        outcome.worst * 1e3, color="r", lw=1.0, label=f"seek time {outcome.worst * 1e3:.6f} ms"
    )
    ax.set_ylim(target - 3 * band, target + 3 * band)
    ax.set(
        xlabel="Time [ms]",
        ylabel=f"Position [{unit}]",
        title=f"Around the target (band +-{band:g} {unit})",
    )
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right")
    fig.suptitle(title)
    save_figure(fig, path)
    return path
