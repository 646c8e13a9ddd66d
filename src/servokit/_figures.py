"""Saving matplotlib figures the same way everywhere (layout, resolution, closing)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["save_figure"]


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 110) -> Path:
    """Lay out, save and close ``fig``; return ``path`` (closing keeps batch runs lean)."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return Path(path)
