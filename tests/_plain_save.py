"""The image of the plain way of saving a figure, for comparisons with save_figure."""

from __future__ import annotations

import io

import matplotlib.pyplot as plt
import numpy as np
from PIL import Image


def plain_pixels(fig, dpi: int = 110) -> np.ndarray:
    """RGBA pixels of ``fig`` laid out by ``tight_layout`` (every artist) and saved by
    ``savefig`` at ``dpi``; the figure is closed."""
    fig.set_dpi(dpi)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    plt.close(fig)
    with Image.open(buf) as img:
        return np.asarray(img)
