"""Unobservable magnitudes (book §4.3, §4.5.3): closed forms, brute force, book numbers."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from math import gcd

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.sampled import _unobservable_grid, unobservable
from servokit.sampled.unobservable import (
    damped_sine_extrema,
    required_measurement_time,
    unacceptable_sampling_frequencies,
    unobservable_magnitude,
)

TAU = 25e-6  # 40 kHz, Figs. 4.3-4.25


def brute_yu(ratio: float, zeta: float, ns: int, ds: float) -> float:
    """(4.48) straight from the definition, continuous sup on a dense grid."""
    b = 2 * np.pi * ratio
    a = b * zeta / np.sqrt(1 - zeta**2)
    s = ns + np.linspace(0.0, 1.5 * 2 * np.pi / b, 200_001)
    yc = np.exp(-a * s) * np.sin(b * s)
    n = np.arange(1, ns + 1) + ds
    yd = np.exp(-a * n) * np.sin(b * n)
    return max(0.0, yc.max() - yd.max(), -(yc.min() - yd.min()))


@pytest.mark.parametrize(
    ("freq", "book_min", "book_max", "ds_min", "ds_max"),
    [
        (40e3, 1.0, 2.0, (0.0, 0.5), (0.25, 0.75)),  # §4.3.1.2, sampling frequency
        (20e3, 0.0, 1.0, (0.5,), (0.0,)),  # §4.3.1.3, Nyquist frequency
        (40e3 / 3, 0.134, 0.5, (0.0, 0.5), (0.25, 0.75)),  # §4.3.1.4, one third
    ],
)
def test_book_steady_state_values(freq, book_min, book_max, ds_min, ds_max):
    r = unobservable_magnitude(freq, TAU)
    assert float(r.minimum) == pytest.approx(book_min, abs=5e-4)
    assert float(r.worst) == pytest.approx(book_max, abs=1e-9)
    assert min(abs(float(r.minimum_delta_s) - d) for d in ds_min) < 1e-6
    assert min(abs(float(r.worst_delta_s) - d) for d in ds_max) < 1e-6
    yu = r.yu
    for d in ds_max:
        assert yu[round(d * r.delta_s.size)] == pytest.approx(book_max, abs=1e-9)


def test_nyquist_rms_closed_form():
    # yu = 1 - |sin(pi ds)| at the Nyquist frequency, so yui^2 = 3/2 - 4/pi.
    r = unobservable_magnitude(20e3, TAU)
    assert float(r.rms) == pytest.approx(np.sqrt(1.5 - 4 / np.pi), rel=1e-5)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 12), st.integers(1, 40))
def test_steady_state_worst_is_one_minus_cos_pi_over_q(q, p):
    # Samples of a p/q ratio fall on q equally spaced phases: largest gap 2 pi / q.
    if gcd(p, q) != 1:
        p, q = p // gcd(p, q), q // gcd(p, q)
    r = unobservable_magnitude(p / q * 40e3, TAU, n_phases=240)
    assert float(r.worst) == pytest.approx(1 - np.cos(np.pi / q), abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    st.floats(0.03, 3.5),
    st.sampled_from([0.0, 0.005, 0.03, 0.1]),
    st.integers(1, 15),
    st.integers(0, 35),
)
def test_finite_samples_match_brute_force(ratio, zeta, ns, k):
    r = unobservable_magnitude(ratio / TAU, TAU, damping=zeta, n_samples=ns, n_phases=36)
    assert r.yu[k] == pytest.approx(brute_yu(ratio, zeta, ns, r.delta_s[k]), abs=2e-6)
    assert float(r.worst) >= r.yu.max() - 1e-12
    assert float(r.minimum) <= r.yu.min() + 1e-12
    assert float(r.rms) == pytest.approx(np.sqrt(np.mean(r.yu**2)))


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 2.0), st.floats(0.1, 30.0), st.floats(-7.0, 7.0), st.floats(0.01, 5.0))
def test_damped_sine_extrema_brute_force(decay, omega, phase, length):
    u = np.linspace(0.0, length, 200_001)
    f = np.exp(-decay * u) * np.sin(omega * u + phase)
    fmax, fmin = damped_sine_extrema(decay, omega, phase, length)
    assert float(fmax) == pytest.approx(f.max(), abs=1e-7)
    assert float(fmin) == pytest.approx(f.min(), abs=1e-7)


def test_broadcasting_and_histogram():
    fs = np.array([[30e3], [50e3]])
    f = np.array([10e3, 20e3, 40e3])
    r = unobservable_magnitude(f, 1 / fs, damping=0.01, n_samples=10, n_phases=100)
    assert r.worst.shape == (2, 3) and r.yu.shape == (2, 3, 100)
    one = unobservable_magnitude(20e3, 1 / 50e3, damping=0.01, n_samples=10, n_phases=100)
    assert r.rms[1, 1] == pytest.approx(float(one.rms))
    edges, pct = one.histogram(0.1)
    assert pct.sum() == pytest.approx(100.0)
    # (4.49)-(4.50) by direct counting.
    bins = zip(edges[:-1], edges[1:], strict=True)
    expected = [100 * np.mean((one.yu >= lo) & (one.yu < hi)) for lo, hi in bins]
    np.testing.assert_allclose(pct, expected)


def test_steady_state_histogram_at_sampling_frequency():
    # Undamped oscillation at the sampling frequency: yu = 1 + |sin(2 pi ds)|, so
    # P(yu >= 1.4) = 1 - 2 asin(0.4) / pi (Fig. 4.13 reads "most more than 140 %").
    r = unobservable_magnitude(40e3, TAU, n_phases=3600)
    edges, pct = r.histogram(0.1)
    share = pct[edges[:-1] >= 1.4 - 1e-12].sum() / 100
    assert share == pytest.approx(1 - 2 * np.arcsin(0.4) / np.pi, abs=2e-3)
    assert share > 0.5


def _assert_near(intervals, book_hz, rel):
    assert len(intervals) == len(book_hz)
    for iv, f in zip(intervals, book_hz, strict=True):
        assert f in iv
        assert iv.peak_hz == pytest.approx(f, rel=rel)


def test_fig_4_24_unacceptable_sampling_frequencies():
    # wd = 40 kHz, zeta = 0.01, Ns = 10, level 0.2: near 13.3, 20.0, 40.0, 80.0 kHz.
    iv = unacceptable_sampling_frequencies(40e3, 0.01, 10, 0.2, (5e3, 200e3))
    _assert_near(iv, [13.3e3, 20.0e3, 40.0e3, 80.0e3], rel=0.01)


def test_fig_4_54_unacceptable_sampling_frequencies_hdd():
    # 4.1 kHz mode, zeta = 0.01, level 0.1.  Ns = 10: the book prints "82.0 kHz and
    # 123 kHz" after 4.10 kHz; the curve peaks at 2 x 4.1 = 8.20 and 3 x 4.1 = 12.3 kHz
    # (8.20 kHz is also listed for Ns = 20), so those are read as 8.20 and 12.3 kHz.
    iv10 = unacceptable_sampling_frequencies(4100, 0.01, 10, 0.1, (0.9e3, 15e3))
    _assert_near(iv10, [1.02e3, 1.37e3, 2.05e3, 2.73e3, 4.10e3, 8.20e3, 12.3e3], rel=0.01)
    iv20 = unacceptable_sampling_frequencies(4100, 0.01, 20, 0.1, (0.9e3, 15e3))
    _assert_near(iv20, [2.05e3, 4.10e3, 8.20e3], rel=0.01)
    # Ns = 5: "most of the frequencies from 1 kHz to 10 kHz are unacceptable".
    iv5 = unacceptable_sampling_frequencies(4100, 0.01, 5, 0.1, (1e3, 10e3))
    covered = sum(np.log(min(i.high_hz, 10e3) / max(i.low_hz, 1e3)) for i in iv5)
    assert covered / np.log(10) > 0.5


@pytest.mark.parametrize(
    ("freq", "tau", "level", "book_time"),
    [(40e3, 23.8e-6, 0.2, 0.26e-3), (4100, 233e-6, 0.1, 3e-3)],  # Figs. 4.25, 4.55
)
def test_required_measurement_time(freq, tau, level, book_time):
    req = required_measurement_time(freq, tau, 0.01, level, max_samples=40)
    assert req.crossing_time_s == pytest.approx(book_time, rel=0.10)
    assert req.rms[req.n_samples - 1 :].max() <= level < req.rms[req.n_samples - 2]
    assert req.time_s == pytest.approx(tau * req.n_samples)


def test_user_errors():
    with pytest.raises(ServokitValueError, match="n_samples"):
        unobservable_magnitude(1e3, 1e-4, damping=0.01)
    with pytest.raises(ServokitValueError, match="freq_hz"):
        unobservable_magnitude(-1.0, 1e-4)
    with pytest.raises(ServokitValueError, match="damping"):
        unobservable_magnitude(1e3, 1e-4, damping=1.5, n_samples=3)
    with pytest.raises(ServokitTypeError, match="n_samples"):
        unobservable_magnitude(1e3, 1e-4, n_samples=2.5)
    with pytest.raises(ServokitValueError, match="fs_range"):
        unacceptable_sampling_frequencies(1e3, 0.01, 5, 0.1, (10e3, 1e3))


# --- the fast damped grid (angle addition, demo speed-up) against the direct grid -------


def _rows(ratios, zeta):  # noqa: ANN001, ANN202
    b = 2 * np.pi * np.asarray(ratios, dtype=float)
    return b, b * zeta / np.sqrt(1 - zeta**2)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(1e-3, 40.0), min_size=1, max_size=6),
    st.floats(1e-6, 0.95),
    st.integers(1, 45),
    st.integers(0, 2**32 - 1),
)
def test_damped_grid_equals_direct_grid(ratios, zeta, ns, seed):
    """Bit for bit: the fast path picks the extremal sample, then evaluates it directly."""
    b, a = _rows(ratios, zeta)
    rng = np.random.default_rng(seed)
    ds = np.concatenate(
        [np.broadcast_to(np.arange(36) / 36, (b.size, 36)), rng.uniform(0, 1, (b.size, 9))],
        axis=1,
    )
    with _fast_path_always():
        fast = _unobservable_grid._damped_yu(b, a, ns, ds)
    np.testing.assert_array_equal(fast, _unobservable_grid._damped_yu_direct(b, a, ns, ds))


@contextmanager
def _fast_path_always() -> Iterator[None]:
    """The angle-addition path even for grids below ``_DIRECT_PHASES``."""
    old = _unobservable_grid._DIRECT_PHASES
    _unobservable_grid._DIRECT_PHASES = 0
    try:
        yield
    finally:
        _unobservable_grid._DIRECT_PHASES = old


@pytest.mark.parametrize("ns", [1, 2, 10, 40])
def test_damped_grid_equals_direct_grid_near_ties_and_fast_decay(ns):
    # rational ratios with tiny damping put samples within the margin of each other (the
    # direct fallback); zeta = 0.95 at large ratios decays towards underflow (direct rows)
    b1, a1 = _rows([1.0, 0.5, 1 / 3, 0.25, 2.0, 7 / 4], 1e-12)
    b2, a2 = _rows([5.0, 30.0, 120.0], 0.95)
    b, a = np.r_[b1, b2], np.r_[a1, a2]
    ds = np.broadcast_to(np.arange(720) / 720, (b.size, 720))
    fast = _unobservable_grid._damped_yu(b, a, ns, ds)
    np.testing.assert_array_equal(fast, _unobservable_grid._damped_yu_direct(b, a, ns, ds))


def test_damped_grid_blocks_match_direct(monkeypatch):
    # several blocks of rows (small block size), the case-sized phase grid
    monkeypatch.setattr(_unobservable_grid, "_BLOCK", 700)
    monkeypatch.setattr(_unobservable_grid, "_DIRECT_PHASES", 0)
    b, a = _rows(np.geomspace(0.05, 30.0, 41), 0.01)
    ds = np.broadcast_to(np.arange(360) / 360, (b.size, 360))
    fast = _unobservable_grid._damped_yu(b, a, 20, ds)
    np.testing.assert_array_equal(fast, _unobservable_grid._damped_yu_direct(b, a, 20, ds))


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.floats(1e-3, 40.0), min_size=1, max_size=9),
    st.sampled_from([None, 1, 7, 30]),
    st.integers(200, 3000),
    st.integers(0, 2**32 - 1),
)
def test_undamped_grid_cache_equals_direct_search(ratios, ns, chunk, seed):
    """The cached sorted phases give the same ``yu`` as a fresh search, bit for bit, for
    every phase grid and chunking (a small ``_CHUNK`` splits the rows)."""
    b = 2 * np.pi * np.asarray(ratios)
    n = np.arange(unobservable.STEADY_STATE_SAMPLES if ns is None else ns, dtype=float)
    n = n if ns is None else n + 1
    rng = np.random.default_rng(seed)
    old = _unobservable_grid._CHUNK
    try:
        _unobservable_grid._CHUNK = chunk
        grid = _unobservable_grid._UndampedGrid(b, n)
        for width in (36, 33, 5, 33):
            ds = rng.uniform(0, 1, (b.size, width))
            fresh = _unobservable_grid._undamped_yu(b, n, ds)
            np.testing.assert_array_equal(grid(ds), fresh)
    finally:
        _unobservable_grid._CHUNK = old


def test_undamped_grid_without_cache_room(monkeypatch):
    monkeypatch.setattr(_unobservable_grid, "_CACHE_ELEMENTS", 10)
    b = 2 * np.pi * np.array([0.3, 1.7, 4.2])
    n = np.arange(1, 11, dtype=float)
    grid = _unobservable_grid._UndampedGrid(b, n)
    assert grid.theta is None
    ds = np.broadcast_to(np.arange(36) / 36, (3, 36))
    np.testing.assert_array_equal(grid(ds), _unobservable_grid._undamped_yu(b, n, ds))


def test_small_damped_grids_use_the_direct_evaluation(monkeypatch):
    calls = []
    monkeypatch.setattr(_unobservable_grid, "_damped_sample_extrema", lambda *a: calls.append(a))
    b, a = _rows([0.3, 1.1], 0.01)
    ds = np.broadcast_to(np.arange(33) / 33, (2, 33))
    small = _unobservable_grid._damped_yu(b, a, 10, ds)
    assert not calls
    np.testing.assert_array_equal(small, _unobservable_grid._damped_yu_direct(b, a, 10, ds))


@pytest.mark.parametrize(("zeta", "ns"), [(0.0, None), (0.0, 7), (0.01, 10)])
def test_unobservable_rms_equals_magnitude_rms(zeta, ns):
    f = np.geomspace(3e3, 90e3, 50)[:, None]
    dt = np.array([25e-6, 37e-6])
    fast = unobservable.unobservable_rms(f, dt, damping=zeta, n_samples=ns, n_phases=90)
    full = unobservable_magnitude(f, dt, damping=zeta, n_samples=ns, n_phases=90)
    assert fast.shape == full.rms.shape == (50, 2)
    np.testing.assert_array_equal(fast, full.rms)


def test_required_measurement_time_reports_each_ns_and_is_unchanged() -> None:
    """The progress hook sees Ns = 1..max in order and does not change the result."""
    seen: list[int] = []
    plain = required_measurement_time(4100.0, 1.535e-4, 0.01, 0.1, max_samples=12)
    hooked = required_measurement_time(
        4100.0, 1.535e-4, 0.01, 0.1, max_samples=12, on_sample=seen.append
    )
    assert seen == list(range(1, 13))
    np.testing.assert_array_equal(plain.rms, hooked.rms)
    assert plain.n_samples == hooked.n_samples
