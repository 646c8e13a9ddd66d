"""Ticks copied from a fresh one (servokit._tick_clone): the ticks matplotlib makes."""

from __future__ import annotations

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from _plain_save import plain_pixels
from PIL import Image

from servokit import _tick_clone
from servokit._figures import save_figure
from servokit._tick_clone import clone_supported, clone_tick, cloned_ticks

_ATOMS = (type(None), bool, int, float, str, bytes, complex, np.generic)


def _same_graph(a, b, pa, pb, seen=None, path="tick"):
    """Walk a copy ``a`` beside a fresh tick ``b``; ``pa``/``pb``: the ticks ``a`` was
    copied from and a second fresh tick.  Same values everywhere; ``a`` shares an object
    with ``pa`` exactly where ``b`` shares it with ``pb``.  Returns the differences."""
    seen = set() if seen is None else seen
    if (id(a), id(b)) in seen:
        return []
    seen.add((id(a), id(b)))
    if _tick_clone._immutable(b):  # a value: its identity does not matter
        return [] if type(a) is type(b) and (a == b or a != a and b != b) else [f"{path}: {a!r}"]
    if (a is pa) != (b is pb):
        return [f"{path}: sharing differs"]
    if b is pb or isinstance(b, _ATOMS) or callable(b) and not hasattr(b, "__dict__"):
        if isinstance(b, _ATOMS) and not (a == b or a != a and b != b):
            return [f"{path}: {a!r} != {b!r}"]
        return []
    if type(a) is not type(b):
        return [f"{path}: {type(a)} != {type(b)}"]
    if isinstance(b, np.ndarray):
        return [] if np.array_equal(a, b, equal_nan=True) else [f"{path}: arrays differ"]
    if isinstance(b, dict):
        if path.endswith("['_parents']"):  # weak references keyed by the parents' ids
            return [] if len(a) == len(b) else [f"{path}: {len(a)} != {len(b)} parents"]
        if a.keys() != b.keys():
            return [f"{path}: keys {set(a) ^ set(b)}"]
        return [
            d
            for k in b
            for d in _same_graph(a[k], b[k], pa.get(k), pb.get(k), seen, f"{path}[{k!r}]")
        ]
    if isinstance(b, (list, tuple)):
        if len(a) != len(b):
            return [f"{path}: lengths differ"]
        return [
            d
            for i, (x, y, px, py) in enumerate(zip(a, b, pa, pb, strict=True))
            for d in _same_graph(x, y, px, py, seen, f"{path}[{i}]")
        ]
    if hasattr(b, "__self__") and hasattr(b, "__func__"):  # bound method: its object
        return _same_graph(a.__self__, b.__self__, pa.__self__, pb.__self__, seen, path)
    if hasattr(b, "__dict__"):
        return _same_graph(vars(a), vars(b), vars(pa), vars(pb), seen, path)
    return []


def _axes_cases():
    fig, axs = plt.subplots(2, 3)
    a, b, c, d, e, f = axs.ravel()
    b.set_xscale("log")
    c.tick_params(direction="in", length=7, labelsize=6, colors="r", grid_alpha=0.5)
    c.grid(True)
    d.spines.bottom.set_position(("outward", 5))
    e.tick_params(labelrotation=30, pad=9, labeltop=True)
    f.yaxis.set_tick_params(which="minor", width=2)
    # a spine moved outwards has a tick-line transform of each tick's own: not copied
    axes = [(ax, ax is not d.xaxis) for axes in axs.ravel() for ax in (axes.xaxis, axes.yaxis)]
    return fig, axes


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
@pytest.mark.parametrize("major", [True, False])
def test_copy_equals_fresh_tick(major):
    fig, axes = _axes_cases()
    for axis, copyable in axes:
        proto, fresh, other = (axis._get_tick(major) for _ in range(3))
        copy = clone_tick(proto)
        assert (copy is not None) == copyable
        if copy is None:
            continue
        assert _same_graph(copy, fresh, proto, other) == [], axis
        # also after the props of the first tick are copied onto both
        for tick in (copy, fresh, proto, other):
            axis._copy_tick_props(axis.majorTicks[0], tick)
        assert _same_graph(copy, fresh, proto, other) == [], axis
    plt.close(fig)


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
def test_copy_is_independent():
    fig, ax = plt.subplots()
    proto = ax.xaxis._get_tick(True)
    copy = clone_tick(proto)
    copy.update_position(3.0)
    copy.label1.set_text("3")
    copy.label1.get_fontproperties().set_size(20)
    copy.tick1line.set_markersize(30)
    assert proto.get_loc() == 0 and proto.label1.get_text() == ""
    assert proto.label1.get_fontproperties().get_size() != 20
    assert proto.tick1line.get_markersize() != 30
    assert copy.label1.get_transform() is not proto.label1.get_transform()
    plt.close(fig)


def test_unknown_state_is_not_copied():
    fig, ax = plt.subplots()
    proto = ax.xaxis._get_tick(True)
    proto.label1.new_state = [1]  # a mutable attribute the copy does not know
    assert clone_tick(proto) is None
    proto = ax.xaxis._get_tick(True)
    proto.tick1line._callbacks.connect("pchanged", print)  # a fresh tick has none
    assert clone_tick(proto) is None
    plt.close(fig)


def _figure():
    f = np.geomspace(1.0, 1e4, 300)
    fig, (a, b) = plt.subplots(2, 1, sharex=True)
    a.loglog(f, 1e3 / f, label="|P|")
    a.grid(True, which="both")
    a.tick_params(which="minor", length=5, colors="g")
    b.plot(f, np.sin(f / 900))
    b.spines.left.set_position(("outward", 6))
    b.set(xlabel="Frequency [Hz]", ylabel="Output [-]")
    a.legend()
    return fig


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
def test_figure_pixels_and_fewer_fresh_ticks(tmp_path, monkeypatch):
    want = plain_pixels(_figure())
    made = []
    make = matplotlib.axis.Axis._get_tick
    monkeypatch.setattr(
        matplotlib.axis.Axis, "_get_tick", lambda self, major: made.append(1) or make(self, major)
    )
    save_figure(_figure(), tmp_path / "f.png")
    got = np.asarray(Image.open(tmp_path / "f.png"))
    assert np.array_equal(got, want)
    fresh = len(made)
    made.clear()
    with monkeypatch.context() as m:
        m.setattr(_tick_clone, "clone_supported", lambda: False)
        save_figure(_figure(), tmp_path / "g.png")
        assert np.array_equal(np.asarray(Image.open(tmp_path / "g.png")), want)
    assert fresh < len(made) / 2


def test_fallback_leaves_axes_alone(monkeypatch):
    fig = _figure()
    monkeypatch.setattr(_tick_clone, "clone_supported", lambda: False)
    with cloned_ticks(fig) as on:
        assert not on
        assert all("_get_tick" not in vars(a) for ax in fig.axes for a in (ax.xaxis, ax.yaxis))
    monkeypatch.undo()
    with cloned_ticks(fig) as on:
        assert on == clone_supported()
    assert all("_get_tick" not in vars(a) for ax in fig.axes for a in (ax.xaxis, ax.yaxis))
    plt.close(fig)


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
def test_axis_with_uncopyable_ticks_makes_fresh_ones(monkeypatch):
    fig, ax = plt.subplots()
    ax.spines.bottom.set_position(("outward", 5))  # a tick-line transform per tick
    monkeypatch.setattr(_tick_clone, "_copy", lambda tick: pytest.fail("copied"))
    with cloned_ticks(fig):
        ticks = [ax.xaxis._get_tick(True) for _ in range(3)]
    assert len({id(t) for t in ticks}) == 3
    plt.close(fig)


def _props_pair(axis, src):
    """Two fresh ticks with ``src``'s props copied: by matplotlib and by TickProps."""
    plain, fast = axis._get_tick(True), axis._get_tick(True)
    type(axis)._copy_tick_props(axis, src, plain)
    _tick_clone.TickProps(axis)(src, fast)
    return plain, fast


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
def test_tick_props_equal_matplotlibs_copy():
    fig, axes = _axes_cases()
    for axis, _ in axes:
        src = axis.get_major_ticks()[0]
        plain, fast = _props_pair(axis, src)
        for name in ("tick1line", "tick2line", "gridline"):
            a, b = getattr(fast, name), getattr(plain, name)
            assert _tick_clone.same_marker(a._marker, b._marker), (axis, name)
            assert a._marker is not src.__dict__[name]._marker
            a._marker = b._marker = None  # compared; the rest as object graphs
        # the rest: equal values, sharing with src exactly where matplotlib's copy does
        assert _same_graph(fast, plain, src, src) == [], axis
    plt.close(fig)


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
@pytest.mark.parametrize("change", ["in_place", "user_transform"])
def test_tick_props_deep_copy_a_changed_marker(change):
    from matplotlib.markers import MarkerStyle
    from matplotlib.transforms import Affine2D

    fig, ax = plt.subplots()
    src = ax.xaxis.get_major_ticks()[0]
    if change == "in_place":  # a marker changed in place, as polar ticks do
        src.tick1line._marker._transform = Affine2D().rotate(0.3)
    else:
        src.tick1line._marker = MarkerStyle(
            src.tick1line._marker.get_marker(), transform=Affine2D().rotate(0.3)
        )
    plain, fast = _props_pair(ax.xaxis, src)
    a, b = fast.tick1line._marker, plain.tick1line._marker
    assert _tick_clone.same_marker(a, b)
    want = src.tick1line._marker.get_transform().get_matrix()
    assert np.array_equal(a.get_transform().get_matrix(), want)
    if change == "user_transform":  # copied, as matplotlib does, not shared
        assert a._user_transform is not src.tick1line._marker._user_transform
    assert not np.array_equal(
        want, ax.xaxis._get_tick(True).tick1line._marker.get_transform().get_matrix()
    )
    plt.close(fig)


@pytest.mark.skipif(not clone_supported(), reason="unchecked matplotlib")
def test_tick_props_see_a_marker_changed_after_its_check():
    # polar ticks rotate their marker's transform in place at every update_position: a
    # source marker checked once and changed later must be copied with the change
    fig, ax = plt.subplots()
    src = ax.xaxis.get_major_ticks()[0]
    props = _tick_clone.TickProps(ax.xaxis)
    props(src, ax.xaxis._get_tick(True))  # the marker checked: rebuildable
    src.tick1line._marker._transform.rotate(0.3)
    fast, plain = ax.xaxis._get_tick(True), ax.xaxis._get_tick(True)
    props(src, fast)
    type(ax.xaxis)._copy_tick_props(ax.xaxis, src, plain)
    assert _tick_clone.same_marker(fast.tick1line._marker, plain.tick1line._marker)
    src.tick1line._marker._transform = plain.tick1line._marker._transform.frozen()
    props(src, fast)  # a new transform object with the same matrix: still the change
    assert _tick_clone.same_marker(fast.tick1line._marker, plain.tick1line._marker)
    plt.close(fig)
