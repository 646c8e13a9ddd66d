"""Ticks and tick-label boxes computed once per pass while a figure is saved (issue 24).

Within one layout pass (``tight_layout``) or one draw, matplotlib asks every axis for
its ticks (``Axis._update_ticks``: locations, labels, positions) and the boxes of its
tick labels (``Axis._get_ticklabel_bboxes``) again and again: the axis' own tight box
and draw, the axis label's position (``_update_label_position`` measures the tick labels
of the axis and of its aligned siblings), the offset text, the spines, and the title
position (which asks for the y axis' whole tight box).  With the axes geometry fixed the
answers do not change, so :func:`memoised_ticks` keeps the last answer of each axis for
the duration of a pass.

The answers are kept per axis under a key of what they depend on: the view limits, the
axes' box on the canvas, the dpi and the renderer (and, for the boxes, the very tick
objects of the last update).  One entry per axis: if the key changes (an axes moved by
``apply_aspect`` during the draw), the ticks are updated again and a later return to the
old key updates them again too, so the tick objects always hold the state of the last
key asked for, as they would without the memo.  A repeated ``_update_ticks`` with an
unchanged key would set the same locations and texts on the same tick objects.

Both methods are private matplotlib API (checked on matplotlib 3.11.2): the memo is
installed only when both exist with the signatures it wraps (:func:`memo_supported`);
otherwise the figure is laid out and drawn by plain matplotlib.  The memo is installed
on the figure's axis objects (instance attributes) and removed when the pass ends.
"""

from __future__ import annotations

import inspect
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["memo_supported", "memoised_ticks"]

#: the wrapped methods of ``matplotlib.axis.Axis`` and their parameters
_WRAPPED = {
    "_update_ticks": ("self",),
    "_get_ticklabel_bboxes": ("self", "ticks", "renderer"),
}


def memo_supported() -> bool:
    """Whether matplotlib's ``Axis`` has the private methods the memo wraps, as wrapped.

    Returns
    -------
    bool
        True if ``Axis._update_ticks(self)`` and
        ``Axis._get_ticklabel_bboxes(self, ticks, renderer)`` exist with these parameters.
    """
    from matplotlib.axis import Axis

    for name, params in _WRAPPED.items():
        method = getattr(Axis, name, None)
        if method is None or not callable(method):
            return False
        try:
            found = tuple(inspect.signature(method).parameters)
        except (TypeError, ValueError):
            return False
        if found != params:
            return False
    return True


def _geometry(axis: Any) -> tuple[float, ...]:
    """What an axis' ticks depend on in a pass: view limits, axes box, dpi."""
    axes = axis.axes
    return (
        *axis.get_view_interval(),
        *axes.bbox.bounds,
        axes.get_figure(root=True).dpi,
    )


class _AxisMemo:
    """The last ticks and tick-label boxes of one axis, with the key they were made for.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        The axis whose class methods compute the answers.
    """

    def __init__(self, axis: Any) -> None:
        self.axis = axis
        cls = type(axis)
        self._update = cls._update_ticks
        self._boxes = cls._get_ticklabel_bboxes
        self._ticks_key: tuple[float, ...] | None = None
        self._ticks: list[Any] = []
        self._boxes_key: tuple[float, ...] | None = None
        self._boxes_ticks: list[Any] = []
        self._boxes_renderer: Any = None
        self._boxes_value: tuple[list[Any], list[Any]] = ([], [])

    def update_ticks(self) -> list[Any]:
        """``Axis._update_ticks``, run again only when the axis' geometry changed."""
        key = _geometry(self.axis)
        if key != self._ticks_key:
            self._ticks_key = None  # (an exception leaves no half-made entry)
            self._ticks = self._update(self.axis)
            self._ticks_key = key
            self._boxes_key = None
        return list(self._ticks)

    def ticklabel_bboxes(self, ticks: list[Any], renderer: Any) -> tuple[list[Any], list[Any]]:
        """``Axis._get_ticklabel_bboxes``, measured again only for other ticks, geometry
        or renderer than last time."""
        # the same tick objects and renderer (compared by identity, and kept: a new object
        # may reuse a freed one's id), unchanged since the boxes were measured
        same = (
            self._ticks_key is not None
            and self._boxes_key == self._ticks_key
            and renderer is self._boxes_renderer
            and len(ticks) == len(self._boxes_ticks)
            and all(a is b for a, b in zip(ticks, self._boxes_ticks, strict=True))
        )
        if not same:
            self._boxes_key = None
            self._boxes_value = self._boxes(self.axis, ticks, renderer)
            self._boxes_ticks = list(ticks)
            self._boxes_renderer = renderer
            self._boxes_key = self._ticks_key
        first, second = self._boxes_value
        return list(first), list(second)


def _axes_of(fig: Figure) -> list[Any]:
    """Every axis (x and y, also of twins and insets) of ``fig``'s axes."""
    axes = fig.get_axes()
    return [
        a for ax in axes for a in getattr(ax, "_axis_map", {"x": ax.xaxis, "y": ax.yaxis}).values()
    ]


@contextmanager
def memoised_ticks(fig: Figure) -> Iterator[bool]:
    """While active, the axes of ``fig`` update their ticks and measure their tick labels
    once per geometry; yields whether the memo is installed.

    Use one ``with`` block per pass (the layout pass, the draw): the boxes of the tick
    labels are kept with the renderer and geometry they were measured for, and leaving
    the block forgets them.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure about to be laid out or drawn.

    Yields
    ------
    bool
        True if the memo is installed, False if matplotlib lacks the private methods it
        wraps (:func:`memo_supported`); the figure is then laid out and drawn as usual.
    """
    if not memo_supported():
        yield False
        return
    installed = []
    try:
        for axis in _axes_of(fig):
            if "_update_ticks" in vars(axis):
                continue  # already memoised (a nested pass) or patched by its owner
            memo = _AxisMemo(axis)
            axis._update_ticks = memo.update_ticks
            axis._get_ticklabel_bboxes = memo.ticklabel_bboxes
            installed.append(axis)
        yield True
    finally:
        for axis in installed:
            del axis._update_ticks
            del axis._get_ticklabel_bboxes
