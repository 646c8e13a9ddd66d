"""New ticks of an axis copied from a fresh one while a figure is saved (issue 24).

Matplotlib makes a ``Tick`` for every tick location of an axis (``Axis.get_major_ticks``:
``Axis._get_tick`` then ``Axis._copy_tick_props`` from the first tick), each with three
``Line2D`` and two ``Text`` built from the rc settings and the axis' tick keywords:
0.25 ms a tick, 1 917 ticks in the report's 78 figures.  Every new tick of one axis is
built from the same inputs (the axes, the figure, the axis' tick keywords, the rc
settings), so :func:`cloned_ticks` keeps one fresh tick per axis and kind (major,
minor) and hands out copies of it: the same attribute values, new objects wherever a
fresh tick has objects of its own (its artists, their callback registries, data lists,
marker styles, paths, font properties, and the label transforms, which are made again
by the tick's own ``_get_text1_transform``/``_get_text2_transform``), the same shared
objects (axes, figure, the axes' tick-line transforms, the rc's path effects) where
fresh ticks share them.  ``_copy_tick_props`` then runs on the copy as on a fresh tick.

The copy follows matplotlib 3.11.2's ``XTick``/``YTick`` (private API): it is made only
on a checked matplotlib version (:data:`CHECKED_VERSIONS`) for exactly these classes,
and only when every attribute of the fresh tick is of a kind it knows (an immutable
value, a shared object as above, or one of the objects listed); otherwise the axis makes
its ticks as usual.  tests/test_tick_clone.py walks the object graphs of a copy and a
fresh tick and checks they are the same values with the same sharing.
"""

from __future__ import annotations

import enum
import inspect
import types
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["clone_supported", "clone_tick", "cloned_ticks", "copyable"]

#: the matplotlib versions (major, minor) whose ticks this module copies
CHECKED_VERSIONS = ((3, 11),)

#: attributes of a tick's artists that the copy makes anew (handled in _copy_artist)
_OWN = frozenset(
    {"_callbacks", "_xorig", "_yorig", "_marker", "_xy", "_x", "_y", "_path",
     "_fontproperties", "_transform"}
)  # fmt: skip
_CHILDREN = ("tick1line", "tick2line", "gridline", "label1", "label2")


def clone_supported() -> bool:
    """Whether this matplotlib's ticks are the ones this module copies.

    Returns
    -------
    bool
        True on a checked matplotlib version with ``Axis._get_tick(self, major)``.
    """
    import matplotlib
    from matplotlib.axis import Axis

    try:
        version = tuple(int(p) for p in matplotlib.__version__.split(".")[:2])
        params = tuple(inspect.signature(Axis._get_tick).parameters)
    except (ValueError, TypeError, AttributeError):
        return False
    return version in CHECKED_VERSIONS and params == ("self", "major")


def _immutable(value: Any) -> bool:
    """Whether ``value`` can be shared by two ticks (a value that cannot change in place,
    or a module's function, such as the stale callback every artist of an axes has)."""
    import numpy as np

    atoms = (bool, int, float, str, bytes, enum.Enum, np.generic, types.FunctionType)
    if value is None or isinstance(value, atoms):
        return True
    return type(value) is tuple and all(_immutable(v) for v in value)


def _shared(tick: Any) -> set[int]:
    """Ids of the objects that fresh ticks of ``tick``'s axes share (kept by a copy)."""
    import matplotlib

    axes = tick.axes
    which = "x" if tick.__name__ == "xtick" else "y"
    transform = getattr(axes, f"get_{which}axis_transform")
    objects = [axes, axes.get_figure(root=False), axes.get_figure(root=True)]
    objects += [transform(w) for w in ("tick1", "tick2", "grid")]
    objects.append(matplotlib.rcParams["path.effects"])
    return {id(o) for o in objects}


def _fresh_registry(registry: Any) -> Any:
    """An empty callback registry like the (empty) ``registry``."""
    from matplotlib.cbook import CallbackRegistry

    return CallbackRegistry(registry.exception_handler, signals=registry._signals)


def _registry_known(registry: Any) -> bool:
    """Whether ``registry`` is an empty ``CallbackRegistry`` (as a fresh artist's)."""
    from matplotlib.cbook import CallbackRegistry

    return type(registry) is CallbackRegistry and not registry.callbacks


def _artist_known(artist: Any, shared: set[int]) -> bool:
    """Whether the fresh ``Line2D`` or ``Text`` of a tick holds only state
    :func:`_copy_artist` copies."""
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    if type(artist) not in (Line2D, Text) or not _registry_known(artist._callbacks):
        return False
    for key, value in vars(artist).items():
        if key not in _OWN and not (_immutable(value) or id(value) in shared):
            return False
    if type(artist) is Text:
        return True
    xy, path = artist._xy, artist._path
    # the data arrays and path as Line2D.recache makes them (or not made yet)
    made = (xy is None and path is None) or (
        path.vertices is xy and path.codes is None and artist._drawstyle == "default"
    )
    return made and id(artist._transform) in shared


def copyable(tick: Any) -> bool:
    """Whether :func:`clone_tick` knows all the state of the fresh ``tick``.

    Parameters
    ----------
    tick : matplotlib.axis.Tick
        A tick as ``Axis._get_tick`` returned it, not changed since.

    Returns
    -------
    bool
        True for an ``XTick`` or ``YTick`` whose attributes are all immutable values,
        objects fresh ticks share, or objects the copy makes anew.
    """
    from matplotlib.axis import XTick, YTick

    if type(tick) not in (XTick, YTick) or not _registry_known(tick._callbacks):
        return False
    shared = _shared(tick)
    for key, value in vars(tick).items():
        if key not in _CHILDREN and key != "_callbacks":
            if not (_immutable(value) or id(value) in shared):
                return False
    return all(_artist_known(getattr(tick, name), shared) for name in _CHILDREN)


def _copy_artist(artist: Any) -> Any:
    """A copy of one fresh ``Line2D`` or ``Text`` of a tick (checked by
    :func:`_artist_known`): its own registry, data, marker, path, font properties."""
    from matplotlib.lines import Line2D
    from matplotlib.markers import MarkerStyle
    from matplotlib.path import Path

    new = object.__new__(type(artist))
    state = new.__dict__
    state.update(vars(artist))
    state["_callbacks"] = _fresh_registry(artist._callbacks)
    if type(artist) is Line2D:
        m = artist._marker
        state["_marker"] = MarkerStyle(
            m._marker, m._fillstyle, m._user_transform, m._user_capstyle, m._user_joinstyle
        )
        state["_xorig"], state["_yorig"] = list(artist._xorig), list(artist._yorig)
        if artist._xy is not None:
            state["_xy"] = xy = artist._xy.copy()
            state["_x"], state["_y"] = xy[:, 0], xy[:, 1]
            steps = artist._path._interpolation_steps
            state["_path"] = Path(xy, _interpolation_steps=steps)
    else:
        state["_fontproperties"] = artist._fontproperties.copy()
    return new


def _copy(tick: Any) -> Any:
    """A copy of the fresh ``tick`` (checked by :func:`copyable`)."""
    new = object.__new__(type(tick))
    state = new.__dict__
    state.update(vars(tick))
    state["_callbacks"] = _fresh_registry(tick._callbacks)
    for name in _CHILDREN:
        state[name] = _copy_artist(state[name])
    # the label transforms are the tick's own (a translation by its pad): made again
    new.label1._transform = new._get_text1_transform()[0]
    new.label2._transform = new._get_text2_transform()[0]
    return new


def clone_tick(tick: Any) -> Any:
    """A copy of the fresh ``tick`` that a new ``tick`` would equal (None if unsupported).

    Parameters
    ----------
    tick : matplotlib.axis.XTick or matplotlib.axis.YTick
        A tick as ``Axis._get_tick`` returned it, not changed since.

    Returns
    -------
    Tick or None
        The copy, or None when ``tick`` holds state this module does not know
        (:func:`copyable`).
    """
    return _copy(tick) if copyable(tick) else None


class _TickSource:
    """``Axis._get_tick`` of one axis answering with copies of one fresh tick per kind.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        The axis; its class's ``_get_tick`` makes the fresh ticks.
    """

    def __init__(self, axis: Any) -> None:
        self.axis = axis
        self._make = type(axis)._get_tick
        self._protos: dict[bool, tuple[dict[str, Any], Any]] = {}

    def __call__(self, major: bool) -> Any:
        """A new tick (``major`` or minor) equal to the one ``Axis._get_tick`` makes."""
        axis = self.axis
        kw = dict(axis._major_tick_kw if major else axis._minor_tick_kw)
        found = self._protos.get(major)
        try:
            same = found is not None and found[0] == kw
        except (TypeError, ValueError):  # keywords that do not compare (arrays)
            same = False
        if not same:
            proto = self._make(axis, major)
            # checked once; an axis whose ticks hold unknown state makes fresh ones
            if not copyable(proto):
                self._protos[major] = (kw, None)
                return proto  # fresh and unchanged: the tick asked for
            self._protos[major] = found = (kw, proto)
        return self._make(axis, major) if found[1] is None else _copy(found[1])


@contextmanager
def cloned_ticks(fig: Figure) -> Iterator[bool]:
    """While active, the axes of ``fig`` make new ticks as copies of a fresh one.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
        The figure about to be laid out and drawn.

    Yields
    ------
    bool
        True if installed, False on an unchecked matplotlib (:func:`clone_supported`):
        the ticks are then made as usual.
    """
    from servokit._instance_patch import on_instances
    from servokit._tick_memo import _axes_of

    if not clone_supported():
        yield False
        return
    with on_instances(_axes_of(fig), "_get_tick", _TickSource):
        yield True
