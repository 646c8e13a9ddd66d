"""Legends laid out and placed once per draw (servokit._legend_memo): the same pixels."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from _plain_save import plain_pixels
from matplotlib.legend import Legend
from PIL import Image

from servokit import _legend_memo
from servokit._figures import save_figure
from servokit._legend_memo import legend_memo_supported, memoised_legends


def _legends():
    # loc="best" over dense data, a titled two-column legend, "expand" mode, a figure
    # legend, a legend anchored outside its axes, markers and patches as handles
    t = np.linspace(0, 10, 2000)
    fig, (a, b, c) = plt.subplots(3, 1, figsize=(6, 8))
    a.plot(t, np.sin(t), label="sin")
    a.plot(t, np.cos(3 * t) * np.exp(-t / 4), label="damped")
    a.scatter(t[::200], np.sin(t[::200]), label="samples")
    a.legend(loc="best")
    b.bar([1, 2, 3], [3, 1, 2], label="bars")
    b.plot([1, 3], [2, 2], "k--", label="level")
    b.legend(title="Title", ncols=2, loc="upper left", mode="expand")
    c.plot(t, t**0.5, label="sqrt")
    c.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0))
    fig.legend(["figure legend"], loc="lower center")
    return fig


@pytest.mark.skipif(not legend_memo_supported(), reason="unchecked matplotlib")
def test_pixels_and_one_search(tmp_path, monkeypatch):
    want = plain_pixels(_legends())
    calls = []
    find = Legend._find_best_position
    monkeypatch.setattr(
        Legend, "_find_best_position", lambda self, *a: calls.append(1) or find(self, *a)
    )
    save_figure(_legends(), tmp_path / "f.png")
    assert np.array_equal(np.asarray(Image.open(tmp_path / "f.png")), want)
    memo_calls = len(calls)
    calls.clear()
    monkeypatch.setattr(_legend_memo, "legend_memo_supported", lambda: False)
    save_figure(_legends(), tmp_path / "g.png")
    assert np.array_equal(np.asarray(Image.open(tmp_path / "g.png")), want)
    # the plain draw searches twice per draw of the loc="best" legend
    assert 0 < memo_calls < len(calls)


def test_removed_after_and_fallback(monkeypatch):
    fig = _legends()
    legends = [ax.get_legend() for ax in fig.axes] + fig.legends
    with memoised_legends(fig) as on:
        assert on == legend_memo_supported()
        fig.canvas.draw()
    assert all("draw" not in vars(lg) for lg in legends)
    box = legends[0]._legend_box
    assert box._offset == legends[0]._findoffset
    assert not any("_get_bbox_and_child_offsets" in vars(p) for p in _legend_memo._packers(box))
    monkeypatch.setattr(_legend_memo, "legend_memo_supported", lambda: False)
    with memoised_legends(fig) as on:
        assert not on
        assert all("draw" not in vars(lg) for lg in legends)
    plt.close(fig)


def test_memo_keeps_first_answer_per_arguments():
    calls = []
    memo = _legend_memo._memo(lambda *a: calls.append(a) or len(calls))
    renderer = object()
    assert memo(1.0, 2.0, renderer) == 1
    assert memo(1.0, 2.0, renderer) == 1
    assert memo(1.5, 2.0, renderer) == 2
    assert memo(1.0, 2.0, object()) == 3
    assert len(calls) == 3


@pytest.mark.skipif(not legend_memo_supported(), reason="unchecked matplotlib")
def test_answers_not_kept_across_draws():
    # a second draw after the axes moved places the legends anew
    def two_draws(memo):
        fig = _legends()
        fig.set_dpi(110)
        with memoised_legends(fig) if memo else plt.rc_context():
            fig.canvas.draw()
            fig.subplots_adjust(right=0.6, hspace=0.6)
            fig.canvas.draw()
        pixels = np.asarray(fig.canvas.buffer_rgba()).copy()
        plt.close(fig)
        return pixels

    assert np.array_equal(two_draws(True), two_draws(False))
