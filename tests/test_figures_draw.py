"""Plot functions drawn the cheap way still draw every curve of their data (issue 24)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from PIL import Image

import servokit.feedback.loopshape_plots as loopshape_plots
from servokit._figures import PNG_COMPRESS_LEVEL, save_figure


def _loop_set(m: int = 5, n: int = 200) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
    f = np.geomspace(10.0, 2e4, n)
    s = 2j * np.pi * f
    wn = 2 * np.pi * np.linspace(4e3, 6e3, m)[:, None]
    plants = 1e8 / s**2 / (1 + 2 * 0.01 * s / wn + (s / wn) ** 2)  # light damping
    lead = (1 + s / (2 * np.pi * 300)) / (1 + s / (2 * np.pi * 3000))
    return f, plants, {"baseline": 0.5 * lead, "designed": 0.6 * lead}


def test_loopshape_plot_draws_every_plant_of_every_set(tmp_path: Path, monkeypatch) -> None:
    figures = []

    def keep(fig, path, **kw):
        figures.append(fig)
        return save_figure(fig, path, **kw)

    monkeypatch.setattr(loopshape_plots, "save_figure", keep)
    f, plants, controllers = _loop_set()
    path = loopshape_plots.loopshape_plot(
        f, plants, controllers, s_max_db=6.0, path=tmp_path / "l.png", title="t"
    )
    (fig,) = figures
    ax_mag, ax_ph, ax_ny = fig.axes
    assert ax_mag.get_xscale() == ax_ph.get_xscale() == "log"
    for ax in (ax_mag, ax_ph, ax_ny):
        assert len(ax.collections) == len(controllers)
    for (label, k), coll_mag, coll_ny in zip(
        controllers.items(), ax_mag.collections, ax_ny.collections, strict=True
    ):
        loop = plants * k[None, :]
        assert coll_mag.get_label() == label
        mag = np.array([seg[:, 1] for seg in coll_mag.get_segments()])
        np.testing.assert_allclose(mag, 20 * np.log10(np.abs(loop)))
        ny = np.array(coll_ny.get_segments())
        np.testing.assert_allclose(ny[..., 0] + 1j * ny[..., 1], loop)
    # the autoscaled frequency axis spans the grid, the legend names each set once
    assert ax_mag.get_xlim()[0] <= f[0] and ax_mag.get_xlim()[1] >= f[-1]
    legend = [t.get_text() for t in ax_mag.get_legend().get_texts()]
    assert legend == list(controllers)
    with Image.open(path) as img:
        assert img.size == (1320, 770)  # 12 x 7 in at 110 dpi


def test_png_level_is_faster_and_lossless(tmp_path: Path, monkeypatch) -> None:
    # the PNG decodes to the pixels matplotlib rendered into the canvas
    fig, ax = plt.subplots()
    ax.plot(np.sin(np.linspace(0, 20, 500)), label="sine")
    ax.legend()
    canvas: list[np.ndarray] = []
    close = plt.close
    monkeypatch.setattr(plt, "close", lambda f: canvas.append(np.array(f.canvas.buffer_rgba())))
    path = save_figure(fig, tmp_path / "s.png")
    close(fig)
    (rendered,) = canvas
    assert 0 < PNG_COMPRESS_LEVEL < 6  # Pillow's default is 6
    with Image.open(path) as img:
        np.testing.assert_array_equal(np.asarray(img), rendered)


def test_held_out_histogram_same_pixels_as_bars(tmp_path: Path, monkeypatch) -> None:
    # the robust-seek histogram draws each design as one filled outline; touching bars
    # without edges cover the same pixels
    from servokit.cases import robust_seek

    rng = np.random.default_rng(3)
    times = {
        panel: {name: rng.normal(mu, 5e-5, 300) for name, mu in (("a", 1e-3), ("b", 1.1e-3))}
        for panel in ("1 track", "10 tracks")
    }
    times["1 track"]["a"][:3] = np.inf  # unsettled plants are left out
    path = robust_seek._histogram(times, tmp_path / "outline.png")
    hist = plt.Axes.hist
    drawn: list[str] = []

    def bars(self, x, *args, histtype="bar", **kwargs):
        drawn.append(histtype)
        return hist(self, x, *args, **kwargs)  # matplotlib's default bars

    monkeypatch.setattr(plt.Axes, "hist", bars)
    ref = robust_seek._histogram(times, tmp_path / "bars.png")
    assert drawn == ["stepfilled"] * 4
    with Image.open(path) as new, Image.open(ref) as old:
        np.testing.assert_array_equal(np.asarray(new), np.asarray(old))


def test_loop_phase_is_continuous_and_every_plant_starts_on_one_branch() -> None:
    """A loop near -180 deg at the first frequency (where the principal value flips sign)
    is drawn continuous, each plant from (-360, 0], the same angle as the principal value."""
    from servokit.feedback.plots import loop_phase_deg

    f, plants, controllers = _loop_set()
    loop = plants * controllers["designed"][None, :]
    loop[1] *= np.exp(-0.05j)  # its first point (-178.3 deg) moved below -180: +178.9
    wrapped = np.degrees(np.angle(loop))
    assert wrapped[:, 0].max() > 170 and wrapped[:, 0].min() < -170  # both branches
    phase = loop_phase_deg(loop)
    assert np.all((phase[:, 0] > -360) & (phase[:, 0] <= 0))
    assert np.abs(np.diff(phase, axis=1)).max() < 180
    turns = (phase - wrapped) / 360.0
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)
