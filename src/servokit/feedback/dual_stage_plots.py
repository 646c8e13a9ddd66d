"""Figures of the dual-stage DMS designs: Bode plots of the loops and the sensitivity
(book Figs. 5.38-5.41), one curve per design method."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.feedback.dual_stage_design import DesignResponses

__all__ = ["METHOD_LABELS", "bode_figure", "finish_magnitude_figure", "sensitivity_figure"]


#: legend label of each design method
METHOD_LABELS = {
    "gain": "gain stabilisation",
    "inverse": "inverse compensation",
    "phase": "phase stabilisation",
}


def _bode_axes(title: str):
    import matplotlib.pyplot as plt

    fig, (ax_m, ax_p) = plt.subplots(2, 1, figsize=(7.5, 6), sharex=True)
    ax_m.set_title(title)
    ax_m.set_ylabel("magnitude [dB]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_yticks(np.arange(-360, 1, 90))
    ax_p.set_xlabel("frequency [Hz]")
    for ax in (ax_m, ax_p):
        ax.set_xscale("log")
        ax.grid(True, which="both", alpha=0.3)
    return fig, ax_m, ax_p


def bode_figure(responses: dict[str, DesignResponses], attr: str, title: str, path: Path) -> Path:
    """Bode plot of one response (``vcm_loop``, ``pzt_loop`` or ``open_loop``) per method.

    Parameters
    ----------
    responses : dict of str to DesignResponses
        Frequency responses keyed by method (``"gain"``, ``"inverse"``, ``"phase"``).
    attr : {"vcm_loop", "pzt_loop", "open_loop"}
        The response plotted: ``CV PV``, ``CM PM`` or the dual-stage ``LD``.
    title : str
        Figure title (with the book's figure number).
    path : pathlib.Path
        Image file to write (its directory must exist).

    Returns
    -------
    pathlib.Path
        ``path``.  Magnitude [dB] and phase [deg, wrapped to (-360, 0]] against frequency
        [Hz], one curve per method.
    """
    fig, ax_m, ax_p = _bode_axes(title)
    for method, r in responses.items():
        h = getattr(r, attr)
        ax_m.plot(r.freq_hz, 20 * np.log10(np.abs(h)), label=METHOD_LABELS[method], lw=1)
        ax_p.plot(r.freq_hz, np.degrees(np.angle(h)) % 360.0 - 360.0, lw=1)
    ax_m.axhline(0.0, color="k", lw=0.6)
    ax_m.legend()
    return save_figure(fig, path)


def finish_magnitude_figure(fig, ax, ylabel: str, title: str, path: Path) -> Path:  # noqa: ANN001
    """Label a magnitude-vs-frequency axis, add grid and legend, save the figure.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure holding ``ax``.
    ax : matplotlib.axes.Axes
        Axis with magnitude curves against frequency [Hz].
    ylabel, title : str
        Axis label (with its unit) and title.
    path : pathlib.Path
        Image file to write.

    Returns
    -------
    pathlib.Path
        The path written.
    """
    ax.set(xlabel="frequency [Hz]", ylabel=ylabel, title=title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    return save_figure(fig, path)


def sensitivity_figure(responses: dict[str, DesignResponses], path: Path) -> Path:
    """|SD| of the DMS loops (Fig. 5.41).

    Parameters
    ----------
    responses : dict of str to DesignResponses
        Frequency responses keyed by method; their ``sensitivity`` is plotted.
    path : pathlib.Path
        Image file to write (its directory must exist).

    Returns
    -------
    pathlib.Path
        ``path``: ``|SD|`` [dB] against frequency [Hz], one curve per method.
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for method, r in responses.items():
        ax.semilogx(
            r.freq_hz, 20 * np.log10(np.abs(r.sensitivity)), label=METHOD_LABELS[method], lw=1
        )
    return finish_magnitude_figure(
        fig, ax, "|SD| [dB]", "Fig. 5.41: DMS dual-stage sensitivity SD = SV SM", path
    )
