"""Saving matplotlib figures the same way everywhere (layout, resolution, closing)."""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING

from servokit._io import write_atomic

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["also_save_as", "figure_title", "save_figure"]

_META_FORMATS = (".png", ".svg", ".pdf")

# formats written beside every figure (e.g. the reproduce report's SVG copies)
_EXTRA_FORMATS: ContextVar[tuple[str, ...]] = ContextVar("extra_formats", default=())


@contextmanager
def also_save_as(*formats: str) -> Iterator[None]:
    """While active, :func:`save_figure` also writes each figure as ``formats`` (``"svg"``)
    beside the requested file, same stem."""
    token = _EXTRA_FORMATS.set(tuple(f.lower().lstrip(".") for f in formats))
    try:
        yield
    finally:
        _EXTRA_FORMATS.reset(token)


def figure_title(fig: Figure) -> str:
    """The figure's suptitle and axes titles joined with " | " (empty if untitled)."""
    parts = [fig.get_suptitle()]
    parts += [ax.get_title() for ax in fig.axes]
    return " | ".join(p.strip() for p in parts if p and p.strip())


#: zlib level of the PNG files: 3 encodes the report's figures in two thirds of the CPU
#: of Pillow's default 6 for 6 % more bytes (78 figures: 0.97 s / 6.5 MB against
#: 1.44 s / 6.2 MB, ``bench/figures_cpu.py``); the pixels are the same (lossless)
PNG_COMPRESS_LEVEL = 3


def save_figure(fig: Figure, path: str | Path, *, dpi: int = 110) -> Path:
    """Lay out, save and close ``fig``; return ``path`` (closing keeps batch runs lean).

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure; closed on return.
    path : str or Path
        Image file; its suffix names the format (the copies of :func:`also_save_as`
        are written beside it).
    dpi : int
        Resolution of raster files [pixels per inch].

    Returns
    -------
    Path
        ``path``.
    """
    import matplotlib.pyplot as plt
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    # lay out at the resolution of the file: the layout pass and the draw then share
    # one renderer, whose text extents and parsed mathtext are cached (laid out at the
    # figure's 100 dpi and drawn at 110, every label was measured twice)
    fig.set_dpi(dpi)
    engine = fig.get_layout_engine()
    # a figure with a layout engine of its own (constrained, tight) is laid out when it
    # is drawn: a tight_layout pass here would be redundant
    if engine is None or isinstance(engine, PlaceHolderLayoutEngine):
        fig.tight_layout()
        # tight_layout leaves a placeholder engine, for which savefig draws the whole
        # figure once more (a "dry" draw, 30 % of a save) before the real draw; the
        # layout is done, so no engine: one draw per file
        fig.set_layout_engine(None)
    title = figure_title(fig)
    targets = [Path(path)] + [
        Path(path).with_suffix(f".{fmt}")
        for fmt in _EXTRA_FORMATS.get()
        if Path(path).suffix.lower() != f".{fmt}"
    ]
    for target in targets:
        fmt = target.suffix.lstrip(".").lower() or None
        # the title travels in the file, so a report can caption any figure
        meta = {"Title": title} if title and target.suffix.lower() in _META_FORMATS else None
        extra = {"pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}} if fmt == "png" else {}
        buf = io.BytesIO()
        fig.savefig(buf, dpi=dpi, metadata=meta, format=fmt, **extra)
        write_atomic(target, buf.getvalue())  # an interrupted run leaves no torn image
    plt.close(fig)
    return Path(path)
