"""servokit.limits: Bode integrals (6.17)-(6.22), waterbed (6.20), variance bound (6.16)."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitError
from servokit.limits import (
    continuous_bode_integral,
    discrete_bode_integral,
    dynamic_range,
    high_frequency_gain,
    output_variance,
    rolloff_bandwidth,
    variance_lower_bound,
    waterbed_lower_bound,
    waterbed_phi1,
)


def test_waterbed_book_example_is_3_48_db():
    bound = waterbed_lower_bound(10 ** (-40 / 20), waterbed_phi1(1000.0, 25000.0))
    # closed form: 40 dB * phi1 / (pi - phi1) with phi1 = 2 pi / 25
    assert 20 * np.log10(bound) == pytest.approx(40 * (2 / 25) / (1 - 2 / 25), rel=1e-12)
    assert 20 * np.log10(bound) == pytest.approx(3.5, abs=0.05)  # book: 3.5 dB


def test_waterbed_bound_holds_for_a_real_loop():
    """A discrete loop: its measured ||S||inf is at least the bound from its own alpha."""
    loop = control.tf([0.06, 0.05], [1, -1.6, 0.64], 1.0) * control.tf([1, -0.9], [1, -1], 1.0)
    phi = np.linspace(1e-4, np.pi, 20000)
    s = np.abs(1 / (1 + loop(np.exp(1j * phi))))
    phi1 = 0.2
    alpha = s[phi <= phi1].max()
    assert alpha < 1
    assert s.max() >= waterbed_lower_bound(alpha, phi1) * (1 - 1e-9)


def test_continuous_integral_closed_form():
    # L = k/(s+a): int_0^inf ln|S| = 1/2 pi (a - (a+k)) = -pi k / 2 = -pi/2 Ks
    res = continuous_bode_integral(control.tf([3.0], [1.0, 2.0]))
    assert res.limit_gain == 3.0
    assert res.integral == pytest.approx(-1.5 * np.pi, rel=1e-6)
    res2 = continuous_bode_integral(control.tf([5.0], [1.0, 2.0, 1.0]))
    assert abs(res2.integral) < 1e-6 and "Corollary 1" in res2.corollary


@st.composite
def stable_discrete_loops(draw):
    n = draw(st.integers(1, 4))
    radii = draw(st.lists(st.floats(0.0, 0.9), min_size=n, max_size=n))
    angles = draw(st.lists(st.floats(0.0, np.pi), min_size=n, max_size=n))
    poles = [r * np.exp(1j * a) for r, a in zip(radii, angles, strict=True)]
    den = np.real(np.poly(poles + [np.conj(p) for p in poles if abs(p.imag) > 1e-12]))
    num = draw(
        st.lists(
            st.floats(-1.0, 1.0).filter(lambda x: abs(x) > 1e-3),
            min_size=len(den),
            max_size=len(den),
        )
    )
    proper = draw(st.booleans())
    num = np.array(num) if proper else np.r_[0.0, num[1:]]
    return control.tf(num, den, 1.0)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(stable_discrete_loops())
def test_discrete_integral_and_corollaries(loop):
    assume(abs(1 + high_frequency_gain(loop)) > 1e-3)  # Kz = -1 is ill-posed (tested below)
    cl_poles = control.feedback(loop, 1).poles()
    assume(np.all(np.abs(cl_poles) < 0.98))
    res = discrete_bode_integral(loop, n_freq=1 << 14)
    kz = res.limit_gain
    assert res.integral == pytest.approx(-2 * np.pi * np.log(abs(1 + kz)), abs=1e-6)
    if kz == 0:
        assert abs(res.integral) < 1e-6
    elif kz > 0 or kz < -2:
        assert res.integral < 0 and "Corollary 3" in res.corollary
    else:
        assert res.integral > 0 and "Corollary 4" in res.corollary


def test_high_frequency_gain_and_errors():
    assert high_frequency_gain(control.tf([2.0, 1.0], [4.0, 0.5], 1.0)) == 0.5
    with pytest.raises(ServokitError, match="strictly proper"):
        high_frequency_gain(control.tf([2.0, 1.0], [1.0, 1.0]))
    with pytest.raises(ServokitError, match="unstable"):
        discrete_bode_integral(control.tf([5.0], [1.0, -0.5], 1.0))  # closed-loop pole -4.5
    with pytest.raises(ServokitError, match="ill-posed"):
        discrete_bode_integral(control.tf([-1.0, 1.0], [1.0, 0.0], 1.0))
    with pytest.raises(ServokitError, match="alpha"):
        waterbed_lower_bound(1.5, 0.3)
    with pytest.raises(ServokitError, match="Nyquist"):
        waterbed_phi1(20000, 25000)


@settings(max_examples=15, deadline=None)
@given(
    st.floats(50.0, 2000.0),  # loop crossover scale [rad/s]
    st.floats(5.0, 500.0),  # disturbance corner [rad/s]
    st.floats(0.2, 0.6),
    st.integers(1, 2),
)
def test_variance_bound_is_below_the_variance(wc, wd, delta, k):
    """The corrected (6.16) never exceeds the true (6.13) variance."""
    loop = control.tf([wc**2], [1.0, 1.5 * wc, 0.0]) * control.tf([1.0], [1 / (20 * wc), 1.0])
    dist = control.tf([1.0], [1 / wd, 1.0])
    omega_hz = rolloff_bandwidth(loop, delta=delta, k=k)
    bound = variance_lower_bound(dist, omega_hz, delta=delta, k=k)
    var = output_variance(loop, dist)
    assert 0 < bound.bound <= var * (1 + 1e-6)
    assert bound.gamma > 0


def test_rolloff_bandwidth_meets_its_definition():
    loop = control.tf([1e6], [1.0, 1500.0, 0.0])
    f = rolloff_bandwidth(loop, delta=0.5, k=1)
    w = np.geomspace(2 * np.pi * f, 1e8, 2000)
    assert np.all(np.abs(loop(1j * w)) <= 0.5 * (2 * np.pi * f / w) ** 2 * (1 + 1e-3))


def test_printed_e_beta_is_not_a_bound():
    """The printed (6.16) (e^beta without e^-2gamma) exceeds the true variance here."""
    loop = control.tf([4e4], [1, 300, 0]) * control.tf([1], [1 / 3000, 1])
    dist = control.tf([1], [1 / 100, 1])
    vb = variance_lower_bound(dist, rolloff_bandwidth(loop))
    var = output_variance(loop, dist)
    assert vb.bound < var < vb.printed


@pytest.mark.parametrize("k", [1, 2, 3])
def test_printed_form_is_e_beta_plus_the_ke_tail(k):
    """``printed`` = (Omega/pi) e^beta + the tail with exponent ke (k + 1 for odd k, whose
    quadrature is the bound's own ``high``; k for even k, integrated separately)."""
    from scipy.integrate import quad

    dist = control.tf([1], [1 / 100, 1])
    vb = variance_lower_bound(dist, 50.0, delta=0.5, k=k)
    omega = 2 * np.pi * 50.0
    ke = k + 1 if k % 2 else k
    tail = (
        quad(
            lambda w: abs(dist(1j * w)) ** 2 / (1 + 0.5 * (omega / w) ** ke) ** 2,
            omega,
            np.inf,
            limit=1000,
        )[0]
        / np.pi
    )
    assert vb.printed == pytest.approx(omega / np.pi * np.exp(vb.beta) + tail, rel=1e-9)
    if k % 2:
        assert vb.printed - omega / np.pi * np.exp(vb.beta) == pytest.approx(vb.high, rel=1e-12)
    else:
        assert vb.high > tail  # (Omega/w)^(k+1) <= (Omega/w)^k: the k + 1 tail is larger


def test_discrete_variance_matches_simulation_free_closed_form():
    # D = 1 (unit white noise), S = 1/(1+L) with L = a/(z - 1): S = (z-1)/(z-1+a)
    # var = ||S||_2^2 = 1 + a^2/(1-(1-a)^2) = 2/(2-a)
    a = 0.5
    loop = control.tf([a], [1.0, -1.0], 1.0)
    dist = control.tf([1.0], [1.0], 1.0)
    assert output_variance(loop, dist) == pytest.approx(2 / (2 - a), rel=1e-8)


def test_dynamic_range():
    assert dynamic_range(0.03, 3e-9) == pytest.approx(1e-7)
    with pytest.raises(ServokitError, match="accuracy_m"):
        dynamic_range(1e-3, 1.0)
    # the smallest normal quotient is returned; one that underflows is refused, not 0
    assert dynamic_range(1.0, 1e-300) == pytest.approx(1e-300)
    with pytest.raises(ServokitError, match="underflows"):
        dynamic_range(1e300, 1e-300)


def test_discrete_integral_with_integrators_is_zero():
    """HDD loop (4.64)+(4.69): triple pole at z = 1 (rigid body + integral action)."""
    from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data

    loop = control.ss(controller_eq_4_69()) * hdd_sampled_data().discretize(HDD_SAMPLED_DATA_TS)
    res = discrete_bode_integral(loop)
    assert abs(res.integral) < 1e-9 and res.limit_gain == 0.0


def test_public_api_contract():
    import servokit as sk

    assert sk.limits.waterbed_lower_bound(0.01, 2 * np.pi / 25) == pytest.approx(
        100 ** ((2 / 25) / (1 - 2 / 25))
    )
    assert sk.learn.SettlingJudge is not None
