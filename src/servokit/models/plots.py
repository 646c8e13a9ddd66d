"""Bode plots of modal plants (exact frequency response, delay included) and of modal fits."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.models.fit import ModalFit
from servokit.models.modal import ModalPlant

__all__ = ["bode_plot", "fit_plot"]


def bode_plot(
    plants: ModalPlant | Sequence[ModalPlant],
    freq_hz: np.ndarray | None = None,
    *,
    path: str | Path | None = None,
    title: str | None = None,
):
    """Draw magnitude [dB] and phase [deg] of one or several plants; save to ``path`` if given.

    The response is exact (:meth:`ModalPlant.freqresp`, delay included); each phase curve
    is unwrapped and starts in (-360, 0] deg.  With more than three plants the first is
    drawn bold and labelled, the others thin as unlabelled "variants".

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Plant(s) to draw.
    freq_hz : ndarray, optional
        Frequencies [Hz] (no rigid-body pole at 0 Hz); default 2000 points log-spaced from
        10 Hz to 50 kHz.
    path : str or Path, optional
        Image file to write (at 120 dpi); the figure is then closed.
    title : str, optional
        Figure title; default ``"Bode plot: <first plant's name>"``.

    Returns
    -------
    matplotlib.figure.Figure
        Two panels, magnitude and phase against frequency [Hz] on a log axis.
    """
    import matplotlib.pyplot as plt

    plist = [plants] if isinstance(plants, ModalPlant) else list(plants)
    if freq_hz is None:
        from servokit.models.frequency_grid import frequency_grid

        f = frequency_grid(plist, 10.0, 5e4, 2000)  # packed at every mode: no clipped peak
    else:
        f = np.asarray(freq_hz)
    fig, (ax_m, ax_p) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    many = len(plist) > 3
    for i, p in enumerate(plist):
        H = p.freqresp(f)
        kw = {"lw": 0.8, "alpha": 0.6} if many and i else {"lw": 1.4}
        label = p.name if (not many or i == 0) else None
        ax_m.semilogx(f, 20 * np.log10(np.abs(H)), label=label, **kw)
        phase = np.degrees(np.unwrap(np.angle(H)))
        phase -= 360.0 * np.ceil(phase[0] / 360.0)  # start in (-360, 0] as servo plots do
        ax_p.semilogx(f, phase, **kw)
    ax_m.set_ylabel("Magnitude [dB]")
    ax_p.set_ylabel("Phase [deg]")
    ax_p.set_xlabel("Frequency [Hz]")
    ax_m.grid(True, which="both", alpha=0.3)
    ax_p.grid(True, which="both", alpha=0.3)
    if many:
        ax_m.plot([], [], color="gray", lw=0.8, label=f"{len(plist) - 1} variants")
    ax_m.legend(loc="best", fontsize=8)
    ax_m.set_title(title or ("Bode plot: " + (plist[0].name or "plant")))
    if path is not None:  # save_figure lays the figure out once
        save_figure(fig, path, dpi=120)
    else:
        fig.tight_layout()
    return fig


def fit_plot(fit: ModalFit, *, path: str | Path | None = None, title: str | None = None):
    """Draw a modal fit: data and model magnitude, phase and the relative error.

    Parameters
    ----------
    fit : ModalFit
        Result of :func:`~servokit.models.fit_modal`.
    path : str or Path, optional
        Image file to write (at 120 dpi); the figure is then closed.
    title : str, optional
        Figure title; default names the plant, its mode count and the median error.

    Returns
    -------
    matplotlib.figure.Figure
        Three panels against frequency [Hz] (log axis): magnitude [dB], phase [deg] and
        relative error |model - data| / |data| [%].
    """
    import matplotlib.pyplot as plt

    f, H, G = fit.freq_hz, fit.response, fit.model
    fig, (ax_m, ax_p, ax_e) = plt.subplots(3, 1, sharex=True, figsize=(7, 8))
    ax_m.semilogx(f, 20 * np.log10(np.abs(H)), ".", ms=2, color="gray", label="data")
    ax_m.semilogx(f, 20 * np.log10(np.abs(G)), lw=1.2, color="C0", label="fitted model")
    # one unwrap of the data; the model drawn on the same 360-degree branch point by point
    ph_h = np.degrees(np.unwrap(np.angle(H)))
    ph_h -= 360.0 * np.ceil(ph_h[0] / 360.0)  # start in (-360, 0] as servo plots do
    ph_g = ph_h + np.degrees(np.angle(G / H))
    ax_p.semilogx(f, ph_h, ".", ms=2, color="gray", label="data")
    ax_p.semilogx(f, ph_g, lw=1.2, color="C0", label="fitted model")
    ax_e.semilogx(f, 100 * fit.rel_error, lw=0.8, color="C3", label="|model - data| / |data|")
    for m in fit.plant.modes:
        if m.freq_hz > 0:
            for ax in (ax_m, ax_p, ax_e):
                ax.axvline(m.freq_hz, color="k", lw=0.5, ls=":")
    ax_m.set_ylabel("Magnitude [dB]")
    ax_p.set_ylabel("Phase [deg]")
    ax_e.set_ylabel("Relative error [%]")
    ax_e.set_xlabel("Frequency [Hz]")
    for ax in (ax_m, ax_p, ax_e):
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    ax_m.set_title(
        title
        or f"Modal fit: {fit.n_modes} resonance(s), delay {fit.plant.delay * 1e6:.3g} us, "
        f"median error {100 * fit.median_error:.2g} %"
    )
    fig.tight_layout()
    if path is not None:
        save_figure(fig, path, dpi=120)
    return fig
