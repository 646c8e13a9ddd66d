"""save_figure: atomic writes, the title kept in the file, SVG copies on request."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
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
