"""Text on matplotlib's Agg renderer with its FreeType work kept across figures (issue 24).

Every figure gets a new ``RendererAgg``, and every renderer measures and draws its
texts from scratch: ``get_text_width_height_descent`` loads and hints every glyph of
a string (``FT2Font.set_text``, 0.4 ms a string), ``draw_text`` shapes the string again
(``FT2Font._layout``) and renders each glyph (``_render_glyph``, with FreeType's
autohinter, 60 us a glyph), although the report's 78 figures draw the same few hundred
strings (599 distinct of 2292) in the same fonts.  :func:`cached_agg_text` puts three
process-wide caches in front of one renderer while a figure is saved:

- the width, height and descent of a string, per font object (which stands for its
  files, hinting factor and kerning factor), size, dpi, string and hinting flags;
- the shaped glyphs of a string (``FT2Font._layout``), under the same key plus the
  text's font features and language;
- the bitmap of a glyph, per font object, size, dpi, glyph, hinting flags, render mode,
  rotation matrix and the sub-pixel (1/64 pixel) part of its position.  FreeType renders
  a glyph translated by whole pixels as the same bitmap moved by those pixels (the
  outline is moved by a multiple of 64 units, the pixel grid of its box with it), so
  the bitmap rendered at the sub-pixel offset and moved is the one matplotlib renders.

The renderer's fonts are read from memory while the caches are installed
(:mod:`servokit._memory_fonts`: FreeType's reads of a font file otherwise go through
Python and two system calls each).

Math text (``10^k`` tick labels) is parsed by one parser shared by all renderers, whose
cache of parses then serves every figure.  The drawn pixels are those of plain matplotlib
(checked on the report's 78 figures and in tests/test_agg_text.py).

The wrapped methods and the font calls are private matplotlib API, read on matplotlib
3.11.2: the caches are installed only on matplotlib 3.11 with the methods present
(:func:`agg_text_supported`); otherwise the renderer is left as it is.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["agg_text_supported", "cached_agg_text", "clear_caches"]

#: the matplotlib versions (major, minor) whose Agg text path this module follows
CHECKED_VERSIONS = ((3, 11),)

#: entries per cache before it is emptied (a bound on memory in long sessions)
MAX_ENTRIES = 50_000

_METRICS: dict[tuple[Any, ...], tuple[float, float, float]] = {}
_LAYOUTS: dict[tuple[Any, ...], tuple[float, tuple[tuple[Any, int, float, float], ...]]] = {}
_BITMAPS: dict[tuple[Any, ...], tuple[Any, int, int]] = {}
# the shared math text parsers, one per rc fingerprint (a parse reads the mathtext.*
# settings, which its cache key does not hold), made on first use
_PARSERS: dict[tuple[Any, ...], Any] = {}


def clear_caches() -> None:
    """Forget every kept metric, layout, bitmap and math parse."""
    _METRICS.clear()
    _LAYOUTS.clear()
    _BITMAPS.clear()
    _PARSERS.clear()


def _signature(func: Any) -> tuple[str, ...]:
    """Parameter names of ``func`` (empty if it has none to inspect)."""
    try:
        return tuple(inspect.signature(func).parameters)
    except (TypeError, ValueError):
        return ()


def agg_text_supported() -> bool:
    """Whether this matplotlib's Agg text path is the one this module follows.

    Returns
    -------
    bool
        True on a checked matplotlib version (:data:`CHECKED_VERSIONS`) with the
        renderer methods and font calls the caches replace.
    """
    import matplotlib
    from matplotlib.backends import backend_agg
    from matplotlib.ft2font import FT2Font

    try:
        version = tuple(int(p) for p in matplotlib.__version__.split(".")[:2])
    except ValueError:
        return False
    renderer = backend_agg.RendererAgg
    return (
        version in CHECKED_VERSIONS
        and callable(getattr(backend_agg, "get_hinting_flag", None))
        and all(hasattr(FT2Font, n) for n in ("_layout", "_set_transform", "_render_glyph"))
        and _signature(renderer.draw_text)
        == ("self", "gc", "x", "y", "s", "prop", "angle", "ismath", "mtext")
        and _signature(renderer.get_text_width_height_descent) == ("self", "s", "prop", "ismath")
        and _signature(renderer._prepare_font) == ("self", "font_prop")
    )


def _remember(cache: dict[tuple[Any, ...], Any], key: tuple[Any, ...], value: Any) -> Any:
    """Store ``value`` under ``key`` (emptying a full cache first); return it."""
    if len(cache) >= MAX_ENTRIES:
        cache.clear()
    cache[key] = value
    return value


def _rc_fingerprint() -> tuple[tuple[str, str], ...]:
    """The rc settings a text's font, hinting and kerning come from (``font.*``,
    ``text.*``, ``mathtext.*``), as text: part of every key of the caches."""
    import matplotlib

    rc = matplotlib.rcParams
    prefixes = ("font.", "text.", "mathtext.")
    return tuple((k, repr(rc[k])) for k in sorted(rc) if k.startswith(prefixes))


class _CachedText:
    """The text methods of one renderer, answering from the process-wide caches.

    A string's key is the rc fingerprint, its font properties (the values
    ``FontProperties`` hashes), the dpi and the string, so that a hit does not even look
    the font up (``_prepare_font``); a miss computes as matplotlib does.

    Parameters
    ----------
    renderer : matplotlib.backends.backend_agg.RendererAgg
        The renderer, its own methods still on its class.
    """

    def __init__(self, renderer: Any) -> None:
        from matplotlib.backends.backend_agg import get_hinting_flag

        self.renderer = renderer
        self._metrics = renderer.get_text_width_height_descent
        self._draw_text = renderer.draw_text
        self._flags = get_hinting_flag()
        self.rc = (_rc_fingerprint(), self._flags)

    def _key(self, s: str, prop: Any) -> tuple[Any, ...]:
        return (self.rc, type(prop), tuple(vars(prop).values()), self.renderer.dpi, s)

    def metrics(self, s: str, prop: Any, ismath: Any) -> Any:
        """``get_text_width_height_descent``, plain text's answers kept."""
        if ismath is not False:
            return self._metrics(s, prop, ismath)  # math: the shared parser keeps it
        key = self._key(s, prop)
        found = _METRICS.get(key)
        return (
            found if found is not None else _remember(_METRICS, key, self._metrics(s, prop, ismath))
        )

    def draw_text(
        self,
        gc: Any,
        x: float,
        y: float,
        s: str,
        prop: Any,
        angle: float,
        ismath: Any = False,
        mtext: Any = None,
    ) -> None:
        """``RendererAgg.draw_text``; plain text from kept shaped strings and glyphs."""
        if ismath:
            return self._draw_text(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)
        features = mtext.get_fontfeatures() if mtext is not None else None
        language = mtext.get_language() if mtext is not None else None
        key = (*self._key(s, prop), features, language)
        try:
            found = _LAYOUTS.get(key)
        except TypeError:  # unhashable features or language
            return self._draw_text(gc, x, y, s, prop, angle, ismath=ismath, mtext=mtext)
        if found is None:
            font = self.renderer._prepare_font(prop)
            flags = self._flags
            shaped = font._layout(s, flags=flags, features=features, language=language)
            items = tuple((i.ft_object, i.glyph_index, i.x, i.y) for i in shaped)
            found = _remember(_LAYOUTS, key, (prop.get_size_in_points(), items))
        size, items = found
        _draw_glyphs(self.renderer, gc, x, y, angle, size, self._flags, items)
        return None


def _draw_glyphs(
    renderer: Any,
    gc: Any,
    x: float,
    y: float,
    angle: float,
    size: float,
    flags: Any,
    items: tuple[tuple[Any, int, float, float], ...],
) -> None:
    """The glyph loop of ``RendererAgg._draw_text_glyphs_and_boxes`` (no slant, no
    extension, no boxes: plain text), each bitmap rendered once per sub-pixel offset."""
    import numpy as np
    from matplotlib.ft2font import RenderMode

    cos = math.cos(math.radians(angle))
    sin = math.sin(math.radians(angle))
    # as matplotlib computes it per glyph, with extend 1 and slant 0
    matrix = (0x10000 * np.array([[cos, -sin], [sin, cos]]) @ [[1, 0], [0, 1]]).round().astype(int)
    matrix_key = tuple(matrix.ravel().tolist())
    antialiased = gc.get_antialiased()
    mode = RenderMode.NORMAL if antialiased else RenderMode.MONO
    dpi, height = renderer.dpi, renderer.height
    draw = renderer._renderer.draw_text_image
    for font, glyph, dx, dy in items:  # dy is upwards, y downwards
        px = round(0x40 * (x + dx * cos - dy * sin))
        py = round(0x40 * (height - y + dx * sin + dy * cos))  # FreeType's y is upwards
        key = (font, size, dpi, glyph, flags, antialiased, matrix_key, px & 63, py & 63)
        found = _BITMAPS.get(key)
        if found is None:
            font.set_size(size, dpi)
            font._set_transform(matrix, [px & 63, py & 63])
            bitmap = font._render_glyph(glyph, flags, mode)
            buffer = bitmap.buffer if antialiased else bitmap.buffer * 0xFF
            found = _remember(_BITMAPS, key, (buffer, bitmap.left, bitmap.top))
        buffer, left, top = found
        # draw_text_image's y is downwards & the bitmap bottom side
        draw(buffer, left + (px >> 6), int(height) - (top + (py >> 6)) + buffer.shape[0], 0, gc)


def _shared_parser(rc: tuple[Any, ...]) -> Any:
    """The math text parser shared by the renderers under the rc settings ``rc`` (its
    parse cache serves them all)."""
    parser = _PARSERS.get(rc)
    if parser is None:
        from matplotlib.mathtext import MathTextParser

        parser = _remember(_PARSERS, rc, MathTextParser("path"))
    return parser


@contextmanager
def cached_agg_text(renderer: Any) -> Iterator[bool]:
    """While active, ``renderer`` measures and draws text through the shared caches.

    Parameters
    ----------
    renderer : matplotlib.backends.backend_agg.RendererAgg
        The renderer a figure is laid out and drawn with.

    Yields
    ------
    bool
        True if the caches are installed, False if not supported
        (:func:`agg_text_supported`) or not an Agg renderer: it then works as usual.
    """
    from matplotlib.backends.backend_agg import RendererAgg

    if (
        type(renderer) is not RendererAgg
        # already wrapped (a nested block) or patched by its owner
        or any(n in vars(renderer) for n in ("draw_text", "get_text_width_height_descent"))
        or not hasattr(getattr(renderer, "_renderer", None), "draw_text_image")
        or not agg_text_supported()
    ):
        yield False
        return
    from servokit._memory_fonts import memory_fonts_supported, prepare_font

    cached = _CachedText(renderer)
    parser = renderer.mathtext_parser
    renderer.draw_text = cached.draw_text
    renderer.get_text_width_height_descent = cached.metrics
    renderer.mathtext_parser = _shared_parser(cached.rc)
    # its fonts read from memory, not through a Python stream on the file
    in_memory = "_prepare_font" not in vars(renderer) and memory_fonts_supported()
    if in_memory:
        renderer._prepare_font = functools.partial(prepare_font, renderer)
    try:
        yield True
    finally:
        del renderer.draw_text
        del renderer.get_text_width_height_descent
        renderer.mathtext_parser = parser
        if in_memory:
            del renderer._prepare_font
