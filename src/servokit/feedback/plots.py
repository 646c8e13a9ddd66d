"""Figures of the feedback package: Bode plots of filters/loops and root loci."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from servokit._figures import save_figure
from servokit.feedback.margins import loop_response
from servokit.feedback.rootlocus import RootLocus

__all__ = ["bode_responses_plot", "loop_phase_deg", "root_locus_plot"]


def loop_phase_deg(L: np.ndarray) -> np.ndarray:
    """Continuous phase of each row of ``L`` [deg], its first point in (-360, 0].

    The principal value of a loop whose phase sits near -180° (integrators and a
    lead) flips between +180 and -180 from one frequency to the next and fills the panel;
    unwrapped along frequency, with every plant started on the same branch, the curves
    of a set lie together.

    Parameters
    ----------
    L : ndarray of complex
        Loop responses, one plant per row, along an increasing frequency grid.

    Returns
    -------
    ndarray
        Phase [deg], the shape of ``L``: the principal value plus whole turns.
    """
    phase = np.degrees(np.unwrap(np.angle(L), axis=-1))
    turns = np.floor(-phase[..., :1] / 360.0)  # whole turns that bring the start to (-360, 0]
    return phase + 360.0 * turns


def bode_responses_plot(
    systems: Mapping[str, Any],
    freq_hz: np.ndarray,
    *,
    path: str | Path,
    title: str,
    magnitude_only: bool = False,
    unwrap: bool = False,
) -> Path:
    """Magnitude [dB] and phase [deg] of labelled systems (LTI, ModalPlant, callable, list).

    Parameters
    ----------
    systems : mapping of str to loop
        Label -> anything :func:`~servokit.feedback.margins.loop_response` accepts.
    freq_hz : numpy.ndarray
        Frequencies [Hz].
    path : str or pathlib.Path
        Figure file.
    title : str
        Figure title (with the book's figure number).
    magnitude_only : bool
        Draw the magnitude only.
    unwrap : bool
        Continuous phase (:func:`loop_phase_deg`: no ±360° jumps, a loop's phase lag read
        down to the Nyquist frequency) instead of the book figures' principal value in
        [-180°, 180°].

    Returns
    -------
    pathlib.Path
        The written figure.
    """
    import matplotlib.pyplot as plt

    rows = 1 if magnitude_only else 2
    fig, axes = plt.subplots(rows, 1, sharex=True, figsize=(7, 3 + 2.5 * rows), squeeze=False)
    for label, sys in systems.items():
        resp, _ = loop_response(sys)
        h = resp(freq_hz)
        axes[0, 0].semilogx(freq_hz, 20 * np.log10(np.abs(h)), label=label)
        if not magnitude_only:
            phase = loop_phase_deg(h) if unwrap else np.degrees(np.angle(h))
            axes[1, 0].semilogx(freq_hz, phase, label=label)
    axes[0, 0].set_ylabel("Magnitude [dB]")
    if not magnitude_only:
        axes[1, 0].set_ylabel("Phase [deg]")
        if not unwrap:
            axes[1, 0].set_ylim(-185, 185)
    axes[-1, 0].set_xlabel("Frequency [Hz]")
    for ax in axes[:, 0]:
        ax.grid(True, which="both", alpha=0.3)
    axes[0, 0].legend(loc="best", fontsize=8)
    axes[0, 0].set_title(title)
    return save_figure(fig, path)


def root_locus_plot(
    locus: RootLocus,
    filter_branch: np.ndarray,
    *,
    path: str | Path,
    title: str,
    window_hz: tuple[float, float] | None = None,
    real_window_hz: tuple[float, float] | None = None,
) -> Path:
    """Branches of a root locus in [kHz]: filter branches solid, others dashed (Figs. 5.16-5.22).

    Parameters
    ----------
    locus : RootLocus
        Tracked branches.
    filter_branch : numpy.ndarray of bool
        Which branches start at a filter pole.
    path : str or pathlib.Path
        Figure file.
    title : str
        Figure title.
    window_hz : tuple of float, optional
        Only branches starting in this band of Im s / 2π are drawn, axes zoomed on it.
    real_window_hz : tuple of float, optional
        Real-axis range [Hz].

    Returns
    -------
    pathlib.Path
        The written figure.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 5))
    r = locus.roots / (2e3 * np.pi)
    for j in range(r.shape[1]):
        if window_hz is not None and not window_hz[0] <= r[0, j].imag * 1e3 <= window_hz[1]:
            continue
        style = "-" if filter_branch[j] else "--"
        label = "filter pole" if filter_branch[j] else "plant pole"
        ax.plot(r[:, j].real, r[:, j].imag, style, lw=1.2, label=label)
        ax.plot(r[0, j].real, r[0, j].imag, "kx")
    ax.axvline(0.0, color="k", lw=0.6)
    if window_hz is not None:
        ax.set_ylim(window_hz[0] / 1e3, window_hz[1] / 1e3)
    if real_window_hz is not None:
        ax.set_xlim(real_window_hz[0] / 1e3, real_window_hz[1] / 1e3)
    ax.set_xlabel("Real axis [kHz]  (s / 2π)")
    ax.set_ylabel("Imaginary axis [kHz]  (s / 2π)")
    handles, labels = ax.get_legend_handles_labels()
    uniq = dict(zip(labels, handles, strict=True))
    ax.legend(uniq.values(), uniq.keys(), loc="best", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax.set_title(title)
    return save_figure(fig, path)
