"""HDD benchmark v2 disturbance generator and model spectra."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from servokit.errors import ServokitError
from servokit.models import HDD_BENCHMARK_TS, BenchmarkDisturbances, band_powers


def test_timing_and_scaling():
    bd = BenchmarkDisturbances()
    assert bd.dt == pytest.approx(HDD_BENCHMARK_TS)
    assert bd.rro_freq_hz().tolist() == pytest.approx([120.0, 240.0, 360.0])
    assert bd.force_sigma_per_sample_a == pytest.approx(np.sqrt(2) * 1e-4)
    rec = bd.generate(100, seed=5)
    assert rec.n == 22000 and rec.force.shape == (22000, 2)
    assert np.std(rec.sensor) == pytest.approx(0.015, rel=0.03)
    assert np.std(rec.force) == pytest.approx(np.sqrt(2) * 1e-4, rel=0.03)


def test_flutter_spectrum_matches_model_within_1_db():
    bd = BenchmarkDisturbances()
    rec = bd.generate(2000, seed=1)
    f, psd = signal.welch(rec.flutter, fs=1 / bd.dt, nperseg=8192)
    edges = np.arange(600.0, 6000.0, 150.0)
    measured = band_powers(f, psd, edges)
    model = band_powers(f, bd.flutter_psd(f), edges)
    keep = model > 1e-3 * model.max()  # bands that carry the flutter power
    assert keep.sum() > 10
    np.testing.assert_array_less(np.abs(10 * np.log10(measured[keep] / model[keep])), 1.0)
    # and the sensor noise is white at its model level
    fs_, psd_s = signal.welch(rec.sensor, fs=1 / bd.dt, nperseg=1024)
    assert np.median(psd_s) == pytest.approx(bd.sensor_psd(1.0), rel=0.1)


def test_rro_is_repeatable_with_the_given_amplitudes():
    bd = BenchmarkDisturbances()
    rec = bd.generate(3, seed=2)
    rev = rec.rro.reshape(3, 220)
    np.testing.assert_allclose(rev[0], rev[2], atol=1e-12)
    spectrum = np.abs(np.fft.rfft(rev[0])) * 2 / 220
    np.testing.assert_allclose(spectrum[[1, 2, 3]], [0.15, 0.03, 0.006], rtol=1e-9)


def test_seeded_and_independent_streams():
    bd = BenchmarkDisturbances()
    a, b = bd.generate(2, seed=3), bd.generate(2, seed=3)
    np.testing.assert_array_equal(a.flutter, b.flutter)
    c = bd.generate(2, seed=4)
    assert not np.allclose(a.sensor, c.sensor)
    quiet = BenchmarkDisturbances(sensor_sigma_track=0.0).generate(2, seed=3)
    np.testing.assert_array_equal(quiet.flutter, a.flutter)  # other streams unchanged


@settings(max_examples=20, deadline=None)
@given(st.floats(300.0, 8000.0), st.floats(0.002, 0.2), st.floats(0.01, 1.0))
def test_flutter_psd_integrates_to_the_h2_variance(freq, zeta, pk):
    """Integral of the model PSD = pk^2 * ||G_d||_2^2 (Gramian, python-control)."""
    bd = BenchmarkDisturbances(
        flutter_freq_hz=(freq,), flutter_damping=(zeta,), flutter_peak_track=(pk,)
    )
    f = np.linspace(0.0, 0.5 / bd.dt, 400_001)
    var_psd = np.trapezoid(bd.flutter_psd(f), f)
    g = control.ss(control.sample_system(bd.flutter_filters()[0], bd.dt, method="zoh"))
    P = control.dlyap(np.asarray(g.A).T, np.asarray(g.C).T @ np.asarray(g.C))
    var_h2 = float((np.asarray(g.B).T @ P @ np.asarray(g.B))[0, 0] + np.asarray(g.D)[0, 0] ** 2)
    assert var_psd == pytest.approx(var_h2, rel=1e-3)


def test_bad_parameters():
    with pytest.raises(ServokitError, match="length"):
        BenchmarkDisturbances(flutter_damping=(0.01,))
    with pytest.raises(ServokitError, match="n_revolutions"):
        BenchmarkDisturbances().generate(0)
