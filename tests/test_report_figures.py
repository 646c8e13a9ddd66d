"""save_figure: atomic writes, the title kept in the file, SVG copies on request."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
from _plain_save import plain_pixels
from PIL import Image

from servokit._figures import also_save_as, figure_title, save_figure


def _fig():
    fig, (a, b) = plt.subplots(1, 2)
    fig.suptitle("Fig. 4.41")
    a.set_title("(a) gain")
    b.plot([0, 1])
    return fig


def test_title_joins_suptitle_and_axes_titles() -> None:
    fig = _fig()
    assert figure_title(fig) == "Fig. 4.41 | (a) gain"
    plt.close(fig)


def test_png_keeps_title_and_no_temp_file(tmp_path: Path) -> None:
    path = save_figure(_fig(), tmp_path / "f.png")
    with Image.open(path) as img:
        assert img.text["Title"] == "Fig. 4.41 | (a) gain"
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"]


def test_svg_copy_only_inside_the_context(tmp_path: Path) -> None:
    with also_save_as("svg"):
        save_figure(_fig(), tmp_path / "a.png")
    save_figure(_fig(), tmp_path / "b.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.svg", "b.png"]
    assert "<title>Fig. 4.41 | (a) gain</title>" in (tmp_path / "a.svg").read_text()


def _count_draws(fig) -> list[int]:
    """Wrap ``fig.draw`` to count full draws (layout passes of savefig)."""
    calls = [0]
    draw = fig.draw

    def counted(renderer):
        calls[0] += 1
        return draw(renderer)

    fig.draw = counted
    return calls


def test_one_draw_per_file_and_the_same_pixels(tmp_path: Path) -> None:
    # the plain save (tight_layout at the file's dpi, then savefig with tight_layout's
    # placeholder engine) draws every figure twice; save_figure draws once and writes
    # the same image
    import io

    import numpy as np

    old = _fig()
    old.set_dpi(110)
    old.tight_layout()
    buf = io.BytesIO()
    old.savefig(buf, dpi=110, metadata={"Title": figure_title(old)}, format="png")
    plt.close(old)
    fig = _fig()
    draws = _count_draws(fig)
    path = save_figure(fig, tmp_path / "f.png")
    assert draws[0] == 1
    with Image.open(path) as new, Image.open(buf) as ref:
        assert np.array_equal(np.asarray(new), np.asarray(ref))
    with also_save_as("svg"):
        fig = _fig()
        draws = _count_draws(fig)
        save_figure(fig, tmp_path / "g.png")
    assert draws[0] == 2  # one per format


def test_each_label_measured_once(tmp_path: Path) -> None:
    # the layout pass and the draw share one renderer at the file's dpi, so the text
    # extent of each string is computed once (laid out at 100 dpi and drawn at 110,
    # every string was measured twice)
    from matplotlib.backends.backend_agg import RendererAgg

    measured: list[tuple[str, float]] = []
    original = RendererAgg.get_text_width_height_descent

    def counted(self, s, prop, ismath):
        measured.append((s, self.dpi))
        return original(self, s, prop, ismath)

    fig, ax = plt.subplots()
    ax.semilogx([1, 10, 100], [1, 2, 3], label="data")
    ax.set_xlabel("Frequency [Hz]")
    ax.legend()
    RendererAgg.get_text_width_height_descent = counted
    try:
        save_figure(fig, tmp_path / "f.png", dpi=120)
    finally:
        RendererAgg.get_text_width_height_descent = original
    assert measured
    assert {dpi for _, dpi in measured} == {120}
    assert len(measured) == len(set(measured))


def _legend_fig(n_entries: int):
    import numpy as np

    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(5, 4))
    t = np.linspace(0, 1, 300)
    for k in range(n_entries):
        a.plot(t, np.sin(2 * np.pi * (k + 1) * t), label=f"mode {k + 1} [rad]")
    a.legend(loc="best")
    b.plot(t, t**2, label="ramp")
    b.legend(loc="upper left")
    b.set_xlabel("Time [s]")
    a.set_ylabel("Angle [rad]")
    a.set_title("Fig. 2.36")
    return fig


def test_legends_out_of_layout_same_pixels(tmp_path: Path) -> None:
    # legends inside their axes are left out of the layout pass: the image is the one
    # of tight_layout with every artist; a legend taller than its axes (12 entries in
    # a 1.5 in axes) goes back into the layout and the image is again the plain one
    import numpy as np

    for n_entries in (3, 12):
        ref = plain_pixels(_legend_fig(n_entries))
        path = save_figure(_legend_fig(n_entries), tmp_path / f"l{n_entries}.png")
        with Image.open(path) as img:
            assert np.array_equal(np.asarray(img), ref), n_entries


def test_legend_outside_the_axes_stays_in_the_layout(tmp_path: Path) -> None:
    # a legend anchored outside its axes (bbox_to_anchor) is laid out as before
    import numpy as np

    def fig_():
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.plot([0, 1], [0, 1], label="a rather long legend entry [unit]")
        ax.legend(loc="center left", bbox_to_anchor=(1.0, 0.5))
        return fig

    ref = plain_pixels(fig_())
    with Image.open(save_figure(fig_(), tmp_path / "o.png")) as img:
        assert np.array_equal(np.asarray(img), ref)


def test_savefig_rc_honoured(tmp_path: Path) -> None:
    # with rc settings that make savefig write more than the canvas (a tight box, a
    # transparent background), the PNG still comes from savefig
    import matplotlib

    with matplotlib.rc_context({"savefig.bbox": "tight", "savefig.transparent": True}):
        with Image.open(save_figure(_fig(), tmp_path / "t.png")) as img:
            assert img.size != (640 * 110 // 100, 480 * 110 // 100)  # cropped
            assert img.getextrema()[3][0] == 0  # transparent pixels


def test_legend_check_draws_again_only_when_needed(tmp_path: Path) -> None:
    # a hidden legend is not taken out of the layout (no frame to check): one draw; a
    # legend taller than its axes is put back into the layout: a second draw
    fig = _legend_fig(3)
    fig.axes[0].get_legend().set_visible(False)
    draws = _count_draws(fig)
    save_figure(fig, tmp_path / "h.png")
    assert draws[0] == 1
    fig = _legend_fig(12)
    draws = _count_draws(fig)
    save_figure(fig, tmp_path / "t.png")
    assert draws[0] == 2
