"""Fonts read from memory for the Agg renderer's text while servokit saves a figure (issue 24).

matplotlib opens a font file with ``FT2Font(path)``, which hands FreeType a *stream*
whose reads call back into Python: a ``seek`` and a ``read`` on a buffered file, two
system calls, for every access FreeType makes while it loads a glyph.  The report's 78
figures made 284 000 ``lseek`` and 129 000 ``read`` calls on ``DejaVuSans.ttf`` this
way (``strace -c -f servokit reproduce``).  The same constructor accepts a file object:
given an ``io.BytesIO`` of the file's bytes, FreeType reads the same bytes from memory
(a 25-character string measured and rendered 3000 times: 0.49 instead of 1.53 s CPU),
and the glyphs, metrics and bitmaps are those of the file.

:func:`prepare_font` is what ``RendererAgg._prepare_font`` returns, with the font built
from memory: the font files of the properties (``fontManager._find_fonts_by_props``),
each fallback file, and the Last Resort font appended as ``matplotlib.font_manager``
does (its Macintosh character map selected), kept per file list, kerning factor, Last
Resort setting and thread (FreeType faces are not shared between threads).  The fonts
live only in this module's cache: matplotlib's own font cache, which the PDF and PS
backends read file names from (a memory font's ``fname`` is its buffer), is untouched.
A forked child forgets them, as matplotlib's cache does (a face must not be used
across a fork).

The ``FT2Font`` keywords used (``_fallback_list``, ``_kerning_factor``,
``_warn_if_used``) are private matplotlib API, read on matplotlib 3.11.2:
:func:`memory_fonts_supported` is True only on matplotlib 3.11 where a font builds this
way; otherwise callers keep matplotlib's ``_prepare_font``.
"""

from __future__ import annotations

import functools
import io
import os
import threading
from pathlib import Path
from typing import Any

__all__ = ["clear_fonts", "memory_fonts_supported", "prepare_font"]

#: the matplotlib versions (major, minor) whose font construction this module follows
CHECKED_VERSIONS = ((3, 11),)
#: fonts kept (file lists x settings x threads) before the cache is emptied
MAX_FONTS = 64

_FONTS: dict[tuple[Any, ...], Any] = {}


def clear_fonts() -> None:
    """Forget every font built from memory (the file bytes stay cached)."""
    _FONTS.clear()


if hasattr(os, "register_at_fork"):  # a face must not be used across a fork
    os.register_at_fork(after_in_child=clear_fonts)


@functools.cache
def _file_bytes(path: str) -> bytes:
    return Path(path).read_bytes()


def _face(path: str, **kwargs: Any) -> Any:
    from matplotlib import ft2font

    return ft2font.FT2Font(io.BytesIO(_file_bytes(path)), **kwargs)


def _build(paths: tuple[tuple[str, int], ...], kerning: int, last_resort: bool) -> Any:
    """The font of ``paths`` (first the face, then its fallbacks), as matplotlib builds it."""
    from matplotlib import cbook

    (first, index), *rest = paths
    fallbacks = [_face(p, face_index=i, _kerning_factor=kerning) for p, i in rest]
    resort = os.path.realpath(cbook._get_data_path("fonts", "ttf", "LastResortHE-Regular.ttf"))
    at = paths.index((resort, 0)) if (resort, 0) in paths else -1
    if at < 0 and last_resort:  # always a glyph, if only Last Resort's box
        fallbacks.append(_face(resort, _kerning_factor=kerning, _warn_if_used=True))
        at = len(fallbacks)
    font = _face(first, face_index=index, _fallback_list=fallbacks, _kerning_factor=kerning)
    # Last Resort's Unicode map is Windows-only and empty: its first map is the one to use
    if at == 0:
        font.set_charmap(0)
    elif at > 0:
        fallbacks[at - 1].set_charmap(0)
    return font


@functools.cache
def memory_fonts_supported() -> bool:
    """Whether fonts build from memory as this module expects on this matplotlib.

    Returns
    -------
    bool
        True on a checked matplotlib version (:data:`CHECKED_VERSIONS`) where the
        default font builds from its bytes with the keywords used here.
    """
    import matplotlib
    from matplotlib.font_manager import findfont

    version = tuple(int(p) for p in matplotlib.__version__.split(".")[:2] if p.isdigit())
    if version not in CHECKED_VERSIONS:
        return False
    try:
        path = os.path.realpath(findfont(matplotlib.font_manager.FontProperties()))
        _build(((path, 0),), matplotlib.rcParams["text.kerning_factor"], True)
    except (TypeError, ValueError, OSError, RuntimeError, AttributeError):
        return False
    return True


def _font_paths(font_prop: Any) -> tuple[tuple[str, int], ...]:
    """The (real path, face index) of each font file of ``font_prop``, as ``get_font``."""
    from matplotlib.font_manager import FontPath, fontManager

    return tuple(
        (os.path.realpath(f.path), f.face_index)
        if isinstance(f, FontPath)
        else (os.path.realpath(f), 0)
        for f in fontManager._find_fonts_by_props(font_prop)
    )


def prepare_font(renderer: Any, font_prop: Any) -> Any:
    """``RendererAgg._prepare_font`` with the font read from memory.

    Parameters
    ----------
    renderer : matplotlib.backends.backend_agg.RendererAgg
        The renderer (its dpi sets the font size in pixels).
    font_prop : matplotlib.font_manager.FontProperties
        The text's font properties.

    Returns
    -------
    matplotlib.ft2font.FT2Font
        The font, its buffer cleared, sized for ``font_prop`` at the renderer's dpi.
    """
    import matplotlib

    rc = matplotlib.rcParams
    key = (
        _font_paths(font_prop),
        rc["text.kerning_factor"],
        rc["font.enable_last_resort"],
        threading.get_ident(),
    )
    font = _FONTS.get(key)
    if font is None:
        if len(_FONTS) >= MAX_FONTS:
            _FONTS.clear()
        font = _FONTS[key] = _build(*key[:3])
    font._set_transform([[0x10000, 0], [0, 0x10000]], [0, 0])  # as get_font leaves it
    font.clear()
    font.set_size(font_prop.get_size_in_points(), renderer.dpi)
    return font
