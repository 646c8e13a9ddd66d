"""Figures of chapter 3: transients after a switch and admissible-set slices."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.switching.admissible import AdmissibleSet

__all__ = ["transient_plot", "admissible_plot"]


def transient_plot(
    t: np.ndarray,
    panels: Sequence[tuple[str, Mapping[str, np.ndarray]]],
    *,
    xlabel: str,
    ylabel: str | Sequence[str],
    title: str,
    path: str | Path,
    band: float | None = None,
) -> Path:
    """One subplot per panel ``(panel title, {curve label: samples})`` sharing ``t``.

    ``ylabel`` is one label for all panels or one per panel.
    """
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.6), squeeze=False)
    ylabels = [ylabel] * len(panels) if isinstance(ylabel, str) else list(ylabel)
    for ax, (name, curves), yl in zip(axes[0], panels, ylabels, strict=True):
        for label, y in curves.items():
            ax.plot(t, y, ".-" if len(t) < 80 else "-", ms=3, label=label)
        if band is not None:
            for b in (-band, band):
                ax.axhline(b, color="grey", ls=":", lw=0.8)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(yl)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    return save_figure(fig, path)


def admissible_plot(
    sets: Mapping[str, AdmissibleSet],
    *,
    points: Mapping[str, np.ndarray] | None = None,
    xlabel: str,
    ylabel: str,
    title: str,
    path: str | Path,
    limits: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> Path:
    """Outlines of 2-D admissible sets with labelled points (switching conditions).

    ``limits`` = ((xmin, xmax), (ymin, ymax)) zooms in (e.g. on the conditions).
    """
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 4.6))
    for (label, s), ls in zip(sets.items(), ("-", "--", ":", "-."), strict=False):
        v = s.polygon()
        v = np.vstack([v, v[:1]])
        ax.plot(v[:, 0], v[:, 1], ls, color="k" if ls == "-" else "C0", label=label)
    for label, p in (points or {}).items():
        ax.plot(p[0], p[1], "o", ms=6, label=label)
    if limits is not None:
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    return save_figure(fig, path)
