"""Saving matplotlib figures the same way everywhere (layout, resolution, closing)."""

from __future__ import annotations

import io
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from contextvars import ContextVar
from pathlib import Path
from typing import TYPE_CHECKING

from servokit._agg_text import cached_agg_text
from servokit._io import write_atomic
from servokit._legend_memo import memoised_legends
from servokit._png import encode_png
from servokit._text_memo import memoised_text_layout
from servokit._tick_clone import cloned_ticks
from servokit._tick_memo import memoised_ticks

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend

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
#: 1.44 s / 6.2 MB, ``bench/figures_cpu.py``); the pixels are the same (lossless).
#: Without Pillow's row filters (:mod:`servokit._png`) level 3 takes 0.34 s, 6.8 MB
PNG_COMPRESS_LEVEL = 3


def _legends_out_of_layout(fig: Figure) -> list[Legend]:
    """Take the legends placed inside their axes out of the layout pass; return them.

    A legend anchored to its axes' box (no ``bbox_to_anchor``) lies inside the axes,
    which the layout keeps whole anyway, so it cannot move the layout; measuring it
    would place it (``loc="best"`` searches the data for a free corner) once more
    before the draw places it again (0.4 s of the report's 78 figures).
    """
    legends = []
    for ax in fig.axes:
        legend = ax.get_legend()
        if legend is None or not (ax.get_visible() and legend.get_visible()):
            continue  # (an undrawn legend has no frame to check after the draw)
        if legend.get_in_layout() and legend.get_bbox_to_anchor() is ax.bbox:
            legend.set_in_layout(False)
            legends.append(legend)
    return legends


def _legends_inside(legends: list[Legend]) -> bool:
    """Whether each legend, as last drawn, lies inside its axes (frame within 1 pixel)."""
    for legend in legends:
        frame = legend.get_frame().get_window_extent()
        box = legend.axes.bbox
        if (
            frame.x0 < box.x0 - 1
            or frame.y0 < box.y0 - 1
            or frame.x1 > box.x1 + 1
            or frame.y1 > box.y1 + 1
        ):
            return False
    return True


def _lay_out(fig: Figure) -> None:
    """One ``tight_layout`` pass, unless the figure has a layout engine of its own."""
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    engine = fig.get_layout_engine()
    # a figure with a layout engine of its own (constrained, tight) is laid out when it
    # is drawn: a tight_layout pass here would be redundant
    if engine is None or isinstance(engine, PlaceHolderLayoutEngine):
        with memoised_ticks(fig):
            fig.tight_layout()
        # tight_layout leaves a placeholder engine, for which savefig draws the whole
        # figure once more (a "dry" draw, 30 % of a save) before the real draw; the
        # layout is done, so no engine: one draw per file
        fig.set_layout_engine(None)


def _plain_savefig_rc() -> bool:
    """Whether savefig would write the canvas as drawn (the default ``savefig.*`` rc)."""
    import matplotlib

    rc = matplotlib.rcParams
    return (
        rc["savefig.bbox"] in (None, "standard")
        and not rc["savefig.transparent"]
        and rc["savefig.facecolor"] == "auto"
        and rc["savefig.edgecolor"] == "auto"
    )


_SUBPLOT_PARAMS = ("left", "bottom", "right", "top", "wspace", "hspace")


def _agg_png(
    fig: Figure,
    dpi: int,
    meta: dict[str, str] | None,
    legends: list[Legend],
    params: dict[str, float],
) -> bytes:
    """Draw ``fig`` on its Agg canvas and encode the pixels (:func:`~servokit._png.encode_png`).

    Should a legend taken out of the layout stick out of its axes after all (a legend
    larger than its axes), the legends go back into the layout and the figure is laid
    out again from the subplot parameters ``params`` it had before the first layout, and
    drawn again: the image is then the one ``tight_layout`` makes of all artists.
    """
    import matplotlib
    import numpy as np

    with memoised_ticks(fig):
        fig.canvas.draw()
    if not _legends_inside(legends):
        for legend in legends:
            legend.set_in_layout(True)
        fig.subplots_adjust(**params)
        _lay_out(fig)
        with memoised_ticks(fig):
            fig.canvas.draw()
    # the metadata savefig writes into a PNG: the software, then the caller's keys
    text = {"Software": f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/"}
    return encode_png(
        np.asarray(fig.canvas.buffer_rgba()),
        dpi=dpi,
        text=text | (meta or {}),
        level=PNG_COMPRESS_LEVEL,
    )


def _write_files(
    fig: Figure,
    path: Path,
    dpi: int,
    agg_png: bool,
    legends: list[Legend],
    params: dict[str, float],
) -> None:
    """Draw the laid-out ``fig`` into ``path`` and the copies of :func:`also_save_as`.

    ``agg_png``: the first file is drawn on the figure's Agg canvas and encoded by
    :func:`_agg_png` (with ``legends`` and ``params``); the other files by ``savefig``.
    """
    title = figure_title(fig)
    targets = [path] + [
        path.with_suffix(f".{fmt}")
        for fmt in _EXTRA_FORMATS.get()
        if path.suffix.lower() != f".{fmt}"
    ]
    for target in targets:
        fmt = target.suffix.lstrip(".").lower() or None
        # the title travels in the file, so a report can caption any figure
        meta = {"Title": title} if title and target.suffix.lower() in _META_FORMATS else None
        if agg_png and target == targets[0]:
            data = _agg_png(fig, dpi, meta, legends, params)
        else:
            extra = {"pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}} if fmt == "png" else {}
            buf = io.BytesIO()
            with memoised_ticks(fig):
                fig.savefig(buf, dpi=dpi, metadata=meta, format=fmt, **extra)
            data = buf.getvalue()
        write_atomic(target, data)  # an interrupted run leaves no torn image


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
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from servokit._ticks import cache_tick_locations

    # lay out at the resolution of the file: the layout pass and the draw then share
    # one renderer, whose text extents and parsed mathtext are cached (laid out at the
    # figure's 100 dpi and drawn at 110, every label was measured twice)
    fig.set_dpi(dpi)
    # a PNG drawn on the figure's own Agg canvas (the report's case) is encoded from the
    # canvas's pixels, the same pixels savefig writes, and its legends can be checked
    # after the draw; any other first file goes through savefig, and so does every file
    # when the rc settings ask savefig for more than the canvas (a tight bounding box,
    # a transparent or other background)
    agg_png = (
        Path(path).suffix.lower() == ".png"
        and isinstance(fig.canvas, FigureCanvasAgg)
        and _plain_savefig_rc()
    )
    legends = _legends_out_of_layout(fig) if agg_png else []
    params = {k: getattr(fig.subplotpars, k) for k in _SUBPLOT_PARAMS}
    cache_tick_locations(fig)
    # one layout per string and style for both passes (and the copies' draws); the
    # FreeType work of the Agg renderer kept across figures; new ticks copied from a
    # fresh one per axis; each legend laid out and placed once per draw
    agg_text = cached_agg_text(fig.canvas.get_renderer()) if agg_png else nullcontext()
    with memoised_text_layout(), agg_text, cloned_ticks(fig), memoised_legends(fig):
        _lay_out(fig)
        _write_files(fig, Path(path), dpi, agg_png, legends, params)
    plt.close(fig)
    return Path(path)
