"""A legend's box layout and position computed once per draw of the legend (issue 24).

``Legend.draw`` (matplotlib 3.11) asks its box for its extent (which lays out the
nested packers of the legend, measuring every entry, and places the box: with
``loc="best"`` by testing the candidate positions against every data vertex of the
axes), and then draws the box, which lays it out and places it again, and each packer
inside lays out its own children again while they are drawn.  Within one
``Legend.draw`` none of what these answers depend on changes (the renderer, the
entries, the axes' data and box), so :func:`memoised_legends` keeps, for the duration
of each legend's draw, the first answer of every packer's
``_get_bbox_and_child_offsets`` and of the legend's ``_findoffset`` (the ``loc`` search)
for the arguments it was given.  The legend's 0.9 s of the report's draws were
about one third box layouts and one sixth ``loc="best"`` searches, half of them repeats.

Private matplotlib API (read on matplotlib 3.11.2): installed only on a checked
version (:data:`CHECKED_VERSIONS`) and for legends whose box takes its offset from the
legend's ``_findoffset`` (as ``Legend`` sets it up); otherwise the legend draws as usual.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["legend_memo_supported", "memoised_legends"]

#: the matplotlib versions (major, minor) whose legend drawing this module follows
CHECKED_VERSIONS = ((3, 11),)


def legend_memo_supported() -> bool:
    """Whether this matplotlib's legends draw as this module follows.

    Returns
    -------
    bool
        True on a checked version with ``Legend._findoffset`` and the packers'
        ``_get_bbox_and_child_offsets(self, renderer)``.
    """
    import matplotlib
    from matplotlib.legend import Legend
    from matplotlib.offsetbox import OffsetBox

    try:
        version = tuple(int(p) for p in matplotlib.__version__.split(".")[:2])
        offsets = tuple(inspect.signature(OffsetBox._get_bbox_and_child_offsets).parameters)
        find = tuple(inspect.signature(Legend._findoffset).parameters)
    except (ValueError, TypeError, AttributeError):
        return False
    return (
        version in CHECKED_VERSIONS
        and offsets == ("self", "renderer")
        and find == ("self", "width", "height", "xdescent", "ydescent", "renderer")
    )


def _memo(func: Callable[..., Any]) -> Callable[..., Any]:
    """``func`` answering repeated calls with equal arguments from its first answer."""
    answers: dict[tuple[Any, ...], Any] = {}

    def memoised(*args: Any) -> Any:
        # the renderer by identity, the numbers by value
        key = tuple(a if isinstance(a, float | int) else id(a) for a in args)
        if key not in answers:
            answers[key] = func(*args)
        return answers[key]

    return memoised


def _packers(box: Any) -> list[Any]:
    """The packers (and padded boxes) of a legend's box tree, ``box`` included."""
    from matplotlib.offsetbox import PackerBase, PaddedBox

    found = []
    stack = [box]
    while stack:
        node = stack.pop()
        if type(node).__module__ == "matplotlib.offsetbox" and isinstance(
            node, PackerBase | PaddedBox
        ):
            found.append(node)
            stack.extend(node.get_children())
    return found


class _MemoDraw:
    """``Legend.draw`` of one legend with its layout answers kept during the draw.

    Parameters
    ----------
    legend : matplotlib.legend.Legend
        The legend, its own ``draw`` still on its class.
    """

    def __init__(self, legend: Any) -> None:
        self.legend = legend

    def __call__(self, renderer: Any) -> Any:
        """Draw the legend as ``Legend.draw`` does."""
        legend = self.legend
        box = legend._legend_box
        offset = box._offset
        packers = [p for p in _packers(box) if "_get_bbox_and_child_offsets" not in vars(p)]
        try:
            for packer in packers:
                packer._get_bbox_and_child_offsets = _memo(packer._get_bbox_and_child_offsets)
            if offset == legend._findoffset:
                box._offset = _memo(offset)
            return type(legend).draw(legend, renderer)
        finally:
            box._offset = offset
            for packer in packers:
                del packer._get_bbox_and_child_offsets


@contextmanager
def memoised_legends(fig: Figure) -> Iterator[bool]:
    """While active, each legend of ``fig`` lays out and places its box once per draw.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure about to be drawn.

    Yields
    ------
    bool
        True if installed, False on an unchecked matplotlib
        (:func:`legend_memo_supported`): the legends then draw as usual.
    """
    from matplotlib.legend import Legend

    from servokit._instance_patch import on_instances

    if not legend_memo_supported():
        yield False
        return
    legends = [ax.get_legend() for ax in fig.get_axes()] + list(fig.legends)
    # legends of matplotlib's own class only
    with on_instances((lg for lg in legends if type(lg) is Legend), "draw", _MemoDraw):
        yield True
