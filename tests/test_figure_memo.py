"""Memos of save_figure (ticks per pass, text layouts, Agg text caches): the same pixels."""

from __future__ import annotations

import inspect
from contextlib import nullcontext
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from _plain_save import plain_pixels
from hypothesis import given, settings
from hypothesis import strategies as st
from matplotlib.axis import Axis
from matplotlib.backends.backend_agg import RendererAgg
from matplotlib.font_manager import FontProperties
from matplotlib.text import Text
from PIL import Image

from servokit import _agg_text, _figures, _text_memo, _tick_memo
from servokit._figures import save_figure


def _shared_twin_log():
    # shared log x axes with aligned y labels, a twin axis, an offset text, titles
    f = np.geomspace(1.0, 1e4, 300)
    fig, (a, b, c) = plt.subplots(3, 1, sharex=True, figsize=(6, 7))
    a.loglog(f, 1e3 / f, label="|P|")
    a.set(ylabel="Magnitude [-]", title="Plant (log axes)")
    b.semilogx(f, 1e5 + 1e-3 * np.sin(f / 300), label="offset")
    b.set(ylabel="Position [nm]", title="Offset text")
    b.twinx().semilogx(f, np.cos(f / 500), "r")
    c.semilogx(f, np.degrees(np.arctan(f / 30)))
    c.set(xlabel="Frequency [Hz]", ylabel="Phase [deg]")
    c.set_title("left", loc="left")
    c.set_title("right", loc="right")
    a.legend()
    fig.align_ylabels()
    return fig


def _aspect_rotated_math():
    # equal aspect (the axes move during the draw), rotated and math tick labels, a
    # suptitle, text without antialiasing, an inset
    fig, (a, b) = plt.subplots(1, 2, figsize=(8, 4))
    t = np.linspace(0, 2 * np.pi, 100)
    a.plot(np.cos(t), 0.5 * np.sin(t))
    a.set_aspect("equal")
    a.set(xlabel="Re L", ylabel="Im L", title="Nyquist $L(j\\omega)$")
    b.plot([1, 2, 3], [1e-7, 4e-7, 2e-7])
    b.set_xticks([1, 2, 3], ["one", "two", "three"], rotation=35)
    b.set_yscale("log")
    b.set(ylabel="Error [$\\mu$m]")
    b.text(1.5, 2e-7, "plain text", antialiased=False, rotation=20)
    b.text(1.2, 3e-7, "plain text")  # the same string and style, not rotated
    b.inset_axes([0.6, 0.6, 0.3, 0.3]).plot([0, 1], [1, 0])
    fig.suptitle("Memo check")
    return fig


def _aligned_aspect():
    # aligned y labels over an axes of equal aspect: in the draw the upper axes places
    # its label with the lower one's tick labels before the lower axes applies its
    # aspect (and moves): the memo must see the move
    fig, (a, b) = plt.subplots(2, 1, figsize=(5, 6))
    a.plot([0, 1000], [0, 12345.0])
    a.set_ylabel("Force [mN]")
    b.plot([0, 4], [0, 1])
    b.set_aspect("equal")
    b.set(xlabel="x [mm]", ylabel="y [mm]")
    fig.align_ylabels()
    return fig


_MAKERS = [_shared_twin_log, _aspect_rotated_math, _aligned_aspect]


@pytest.mark.parametrize("make", _MAKERS)
def test_same_pixels_as_the_plain_save(make, tmp_path: Path) -> None:
    ref = plain_pixels(make())
    for _ in range(2):  # the Agg text caches cold (maybe), then warm
        with Image.open(save_figure(make(), tmp_path / "f.png")) as img:
            np.testing.assert_array_equal(np.asarray(img), ref)


def test_memos_removed_after_the_save(tmp_path: Path, monkeypatch) -> None:
    renderers = []

    def cached(renderer):
        renderers.append(renderer)
        return _agg_text.cached_agg_text(renderer)

    monkeypatch.setattr(_figures, "cached_agg_text", cached)
    fig = _shared_twin_log()
    layout = Text._get_layout
    save_figure(fig, tmp_path / "f.png")
    assert Text._get_layout is layout
    assert not _text_memo._installed
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            assert "_update_ticks" not in vars(axis)
            assert "_get_ticklabel_bboxes" not in vars(axis)
    (renderer,) = renderers
    assert "draw_text" not in vars(renderer)
    assert "get_text_width_height_descent" not in vars(renderer)


def _count(monkeypatch, name: str) -> list[int]:
    """Count the calls of ``Axis.<name>`` (keeping its signature, so the memo installs)."""
    original = getattr(Axis, name)
    calls = [0]

    def counted(*args, **kwargs):
        calls[0] += 1
        return original(*args, **kwargs)

    counted.__signature__ = inspect.signature(original)
    monkeypatch.setattr(Axis, name, counted)
    return calls


def test_tick_memo_computes_less(tmp_path: Path, monkeypatch) -> None:
    calls = _count(monkeypatch, "_get_ticklabel_bboxes")
    fig = _shared_twin_log()
    fig.set_dpi(110)
    fig.tight_layout()
    fig.canvas.draw()
    plain = calls[0]
    calls[0] = 0
    save_figure(_shared_twin_log(), tmp_path / "f.png")
    # once per axis and pass (layout, draw), and again only for an axes that moved
    assert 0 < calls[0] < plain / 2


def test_fallback_without_the_private_methods(tmp_path: Path, monkeypatch) -> None:
    # another matplotlib: the memos are not installed, the figure is saved as usual
    original = Axis._get_ticklabel_bboxes
    monkeypatch.setattr(
        Axis,
        "_get_ticklabel_bboxes",
        lambda self, ticks, renderer, extra=None: original(self, ticks, renderer),
    )
    monkeypatch.setattr(matplotlib, "__version__", "3.99.0")
    assert not _tick_memo.memo_supported()
    assert not _text_memo.layout_memo_supported()
    assert not _agg_text.agg_text_supported()
    fig = _shared_twin_log()
    with _tick_memo.memoised_ticks(fig) as ticks, _text_memo.memoised_text_layout() as text:
        assert not ticks and not text
    ref = plain_pixels(_shared_twin_log())
    with Image.open(save_figure(_shared_twin_log(), tmp_path / "f.png")) as img:
        np.testing.assert_array_equal(np.asarray(img), ref)


def test_supported_on_this_matplotlib() -> None:
    # checked on matplotlib 3.11.2: if this fails on a new matplotlib, read its
    # Axis._update_ticks, Text._get_layout and RendererAgg text path again
    if tuple(int(p) for p in matplotlib.__version__.split(".")[:2]) != (3, 11):
        pytest.skip("the memos were checked on matplotlib 3.11")
    assert _tick_memo.memo_supported()
    assert _text_memo.layout_memo_supported()
    assert _agg_text.agg_text_supported()


def _text_pixels(cached: bool, texts: list[tuple[str, float, float, float, bool]]) -> np.ndarray:
    """The pixels of ``texts`` (string, x, y, angle, antialiased) drawn on a new
    renderer, through the Agg text caches or not."""
    renderer = RendererAgg(120, 90, 110)
    prop = FontProperties(size=9)
    with _agg_text.cached_agg_text(renderer) if cached else nullcontext():
        for s, x, y, angle, antialiased in texts:
            gc = renderer.new_gc()
            gc.set_antialiased(antialiased)
            renderer.draw_text(gc, x, y, s, prop, angle)
            gc.restore()
    return np.asarray(renderer.buffer_rgba()).copy()


_TEXTS = st.lists(
    st.tuples(
        st.sampled_from(["0", "10", "-0.5", "Hz", "Wy", "g(j)", "±1.25"]),
        st.floats(-20.0, 130.0),
        st.floats(-20.0, 100.0),
        st.sampled_from([0.0, 90.0, 35.0, 270.0]),
        st.booleans(),
    ),
    min_size=1,
    max_size=6,
)


@settings(max_examples=40, deadline=None)
@given(texts=_TEXTS)
def test_glyph_bitmaps_moved_by_whole_pixels_are_exact(texts) -> None:
    # glyphs at any sub-pixel position, partly off the canvas, rotated, without
    # antialiasing: the cached bitmaps draw the pixels of matplotlib's own path, cold
    # and warm (the same strings drawn again elsewhere hit the caches)
    plain = _text_pixels(False, texts)
    np.testing.assert_array_equal(_text_pixels(True, texts), plain)
    moved = [(s, x + 7.0, y + 3.0, a, aa) for s, x, y, a, aa in texts]
    np.testing.assert_array_equal(_text_pixels(True, moved), _text_pixels(False, moved))


def _math_fig():
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([1, 10, 100], [1, 2, 3])
    ax.set_xscale("log")
    ax.set(xlabel="$x_k$ [m]", ylabel="$\\alpha^2$")
    return fig


def test_math_parsed_under_each_rc(tmp_path: Path) -> None:
    # the shared math parsers are per rc fingerprint: a parse reads mathtext.* settings
    # that its cache key does not hold
    for rc in ({}, {"mathtext.default": "regular"}, {}):
        with matplotlib.rc_context(rc):
            ref = plain_pixels(_math_fig())
            with Image.open(save_figure(_math_fig(), tmp_path / "f.png")) as img:
                np.testing.assert_array_equal(np.asarray(img), ref)
