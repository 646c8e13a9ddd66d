"""Text layouts computed once per string and style while a figure is saved (issue 24).

matplotlib lays out a text (``Text._get_layout``: lines, font metrics, alignment and
rotation offsets) every time it is measured or drawn: a tick label four to six times
between the layout pass and the draw, and the many tick labels ``0``, ``1``, ``10^2``
... of a figure with the same font each on their own.  The layout is relative to the
text's anchor, so it depends only on the text and its style, not on where the text
stands: :func:`memoised_text_layout` keeps one layout per key of everything matplotlib
3.11's ``Text._get_layout`` reads (the string, the font properties, the figure's dpi,
the renderer, rotation, alignments, rotation mode, line spacing, multi-alignment and
whether the string is parsed as math) while a figure is laid out and drawn.  Wrapped
texts and TeX texts are laid out as usual.

``_get_layout`` is private matplotlib API and what it reads was checked on matplotlib
3.11.2: the memo is installed only on matplotlib 3.11 and when the method and the
attributes the key reads exist (:func:`layout_memo_supported`); otherwise texts are
laid out by plain matplotlib.  The memo sits on the ``Text`` class while a figure is
saved, so texts of other figures drawn meanwhile (another thread) go through it too;
the renderer in the key keeps their layouts apart and exact.
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["layout_memo_supported", "memoised_text_layout"]

#: the matplotlib versions (major, minor) whose ``Text._get_layout`` the key was read on
CHECKED_VERSIONS = ((3, 11),)

#: the attributes of a ``Text`` the key reads besides its public getters
_TEXT_ATTRIBUTES = (
    "_text",
    "_fontproperties",
    "_linespacing",
    "_multialignment",
    "_horizontalalignment",
    "_verticalalignment",
    "_parse_math",
)


_installed = False


def layout_memo_supported() -> bool:
    """Whether the text-layout memo can be installed on this matplotlib.

    Returns
    -------
    bool
        True on a checked matplotlib version (:data:`CHECKED_VERSIONS`) whose
        ``Text._get_layout(self, renderer)`` exists and whose texts have the attributes
        the memo's key reads.
    """
    import matplotlib
    from matplotlib.text import Text

    try:
        version = tuple(int(p) for p in matplotlib.__version__.split(".")[:2])
    except ValueError:
        return False
    method = getattr(Text, "_get_layout", None)
    if version not in CHECKED_VERSIONS or not callable(method):
        return False
    try:
        if tuple(inspect.signature(method).parameters) != ("self", "renderer"):
            return False
    except (TypeError, ValueError):
        return False
    text = Text()
    return all(hasattr(text, name) for name in _TEXT_ATTRIBUTES)


def _layout_key(text: Any, renderer: Any) -> tuple[Any, ...] | None:
    """Everything ``Text._get_layout`` reads, or None for a text laid out as usual."""
    if text.get_wrap() or text.get_usetex():
        return None  # (wrapping depends on the text's place in the figure)
    fig = text.get_figure(root=True)
    if fig is None:
        return None
    prop = text._fontproperties
    return (
        renderer,
        fig.dpi,
        text._text,
        type(prop),
        # what FontProperties hashes and compares (its __hash__ is of these values)
        tuple(vars(prop).values()),
        text.get_rotation(),
        text._horizontalalignment,
        text._verticalalignment,
        text.get_rotation_mode(),
        text._linespacing,
        text._multialignment,
        text._parse_math,
    )


@contextmanager
def memoised_text_layout() -> Iterator[bool]:
    """While active, texts with the same string and style share one layout.

    Yields
    ------
    bool
        True if the memo is installed, False if not supported
        (:func:`layout_memo_supported`): texts are then laid out as usual.
    """
    from matplotlib.text import Text

    global _installed
    if _installed or not layout_memo_supported():
        yield False  # (not supported, or already installed by an enclosing block)
        return
    original = Text._get_layout
    memo: dict[tuple[Any, ...], Any] = {}

    def _get_layout(self: Any, renderer: Any) -> Any:
        key = _layout_key(self, renderer)
        if key is None:
            return original(self, renderer)
        found = memo.get(key)
        if found is None:
            found = memo[key] = original(self, renderer)
        bbox, info, box = found
        # copies: callers may change the box they are given
        return bbox.frozen(), list(info), box

    Text._get_layout = _get_layout
    _installed = True
    try:
        yield True
    finally:
        Text._get_layout = original
        _installed = False
