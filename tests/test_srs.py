"""Shock response spectrum (book §4.4): scipy lsim reference, closed forms, book peaks."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.sampled.srs import (
    amplitude_spectrum,
    half_sine,
    held_samples,
    polynomial_wave,
    shock_response,
    shock_response_spectrum,
    spectrum_peaks,
    srs_plot,
)

TZOH = 25e-6
F = np.arange(100.0, 100e3, 10.0)


def lsim_reference(u, h, f, zeta, after_periods=3.0, per_hold=None):
    """Residual and initial SRS from scipy lsim (ZOH) on a fine grid aligned with the holds."""
    w = 2 * np.pi * f
    sys = ss.lti([1.0, 0.0, 0.0], [1.0, 2 * zeta * w, w**2])  # Psrs (4.54)
    K = per_hold or int(np.ceil(4200 * f * h))
    T = u.size * h
    n_after = int(np.ceil(after_periods / f / (h / K)))
    uf = np.concatenate([np.repeat(u, K), np.zeros(n_after)])
    t = np.arange(uf.size) * (h / K)
    _, y, x = ss.lsim(sys, uf, t, interp=False)
    resid = np.abs(y[u.size * K :]).max()
    # left limits at the hold switches: state at the switch with the previous input
    ss_sys = sys.to_ss()
    idx = np.arange(1, u.size + 1) * K
    y_left = x[idx] @ ss_sys.C.ravel() + u
    initial = max(np.abs(y).max(), np.abs(y_left).max())
    assert t[u.size * K] == pytest.approx(T)
    return resid, initial


@pytest.mark.parametrize("zeta", [0.0, 0.005])
@pytest.mark.parametrize("f", [1370.0, 20e3, 38.6e3, 41.4e3])
def test_half_sine_zoh_matches_lsim(f, zeta):
    u = held_samples(half_sine(0.5e-3), 0.5e-3, TZOH)
    resid, initial = lsim_reference(u, TZOH, f, zeta)
    r = shock_response_spectrum(u, TZOH, [f], zeta)
    i = shock_response_spectrum(u, TZOH, [f], zeta, kind="initial")
    assert r.magnitude[0] == pytest.approx(resid, rel=1e-6)
    assert i.magnitude[0] == pytest.approx(initial, rel=1e-6)


def test_polynomial_wave_matches_lsim():
    u = polynomial_wave(40, TZOH, 1.0)
    for f in (4.1e3, 38.7e3):
        resid, _ = lsim_reference(u, TZOH, f, 0.005)
        mag = shock_response_spectrum(u, TZOH, [f], 0.005).magnitude[0]
        assert mag == pytest.approx(resid, rel=1e-6)


def test_shock_response_matches_lsim_time_history():
    u = polynomial_wave(20, TZOH, 1.0)
    f, K = 38.7e3, 64
    sys = ss.lti([1.0, 0.0, 0.0], [1.0, 2 * 0.005 * 2 * np.pi * f, (2 * np.pi * f) ** 2])
    uf = np.concatenate([np.repeat(u, K), np.zeros(30 * K)])
    t = np.arange(uf.size) * (TZOH / K)
    _, y, _ = ss.lsim(sys, uf, t, interp=False)
    np.testing.assert_allclose(shock_response(u, TZOH, f, 0.005, t), y, atol=1e-9 * np.abs(y).max())


def test_polynomial_wave_is_eq_4_60():
    # (4.60) typed from the book, Pt = 2, tau_ff = 25 us.
    N, Pt = 40, 2.0
    n = np.arange(N)
    book = (
        840
        * n**2
        * (n - N) ** 3
        * (-10 + (7 * n - 3 * N) * N * (1 + N**2))
        * Pt
        / (N * (N**2 - 4) * (N**2 - 1) * (N**2 + 5) * (10 + 3 * (N**2 + N**4)) * TZOH**2)
    )
    np.testing.assert_allclose(polynomial_wave(N, TZOH, Pt), book, rtol=1e-10, atol=1e-6)


def test_continuous_half_sine_closed_form():
    # zeta = 0: residual = w |U(jw)|, U of the half-sine in closed form.
    T = 0.5e-3
    f = F + 3.3  # stay off the removable singularity w = pi / T
    s = shock_response_spectrum(half_sine(T), None, f, 0.0, duration=T)
    w, a = 2 * np.pi * f, np.pi / T
    expected = w * np.abs(a * (1 + np.exp(-1j * w * T)) / (a**2 - w**2))
    np.testing.assert_allclose(s.magnitude, expected, rtol=1e-10, atol=1e-12 * expected.max())


def test_continuous_initial_close_to_fine_grid():
    T = 0.5e-3
    f = np.array([700.0, 5e3, 21e3])
    coarse = shock_response_spectrum(half_sine(T), None, f, 0.005, duration=T, kind="initial")
    fine = shock_response_spectrum(
        half_sine(T), None, f, 0.005, duration=T, kind="initial", points_per_period=2000
    )
    np.testing.assert_allclose(coarse.magnitude, fine.magnitude, rtol=2e-3)


@settings(max_examples=25, deadline=None)
@given(st.integers(5, 60), st.floats(200.0, 90e3))
def test_undamped_residual_is_w_times_fourier_amplitude(N, f):
    u = polynomial_wave(N, TZOH, 1.0)
    srs = shock_response_spectrum(u, TZOH, [f], 0.0).magnitude[0]
    amp = amplitude_spectrum(u, TZOH, np.array([f]))[0]
    assert srs == pytest.approx(2 * np.pi * f * amp, rel=1e-9, abs=1e-9 * np.abs(u).max())


def test_amplitude_spectrum_matches_fft():
    u = polynomial_wave(40, TZOH, 1.0)
    K, pad = 50, 2**16
    h = TZOH / K
    x = np.zeros(pad)
    x[: u.size * K] = np.repeat(u, K)
    freqs = np.fft.rfftfreq(pad, h)
    sel = (freqs > 0) & (freqs < 60e3)
    # exact transform of the fine staircase = FFT times the fine hold factor
    w = 2 * np.pi * freqs[sel]
    fine_hold = np.abs((1 - np.exp(-1j * w * h)) / (1j * w))
    fft_amp = np.abs(np.fft.rfft(x))[sel] * fine_hold
    np.testing.assert_allclose(
        amplitude_spectrum(u, TZOH, freqs[sel]), fft_amp, rtol=1e-8, atol=1e-10 * fft_amp.max()
    )


def test_book_half_sine_peaks():
    hs = half_sine(0.5e-3)
    zoh = shock_response_spectrum(hs, TZOH, F, 0.0, duration=0.5e-3)
    cont = shock_response_spectrum(hs, None, F, 0.0, duration=0.5e-3)
    # Fig. 4.28: with ZOH large near 1.4, 38.6, 41.4, 78.6, 81.4 kHz; without only 1.4 kHz.
    np.testing.assert_allclose(
        spectrum_peaks(F, zoh.magnitude), [1.4e3, 38.6e3, 41.4e3, 78.6e3, 81.4e3], rtol=0.025
    )
    np.testing.assert_allclose(spectrum_peaks(F, cont.magnitude), [1.4e3], rtol=0.025)
    # Fig. 4.32: 1 ms half-sine, near 700 Hz, 39.3 and 40.7 kHz.
    f60 = F[F < 60e3]
    one = shock_response_spectrum(half_sine(1e-3), TZOH, f60, 0.0, duration=1e-3)
    np.testing.assert_allclose(spectrum_peaks(f60, one.magnitude), [700, 39.3e3, 40.7e3], rtol=0.03)


def test_book_polynomial_and_fig_4_30():
    # Fig. 4.36: 40-sample polynomial wave, zeta = 0.005, largest residual near 38.7 kHz.
    u = polynomial_wave(40, TZOH, 1.0)
    band = F[(F > 30e3) & (F < 50e3)]
    s = shock_response_spectrum(u, TZOH, band, 0.005)
    assert band[np.argmax(s.magnitude)] == pytest.approx(38.7e3, rel=0.005)
    # Fig. 4.30: half-sine, zeta = 0.005, 38.6 kHz far above 20 kHz and 40 kHz.
    hs = held_samples(half_sine(0.5e-3), 0.5e-3, TZOH)
    g = shock_response_spectrum(hs, TZOH, [20e3, 40e3, 38.6e3], 0.005).magnitude
    assert g[2] > 4 * g[1] > 4 * g[0]


def test_initial_dominates_residual_and_damping_lowers():
    u = polynomial_wave(20, TZOH, 1.0)
    r0 = shock_response_spectrum(u, TZOH, F[::20], 0.0)
    r5 = shock_response_spectrum(u, TZOH, F[::20], 0.005)
    i5 = shock_response_spectrum(u, TZOH, F[::20], 0.005, kind="initial")
    assert np.all(i5.magnitude >= r5.magnitude - 1e-12)
    # Fig. 4.29: damping lowers the residual almost everywhere, except near the zeros
    # of the undamped spectrum.
    lower = r5.magnitude < r0.magnitude
    assert lower.mean() > 0.8 and not lower.all()


def test_plot_and_errors(tmp_path):
    u = polynomial_wave(20, TZOH, 1.0)
    s = shock_response_spectrum(u, TZOH, F[::50], 0.0)
    path = tmp_path / "srs.png"
    srs_plot([s], ["poly"], normalize=True, path=path)
    assert path.stat().st_size > 1000
    with pytest.raises(ServokitValueError, match="duration"):
        shock_response_spectrum(half_sine(1e-3), TZOH, F, 0.0)
    with pytest.raises(ServokitValueError, match="dt_hold"):
        shock_response_spectrum(u, None, F, 0.0)
    with pytest.raises(ServokitValueError, match="kind"):
        shock_response_spectrum(u, TZOH, F, 0.0, kind="peak")
    with pytest.raises(ServokitValueError, match="freq_hz"):
        shock_response_spectrum(u, TZOH, [0.0, 1.0], 0.0)
    with pytest.raises(ServokitValueError, match="whole number"):
        shock_response_spectrum(half_sine(1e-3), 0.3e-3, F, 0.0, duration=1e-3)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=1, max_size=30),
    st.integers(0, 20),
    st.floats(0.0, 0.05),
    st.floats(1e-3, 5.0),
    st.booleans(),
)
def test_residual_shift_invariant_and_linear(samples, lead, zeta, scale, negative):
    # Leading zeros leave the final state unchanged; the SRS is positively homogeneous.
    u = np.asarray(samples)
    scale = -scale if negative else scale
    f = np.array([500.0, 7e3, 39e3])
    base = shock_response_spectrum(u, TZOH, f, zeta).magnitude
    shifted = shock_response_spectrum(np.r_[np.zeros(lead), u], TZOH, f, zeta).magnitude
    scaled = shock_response_spectrum(scale * u, TZOH, f, zeta, kind="initial").magnitude
    initial = shock_response_spectrum(u, TZOH, f, zeta, kind="initial").magnitude
    tol = 1e-9 * (np.abs(u).max() + 1e-300)
    np.testing.assert_allclose(shifted, base, rtol=1e-9, atol=tol)
    np.testing.assert_allclose(scaled, abs(scale) * initial, rtol=1e-9, atol=abs(scale) * tol)
    assert np.all(initial >= base - tol)


def test_many_frequencies_processed_in_blocks_agree():
    rng = np.random.default_rng(0)
    u = rng.standard_normal(1000)
    f = np.linspace(100.0, 90e3, 2500)  # 2e6 // 2500 = 800 holds per block: two blocks
    full = shock_response_spectrum(u, TZOH, f, 0.005, kind="initial").magnitude
    few = shock_response_spectrum(u, TZOH, f[[0, 1234, 2499]], 0.005, kind="initial").magnitude
    np.testing.assert_allclose(full[[0, 1234, 2499]], few, rtol=1e-10)


def test_held_samples_rejects_non_positive_hold():
    from servokit.sampled.srs import held_samples

    with pytest.raises(ServokitValueError, match="dt_hold must be > 0"):
        held_samples(lambda t: t, 1e-3, -1.0)
