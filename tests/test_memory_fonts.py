"""Fonts read from memory for the Agg text of servokit's saves (servokit._memory_fonts)."""

from __future__ import annotations

import io
import os
import sys
import warnings

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends.backend_agg import RendererAgg, get_hinting_flag  # noqa: E402
from matplotlib.font_manager import FontProperties, get_font  # noqa: E402

from servokit import _memory_fonts  # noqa: E402
from servokit._figures import save_figure  # noqa: E402

pytestmark = pytest.mark.skipif(
    not _memory_fonts.memory_fonts_supported(), reason="not a checked matplotlib"
)

PROPS = [
    FontProperties(),
    FontProperties(weight="bold", size=14),
    FontProperties(style="italic", size=7.5),
    FontProperties(family="monospace", size=11),
]


@pytest.mark.parametrize("prop", PROPS, ids=["default", "bold", "italic", "mono"])
def test_memory_font_renders_what_matplotlib_renders(prop: FontProperties) -> None:
    renderer = RendererAgg(300, 200, 110)
    flags = get_hinting_flag()
    text = "Frequency [Hz] -180° µs 0.001"
    ours = _memory_fonts.prepare_font(renderer, prop)
    assert isinstance(ours.fname, io.BytesIO)  # from memory, not through the file
    theirs = renderer._prepare_font(prop)
    assert ours.family_name == theirs.family_name and ours.style_name == theirs.style_name
    for font in (ours, theirs):
        font.set_text(text, 0.0, flags=flags)
        font.draw_glyphs_to_bitmap()
    assert ours.get_width_height() == theirs.get_width_height()
    assert ours.get_descent() == theirs.get_descent()
    assert np.array_equal(np.asarray(ours.get_image()), np.asarray(theirs.get_image()))
    # a glyph the face lacks comes from the same fallback (Last Resort's box here)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Last Resort's "glyph missing" warning
        shaped = [
            [(i.glyph_index, i.ft_object.family_name, i.x) for i in f._layout("a\u4e2db", flags)]
            for f in (ours, theirs)
        ]
    assert shaped[0] == shaped[1] and shaped[0][1][0] != 0


def _figure_pixels(tmp_path, name: str, supported: bool, monkeypatch) -> np.ndarray:  # noqa: ANN001
    from PIL import Image

    monkeypatch.setattr(_memory_fonts, "memory_fonts_supported", lambda: supported)
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot([1, 2, 3], [1, 4, 2], label="gain \u4e2d")  # a glyph only Last Resort has
    ax.set_xlabel("Frequency [Hz]")
    ax.set_title("Fig. 1 — bold", fontweight="bold")
    ax.legend()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Last Resort's "glyph missing" warning
        path = save_figure(fig, tmp_path / name)
    return np.asarray(Image.open(path))


def test_saved_pixels_are_those_of_file_fonts(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    from servokit._agg_text import clear_caches

    clear_caches()  # the glyph caches are keyed on the font objects: start both cold
    files = _figure_pixels(tmp_path, "files.png", False, monkeypatch)
    clear_caches()
    memory = _figure_pixels(tmp_path, "memory.png", True, monkeypatch)
    assert np.array_equal(files, memory)


def test_matplotlib_font_cache_keeps_file_names(tmp_path, monkeypatch) -> None:  # noqa: ANN001
    _figure_pixels(tmp_path, "any.png", True, monkeypatch)
    path = matplotlib.font_manager.findfont(FontProperties())
    assert isinstance(get_font(path).fname, str)  # what the PDF and PS backends read


@pytest.mark.skipif(not hasattr(os, "fork") or sys.platform == "darwin", reason="needs fork")
def test_a_forked_child_forgets_the_fonts() -> None:
    _memory_fonts.prepare_font(RendererAgg(10, 10, 72), FontProperties())
    assert _memory_fonts._FONTS
    pid = os.fork()
    if pid == 0:  # the child: exit status 0 only if the faces were dropped
        os._exit(0 if not _memory_fonts._FONTS else 1)
    _, status = os.waitpid(pid, 0)
    assert os.waitstatus_to_exitcode(status) == 0
    assert _memory_fonts._FONTS  # the parent keeps its own


def test_unchecked_matplotlib_keeps_file_fonts(monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(matplotlib, "__version__", "3.99.0")
    _memory_fonts.memory_fonts_supported.cache_clear()
    try:
        assert not _memory_fonts.memory_fonts_supported()
    finally:
        monkeypatch.undo()
        _memory_fonts.memory_fonts_supported.cache_clear()
    assert _memory_fonts.memory_fonts_supported()


def test_the_font_cache_is_bounded(monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(_memory_fonts, "MAX_FONTS", 2)
    _memory_fonts.clear_fonts()
    renderer = RendererAgg(10, 10, 72)
    for prop in PROPS:
        _memory_fonts.prepare_font(renderer, prop)
        assert len(_memory_fonts._FONTS) <= 2
