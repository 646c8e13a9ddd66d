"""Figures of simulated runs (compute functions in :mod:`servokit.simulate` return data;
these draw it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["pes_spectrum_plot"]


def pes_spectrum_plot(
    freq_hz: np.ndarray, psd: np.ndarray, nrpe_3sigma_percent: float, path: str | Path
) -> Path:
    """The one-sided PES power spectral density (cf. book Fig. 6.5).

    Parameters
    ----------
    freq_hz : ndarray
        Frequencies of the PSD [Hz] (the first, 0 Hz, is not drawn on the log axis).
    psd : ndarray
        PES PSD [track^2/Hz].
    nrpe_3sigma_percent : float
        NRPE 3 sigma [% of track], shown in the legend.
    path : str or Path
        Figure file (.png or .svg).

    Returns
    -------
    Path
        The file written.
    """
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    fig, ax = plt.subplots(figsize=(7, 3.6))
    ax.semilogx(
        freq_hz[1:],
        10 * np.log10(psd[1:]),
        label=f"NRPE 3sigma {nrpe_3sigma_percent:.2f} % of track",
    )
    ax.set(xlabel="frequency [Hz]", ylabel="PES PSD [dB track^2/Hz]")
    ax.set_title("PES spectrum (cf. book Fig. 6.5)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save_figure(fig, path)
