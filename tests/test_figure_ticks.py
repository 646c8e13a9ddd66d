"""servokit._ticks: tick locations computed once per axes geometry, the same figures."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from _plain_save import plain_pixels
from matplotlib.ticker import AutoLocator, FixedLocator, LogLocator
from PIL import Image

from servokit._figures import save_figure
from servokit._ticks import ViewTickLocator, cache_tick_locations


def _bode():
    f = np.geomspace(3.0, 2e4, 400)
    h = 1e6 / (2j * np.pi * f) ** 2 / (1 + 1j * f / 5e3)
    fig, (a, b) = plt.subplots(2, 1, sharex=True, figsize=(6, 5))
    a.semilogx(f, 20 * np.log10(abs(h)), label="plant")
    b.semilogx(f, np.degrees(np.angle(h)))
    a.set_ylabel("Magnitude [dB]")
    b.set_ylabel("Phase [deg]")
    b.set_xlabel("Frequency [Hz]")
    a.set_title("Fig. 5.38")
    a.legend()
    for ax in (a, b):
        ax.grid(True, which="both", alpha=0.3)
    return fig


def _mixed():
    # log-log with few decades (labelled minor ticks), fixed labels, equal aspect,
    # an offset on the y axis, a twin axis
    fig, axs = plt.subplots(2, 2, figsize=(8, 6))
    axs[0, 0].loglog([2.0, 30.0], [5e-3, 8e-2], label="psd")
    axs[0, 0].set(xlabel="Frequency [Hz]", ylabel="PSD [nm²/Hz]")
    axs[0, 1].bar([0, 1, 2], [3.0, 1.0, 2.0])
    axs[0, 1].set_xticks([0, 1, 2], ["design 1", "design 2", "design 3"])
    axs[0, 1].set_ylabel("Seek time [ms]")
    t = np.linspace(0, 2 * np.pi, 200)
    axs[1, 0].plot(np.cos(t), np.sin(t))
    axs[1, 0].set_aspect("equal")
    axs[1, 0].set(xlabel="Re L", ylabel="Im L", title="Nyquist")
    axs[1, 1].plot(t, 1e5 + 1e-2 * np.sin(t))
    axs[1, 1].twinx().plot(t, np.cos(t), "r")
    axs[1, 1].set(xlabel="Time [s]", ylabel="Position [track]")
    return fig


@pytest.mark.parametrize("make", [_bode, _mixed])
def test_same_pixels_as_the_plain_save(make, tmp_path: Path) -> None:
    ref = plain_pixels(make())
    with Image.open(save_figure(make(), tmp_path / "f.png")) as img:
        np.testing.assert_array_equal(np.asarray(img), ref)


def _labels(fig) -> list[tuple[str, tuple[float, float]]]:
    """Text and place of the tick labels drawn (those of ticks inside the view)."""
    out = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            lo, hi = sorted(axis.get_view_interval())
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                if lo - 1e-9 * (hi - lo) <= tick.get_loc() <= hi + 1e-9 * (hi - lo):
                    text = tick.label1
                    if text.get_visible() and text.get_text():
                        out.append((text.get_text(), tuple(np.round(text.get_position(), 6))))
    return sorted(out)


def test_same_tick_labels_fewer_ticks() -> None:
    # drawn tick labels (text and place) as without the cache; ticks are created only
    # for the locations inside the view
    fig = _bode()
    fig.set_dpi(110)
    fig.tight_layout()
    fig.canvas.draw()
    ref = _labels(fig)
    n_ref = sum(len(ax.xaxis.majorTicks) + len(ax.xaxis.minorTicks) for ax in fig.axes)
    plt.close(fig)
    fig = _bode()
    fig.set_dpi(110)
    assert cache_tick_locations(fig) == 4  # x shared: one major and one minor; y: two each
    fig.tight_layout()
    fig.canvas.draw()
    assert _labels(fig) == ref
    n_new = sum(len(ax.xaxis.majorTicks) + len(ax.xaxis.minorTicks) for ax in fig.axes)
    plt.close(fig)
    assert n_new < n_ref


def test_locator_runs_once_per_geometry() -> None:
    calls = []

    class Counted(AutoLocator):
        def __call__(self):
            calls.append(1)
            return super().__call__()

    fig, ax = plt.subplots()
    ax.plot([0, 1.3], [0, 1])
    ax.xaxis.set_major_locator(Counted())
    cache_tick_locations(fig)
    assert isinstance(ax.xaxis.get_major_locator(), ViewTickLocator)
    fig.canvas.draw()
    fig.canvas.draw()
    assert len(calls) == 1
    ax.set_xlim(0, 2)  # new view: computed again
    fig.canvas.draw()
    assert len(calls) == 2
    loc = ax.xaxis.get_major_locator()()
    assert loc.min() >= 0 and loc.max() <= 2
    plt.close(fig)


def test_fixed_and_shared_locators_left_alone() -> None:
    fig, (a, b) = plt.subplots(1, 2, sharey=True)
    a.set_xticks([0, 1], ["low", "high"])
    b.set_xscale("log")
    cache_tick_locations(fig)
    assert isinstance(a.xaxis.get_major_locator(), FixedLocator)
    inner = b.xaxis.get_major_locator().inner
    assert isinstance(inner, LogLocator)
    # the shared y axes share one wrapped locator, answering for the axis it had
    assert a.yaxis.get_major_locator() is b.yaxis.get_major_locator()
    plt.close(fig)
