"""Figure of the sampled-data sensitivity magnitudes (book Figs. 4.3-4.8).

The compute side lives in :mod:`servokit.sampled.sensitivity`; this module only draws a
:class:`~servokit.sampled.sensitivity.SampledDataSensitivity`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from servokit._figures import save_figure
from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from servokit.sampled.sensitivity import SampledDataSensitivity

__all__ = ["sensitivity_plot"]


_LABELS = {
    "Ssd": "|Ssd|",
    "Tsd": "|Tsd|",
    "Sd": "|Sd|",
    "Td": "|Td|",
    "S_delta": "|S_Δ|",
    "T_delta": "|T_Δ|",
    "gamma_sum": "Σ_{l≠0} |Γ(ω, l)|",
    "Pd": "|Pd|",
}


def sensitivity_plot(
    result: SampledDataSensitivity,
    *,
    quantities: Sequence[str] = ("Ssd", "Tsd"),
    db: bool = True,
    title: str | None = None,
    filename: str | None = None,
    ax: Axes | None = None,
) -> Figure:
    """Plot magnitudes of ``result`` against frequency; return the matplotlib ``Figure``.

    Parameters
    ----------
    result : SampledDataSensitivity
        Output of :func:`sampled_data_sensitivity`.
    quantities : sequence of str
        Any of ``Ssd, Tsd, Sd, Td, S_delta, T_delta, gamma_sum, Pd``.
    db : bool
        Gain in dB (20 log10) instead of linear magnitude.
    filename : str, optional
        Save the figure as PNG there and close it.
    ax : matplotlib Axes, optional
        Draw into it instead of a new figure.
    title : str, optional
        Axes title (put the book's figure number in it).

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn into.
    """
    import matplotlib.pyplot as plt

    unknown = [q for q in quantities if q not in _LABELS]
    if unknown:
        raise ServokitValueError(
            f"quantities holds {unknown[0]!r}; choose from {', '.join(_LABELS)}"
        )
    if ax is None:
        fig, ax = plt.subplots(figsize=(7.0, 4.0))
    else:
        fig = ax.figure
    styles = ["-", "--", "-.", ":"]
    for i, q in enumerate(quantities):
        mag = np.abs(getattr(result, q))
        y = 20.0 * np.log10(np.maximum(mag, 1e-12)) if db else mag
        ax.plot(result.freq_hz, y, styles[i % len(styles)], label=_LABELS[q])
    nyq = 0.5 / result.dt
    ax.axvline(nyq, color="0.6", lw=0.8, ls=":", label=f"Nyquist {nyq:.0f} Hz")
    ax.set_xlabel("Frequency [Hz]")
    ax.set_ylabel("Gain [dB]" if db else "Magnitude [-]")
    ax.set_xlim(result.freq_hz.min(), result.freq_hz.max())
    ax.grid(True, alpha=0.3)
    ax.legend()
    mr = f", multirate m = {result.m}" if result.m > 1 else ""
    ax.set_title(title or f"Sampled-data sensitivity (Ts = {result.dt * 1e6:.1f} us{mr})")
    if filename is not None:
        save_figure(fig, filename, dpi=120)
    return fig
