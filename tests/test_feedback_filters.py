"""Filters of chapter 5 against closed forms and their defining conditions."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback import (
    complex_lag,
    design_peak_filter,
    discretize_filter,
    inverse_pair,
    lag,
    lead_lag,
    notch,
    peak_filter,
    peak_filter_phase,
    pi_controller,
)


def at(sys: control.LTI, f: float) -> complex:
    x = np.exp(2j * np.pi * f * sys.dt) if sys.dt else 2j * np.pi * f
    return complex(sys(x))


@settings(max_examples=40, deadline=None)
@given(
    f_r=st.floats(100, 2e4),
    z_r=st.floats(0.001, 0.5),
    ratio=st.floats(1.0, 1.5),
    z_d=st.floats(np.sqrt(2) / 2, 1.0),
)
def test_notch_cancels_the_mode_and_has_unit_dc_gain(f_r, z_r, ratio, z_d):
    n = notch(f_r, z_r, filter_freq_hz=ratio * f_r, filter_damping=z_d)
    w = 2 * np.pi * f_r
    mode = control.tf([w * w], [1, 2 * z_r * w, w * w])  # R(s), (5.13)
    assert complex(n(0)) == pytest.approx(1.0, rel=1e-12)
    # N R equals the filter's own second order: the resonance is gone
    wd = 2 * np.pi * ratio * f_r
    for f in (0.5 * f_r, f_r, 2 * f_r):
        expected = wd**2 / ((2j * np.pi * f) ** 2 + 2 * z_d * wd * 2j * np.pi * f + wd**2)
        assert abs(at(n * mode, f) - expected) < 1e-9 * max(1, abs(expected))


def test_high_pass_notch_loses_less_phase_below_the_mode():
    plain = notch(4000, 0.02, filter_damping=0.7)
    high = notch(4000, 0.02, filter_freq_hz=6000, filter_damping=0.7)
    assert np.angle(at(high, 2000)) > np.angle(at(plain, 2000))


@settings(max_examples=40, deadline=None)
@given(
    f_m=st.floats(100, 2e4),
    zeta=st.floats(0.01, 1.0),
    phi=st.floats(-1.4, 1.4),
)
def test_complex_lag_gives_minus_two_phi_at_wm(f_m, zeta, phi):
    c = complex_lag(f_m, zeta, phi)
    assert np.angle(at(c, f_m)) == pytest.approx(-2 * phi, abs=1e-9)
    wz2 = c.num[0][0][-1] / c.num[0][0][0]
    wp2 = c.den[0][0][-1]
    assert np.sqrt(wz2 * wp2) == pytest.approx((2 * np.pi * f_m) ** 2, rel=1e-9)


def test_complex_lag_book_example_is_a_lag_of_2_3038_rad():
    c = complex_lag(6900, 0.1, 1.1519)
    assert np.angle(at(c, 6900)) == pytest.approx(-2.3038, abs=1e-12)
    poles = np.sort(np.abs(c.poles())) / (2 * np.pi)
    zeros = np.sort(np.abs(c.zeros())) / (2 * np.pi)
    assert poles[0] < 6900 < zeros[0]


@settings(max_examples=40, deadline=None)
@given(
    f1=st.floats(100, 2e4),
    zeta=st.floats(0.001, 0.5),
    k=st.floats(0.01, 10),
    phi=st.floats(-10, 10),
)
def test_peak_filter_formula_and_periodicity(f1, zeta, k, phi):
    flt = peak_filter(f1, zeta, k, phi)
    w1 = 2 * np.pi * f1
    for f in (0.3 * f1, f1, 3 * f1):
        s = 2j * np.pi * f
        closed = k * s * (s * np.cos(phi) + w1 * np.sin(phi)) / (s * s + 2 * zeta * w1 * s + w1**2)
        assert abs(at(flt, f) - closed) < 1e-9 * max(1, abs(closed))
    # at ω1 the response is K/(2ζ) j e^{-jφ}: (5.18) then makes Sh F real positive there
    assert at(flt, f1) == pytest.approx(k / (2 * zeta) * 1j * np.exp(-1j * phi), rel=1e-9)
    assert at(peak_filter(f1, zeta, k, phi + 2 * np.pi), f1) == pytest.approx(at(flt, f1))


def test_peak_filter_phase_is_arg_plus_quarter_turn():
    assert peak_filter_phase(1j) == pytest.approx(np.pi)
    assert peak_filter_phase(np.exp(-0.3j)) == pytest.approx(np.pi / 2 - 0.3)


def test_lead_lag_lag_pi_match_book_forms():
    c = lead_lag(5.0)
    s = 2j * np.pi * 700
    assert at(c, 700) == pytest.approx(5 * (s + 100 * np.pi) ** 2 / (s * (s + 2 * np.pi * 30000)))
    cm = lag(2.0)
    assert at(cm, 700) == pytest.approx(2 * (s + 2 * np.pi * 30000) / (s + 2 * np.pi * 900))
    pi = pi_controller(3.0, 100.0)
    assert at(pi, 700) == pytest.approx(3 * (s + 2 * np.pi * 100) / s)


def test_inverse_pair_has_unit_dc_gain_and_the_given_frequencies():
    p = inverse_pair(4449, 4775)
    assert complex(p(0)) == pytest.approx(1.0, rel=1e-12)
    assert np.abs(p.zeros()) / (2 * np.pi) == pytest.approx([4449, 4449])
    assert np.abs(p.poles()) / (2 * np.pi) == pytest.approx([4775, 4775])


def test_prewarped_tustin_keeps_the_peak_frequency():
    dt = 1 / 30000
    flt = peak_filter(7913, 0.02, 1.0, 0.4)
    fd = discretize_filter(flt, dt, 7913)
    assert at(fd, 7913) == pytest.approx(at(flt, 7913), rel=1e-9)


@pytest.mark.parametrize(
    "call",
    [
        lambda: notch(-1, 0.1),
        lambda: notch(1000, 1.5),
        lambda: peak_filter(1000, 0.01, -1, 0),
        lambda: peak_filter(1000, 0.01, 1, np.nan),
        lambda: complex_lag(1000, 0.1, 2.0),
        lambda: discretize_filter(notch(1000, 0.1), 1e-3, 600),
    ],
)
def test_bad_filter_arguments_raise(call):
    with pytest.raises(ServokitValueError):
        call()


@pytest.mark.parametrize(
    "method, offset",
    [
        ("stable", np.pi / 2),
        ("frequency-shift", np.pi / 2),
        ("phase-shift", 0.0),
        ("transient", -np.pi / 2),
    ],
)
def test_zero_placements_offsets(method, offset):
    sh = 0.7 * np.exp(-0.4j)
    assert np.exp(1j * peak_filter_phase(sh, method)) == pytest.approx(np.exp(1j * (offset - 0.4)))


def test_design_peak_filter_makes_sh_f_real_at_w1():
    sh = control.tf([1.0], [1 / 3000.0, 1])
    flt, phi = design_peak_filter(sh, 1000.0, 0.02, 0.5)
    g = complex(sh(2j * np.pi * 1000)) * at(flt, 1000)
    assert g.imag == pytest.approx(0.0, abs=1e-9) and g.real > 0  # (5.21)
    with pytest.raises(ServokitValueError):
        peak_filter_phase(1.0, "sideways")


@settings(max_examples=30, deadline=None)
@given(f=st.floats(10.0, 5e4), k=st.floats(0.01, 5.0), phi=st.floats(-3.0, 3.0))
def test_sensitivity_factorises_as_s0_times_sf(f, k, phi):
    """(5.15)-(5.16) and (5.22): S = S0 SF with SF = 1/(1 + Sh F)."""
    from servokit.feedback import pseudo_plant

    plant = control.tf([1e8], [1, 500, 0])
    ctrl = lead_lag(0.05)
    flt = peak_filter(3000.0, 0.02, k, phi)
    sh = pseudo_plant(plant * ctrl)
    s = 2j * np.pi * f
    pc, fv, shv = complex((plant * ctrl)(s)), complex(flt(s)), complex(sh(s))
    assert shv == pytest.approx(pc / (1 + pc), rel=1e-9)
    assert 1 / (1 + pc * (1 + fv)) == pytest.approx(1 / (1 + pc) / (1 + shv * fv), rel=1e-9)
    assert pc * (1 + fv) == pytest.approx((1 + pc) * (1 + shv * fv) - 1, rel=1e-9, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(
    f_r=st.floats(10.0, 2e4),
    z_r=st.floats(1e-6, 0.99),
    ratio=st.floats(0.5, 2.0),
    z_d=st.floats(0.05, 1.0),
    nyquist_share=st.floats(0.01, 0.9),
)
@example(  # zeros = poles: the notch is 1, and so is its Tustin map (was refused)
    f_r=10.0, z_r=0.5, ratio=1.0, z_d=0.5, nyquist_share=0.5
)
def test_numpy_notch_and_tustin_match_python_control(f_r, z_r, ratio, z_d, nyquist_share) -> None:
    # the CLI's control-free path (start-up) against notch() + control.sample_system
    from servokit.feedback.filters import notch_coefficients, tustin_coefficients

    num, den = notch_coefficients(f_r, z_r, filter_freq_hz=ratio * f_r, filter_damping=z_d)
    ref = notch(f_r, z_r, filter_freq_hz=ratio * f_r, filter_damping=z_d)
    np.testing.assert_allclose(num, ref.num[0][0], rtol=1e-13)
    np.testing.assert_allclose(den, ref.den[0][0], rtol=1e-13)
    dt = nyquist_share * 0.5 / f_r  # prewarped at f_r, anywhere below Nyquist
    num_z, den_z = tustin_coefficients(num, den, dt, f_r)
    ref_z = discretize_filter(ref, dt, f_r)
    scale = np.max(np.abs(ref_z.den[0][0]))
    np.testing.assert_allclose(num_z, ref_z.num[0][0], rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(den_z, ref_z.den[0][0], rtol=1e-9, atol=1e-12 * scale)
    assert den_z[0] == 1.0
    # exact at the prewarp frequency: the discrete filter equals the continuous one there
    z = np.exp(2j * np.pi * f_r * dt)
    at_z = np.polyval(num_z, z) / np.polyval(den_z, z)
    assert abs(at_z - at(ref, f_r)) <= 1e-7 * max(1.0, abs(at(ref, f_r)))


def test_tustin_coefficients_of_a_lag_and_the_nyquist_check() -> None:
    from servokit.feedback.filters import tustin_coefficients

    g = lag(2.0, 3000.0, 300.0)  # first order, num and den of equal length
    num_z, den_z = tustin_coefficients(g.num[0][0], g.den[0][0], 1e-4, 300.0)
    ref = discretize_filter(g, 1e-4, 300.0)
    np.testing.assert_allclose(num_z, ref.num[0][0], rtol=1e-12)
    np.testing.assert_allclose(den_z, ref.den[0][0], rtol=1e-12)
    with pytest.raises(ServokitValueError, match="Nyquist"):
        tustin_coefficients([1.0], [1.0, 1.0], 1e-3, 600.0)
    with pytest.raises(ServokitValueError, match="proper"):
        tustin_coefficients([1.0, 0.0, 0.0], [1.0, 1.0], 1e-3, 100.0)
