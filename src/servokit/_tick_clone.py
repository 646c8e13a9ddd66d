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

While the figure is saved, the axes' ``_copy_tick_props`` is :class:`TickProps`:
matplotlib's copy of the first tick's properties onto each new tick, except that the
markers of the three tick lines, which ``Line2D.update_from`` deep-copies (0.1 ms of the
0.12 ms a tick), are made again from their arguments wherever the source marker holds
exactly the state those arguments make (:func:`same_marker`); tests compare the result
with matplotlib's copy.
"""

from __future__ import annotations

import enum
import inspect
import operator
import types
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["TickProps", "clone_supported", "clone_tick", "cloned_ticks", "copyable", "same_marker"]

#: the matplotlib versions (major, minor) whose ticks this module copies
CHECKED_VERSIONS = ((3, 11),)

#: attributes of a tick's artists that the copy makes anew (handled in _copy_artist)
_OWN = frozenset(
    {"_callbacks", "_xorig", "_yorig", "_marker", "_xy", "_x", "_y", "_path",
     "_fontproperties", "_transform"}
)  # fmt: skip
_CHILDREN = ("tick1line", "tick2line", "gridline", "label1", "label2")
_LINES = _CHILDREN[:3]


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
    from matplotlib.path import Path

    new = object.__new__(type(artist))
    state = new.__dict__
    state.update(vars(artist))
    state["_callbacks"] = _fresh_registry(artist._callbacks)
    if type(artist) is Line2D:
        state["_marker"] = _rebuilt(artist._marker)
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


def _rebuilt(marker: Any) -> Any:
    """A new ``MarkerStyle`` from the arguments ``marker`` was made with; a user transform
    is copied (as matplotlib's deep copy of the marker copies it), not shared."""
    import copy

    from matplotlib.markers import MarkerStyle

    m = marker
    user = None if m._user_transform is None else copy.deepcopy(m._user_transform)
    return MarkerStyle(m._marker, m._fillstyle, user, m._user_capstyle, m._user_joinstyle)


def _same_value(key: str, x: Any, y: Any) -> bool:
    import numpy as np
    from matplotlib.path import Path
    from matplotlib.transforms import Transform

    if key == "_marker_function":  # bound to each marker: the same function
        return getattr(x, "__func__", x) is getattr(y, "__func__", y)
    if isinstance(x, Path) or isinstance(y, Path):
        return (
            type(x) is type(y)
            and np.array_equal(x.vertices, y.vertices)
            and (x.codes is None) == (y.codes is None)
            and (x.codes is None or np.array_equal(x.codes, y.codes))
            and x._interpolation_steps == y._interpolation_steps
        )
    if isinstance(x, Transform) or isinstance(y, Transform):
        return type(x) is type(y) and np.array_equal(x.get_matrix(), y.get_matrix())
    if isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
        return type(x) is type(y) and np.array_equal(x, y)
    return type(x) is type(y) and bool(x == y)


def same_marker(a: Any, b: Any) -> bool:
    """Whether two ``MarkerStyle`` hold the same state: the same attributes, equal
    values, paths and transforms equal as data, the same marker function.

    Parameters
    ----------
    a, b : matplotlib.markers.MarkerStyle

    Returns
    -------
    bool
    """
    va, vb = vars(a), vars(b)
    if va.keys() != vb.keys():
        return False
    try:
        return all(_same_value(k, va[k], vb[k]) for k in va)
    except (TypeError, ValueError):  # values that do not compare: not known
        return False


def _state(marker: Any) -> tuple:
    """What a change of ``marker`` in place alters (polar ticks rotate its transform at
    every ``update_position``): its attributes' objects and its transforms' matrices."""
    d = vars(marker)
    moved = [d.get(k) for k in ("_transform", "_alt_transform")]
    mats = tuple(t.get_matrix().tobytes() for t in moved if t is not None)
    return tuple(d), tuple(d.values()), mats


def _same_state(a: tuple, b: tuple) -> bool:
    return a[0] == b[0] and all(map(operator.is_, a[1], b[1])) and a[2] == b[2]


class TickProps:
    """``Axis._copy_tick_props`` of one axis with the tick lines' markers rebuilt.

    Matplotlib's copy runs ``Line2D.update_from`` on the three lines of every new tick,
    each deep-copying the first tick's ``MarkerStyle`` (its paths, transforms and, through
    its bound marker function, the marker once more): 32 µs a line, 0.1 ms of the 0.12 ms
    a tick takes to copy.  A marker that holds exactly the state its arguments make
    (checked once per source marker, and again once it changed in place:
    :func:`same_marker`) is instead made again from them, as a fresh tick's is (8 µs); the
    other properties are copied by matplotlib's own method.  Any other marker is
    deep-copied as before.

    Parameters
    ----------
    axis : matplotlib.axis.Axis
        The axis whose method this replaces while installed.
    """

    def __init__(self, axis: Any) -> None:
        self.axis = axis
        self._plain = type(axis)._copy_tick_props
        self._known: dict[int, tuple[Any, tuple, bool]] = {}

    def _rebuildable(self, marker: Any) -> bool:
        found = self._known.get(id(marker))
        state = _state(marker)
        if found is None or found[0] is not marker or not _same_state(found[1], state):
            found = (marker, state, same_marker(_rebuilt(marker), marker))
            self._known[id(marker)] = found
        return found[2]

    def __call__(self, src: Any, dest: Any) -> None:
        """Copy the properties of tick ``src`` to tick ``dest``."""
        if src is None or dest is None:
            return
        lines = [getattr(src, name, None) for name in _LINES]
        markers = [getattr(line, "_marker", None) for line in lines]
        if not all(m is not None and self._rebuildable(m) for m in markers):
            self._plain(self.axis, src, dest)
            return
        try:  # matplotlib's copy, with a marker that is cheap to copy in the source lines
            for line in lines:
                line._marker = "none"
            self._plain(self.axis, src, dest)
        finally:
            for line, marker in zip(lines, markers, strict=True):
                line._marker = marker
        for name, marker in zip(_LINES, markers, strict=True):
            getattr(dest, name)._marker = _rebuilt(marker)


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
    axes = list(_axes_of(fig))
    with (
        on_instances(axes, "_get_tick", _TickSource),
        on_instances(axes, "_copy_tick_props", TickProps),
    ):
        yield True
