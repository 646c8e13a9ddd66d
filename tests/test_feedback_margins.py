"""stability_margins against python-control, brute-force grids and identities."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback import Margins, stability_margins
from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data


def brute(resp, f):
    """Independent crossings: sign changes on a very fine linear grid, linear interpolation."""
    L = resp(f)
    lm = np.log(np.abs(L))
    i = np.nonzero(np.sign(lm[:-1]) != np.sign(lm[1:]))[0]
    wc = f[i] - lm[i] * (f[i + 1] - f[i]) / (lm[i + 1] - lm[i])
    im = np.sin(np.angle(L))
    j = np.nonzero((np.sign(im[:-1]) != np.sign(im[1:])) & (L.real[:-1] < 0))[0]
    w180 = f[j] - im[j] * (f[j + 1] - f[j]) / (im[j + 1] - im[j])
    return wc, w180


@settings(max_examples=25, deadline=None)
@given(k=st.floats(50, 3000), a=st.floats(5, 50), b=st.floats(60, 400))
def test_equals_python_control_on_third_order_loops(k, a, b):
    loop = control.tf([k], [1, a + b, a * b, 0])
    gm, pm, _, w180, wc = control.stability_margins(loop)[:5]
    m = stability_margins(loop)
    if np.isfinite(gm):
        assert m.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=1e-6)
        assert m.gm_freq_hz == pytest.approx(w180 / (2 * np.pi), rel=1e-6)
    assert m.phase_margin_deg == pytest.approx(pm, abs=1e-6)
    assert m.pm_freq_hz == pytest.approx(wc / (2 * np.pi), rel=1e-6)


def test_delay_margin_is_pm_over_crossover_and_makes_the_loop_marginal():
    loop = control.tf([1000.0], [1, 30, 200, 0])
    m = stability_margins(loop)
    assert m.delay_margin_s == pytest.approx(
        np.radians(m.phase_margin_deg) / (2 * np.pi * m.pm_freq_hz)
    )
    marginal = stability_margins(loop, delay=m.delay_margin_s)
    assert marginal.phase_margin_deg == pytest.approx(0.0, abs=1e-6)


def test_exact_delay_equals_an_integer_sample_delay_in_discrete_time():
    dt = 1e-3
    loop = control.sample_system(control.tf([1000.0], [1, 30, 200, 0]), dt)
    z = control.tf([1], [1, 0, 0], dt)
    a = stability_margins(loop, delay=2 * dt)
    b = stability_margins(loop * z)
    assert a.phase_margin_deg == pytest.approx(b.phase_margin_deg, abs=1e-8)
    assert a.gain_margin_db == pytest.approx(b.gain_margin_db, abs=1e-8)


def test_section_4_5_loop_matches_an_independent_fine_grid():
    plant = hdd_sampled_data().discretize(HDD_SAMPLED_DATA_TS)
    ctrl = controller_eq_4_69()
    m = stability_margins([plant, ctrl])
    assert isinstance(m, Margins)
    f = np.linspace(1.0, 0.5 / HDD_SAMPLED_DATA_TS, 60_001)

    def resp(x):
        z = np.exp(2j * np.pi * x * HDD_SAMPLED_DATA_TS)
        return plant(z) * ctrl(z)

    wc, w180 = brute(resp, f)
    assert np.array(m.gain_crossovers_hz) == pytest.approx(wc, rel=1e-5)
    assert np.array(m.phase_crossovers_hz) == pytest.approx(w180, rel=1e-5)
    # the values the earlier analysis of §4.5 gave; python-control reports PM 19.9° at 317 Hz
    assert m.pm_freq_hz == pytest.approx(819.4, abs=0.1)
    assert m.phase_margin_deg == pytest.approx(30.3, abs=0.05)
    assert m.gain_margin_db == pytest.approx(4.21, abs=0.005)
    at_317 = abs(resp(np.array([317.0]))[0])
    assert at_317 > 2  # not a crossover, whatever a polynomial root finder says


def test_no_crossing_gives_infinite_margins():
    m = stability_margins(control.tf([0.1], [1, 1]))
    assert m.phase_margin_deg == np.inf and m.gain_margin_db == np.inf
    d = m.to_dict()
    assert set(d) >= {"gain_margin_db", "phase_margin_deg", "gm_freq_hz", "pm_freq_hz"}


def test_bad_arguments():
    with pytest.raises(ServokitValueError):
        stability_margins(control.tf([1], [1, 1]), delay=-1)
    with pytest.raises(ServokitValueError):
        stability_margins(control.tf([1], [1, 1], 0.1), fmax=100)
    with pytest.raises(TypeError):
        stability_margins("loop")


@pytest.mark.parametrize("which", ["table-5.2", "multirate-4.5.2"])
def test_high_order_loops_match_an_independent_fine_grid(which):
    if which == "table-5.2":
        from servokit.models import vcm_controller_table_5_2, vcm_dual_stage

        ctrl = vcm_controller_table_5_2()
        plant = vcm_dual_stage().discretize(ctrl.dt)
    else:
        from servokit.cases.hdd_sensitivity import hdd_multirate

        ctrl = controller_eq_4_69()
        plant = hdd_multirate(ctrl.dt, 4).discretize(hdd_sampled_data(), ctrl.dt)
    m = stability_margins([plant, ctrl])
    f = np.linspace(5.0, 0.5 / ctrl.dt * (1 - 1e-9), 60_001)
    loop = control.ss(plant) * control.ss(ctrl)

    def resp(x):
        return np.asarray(loop(np.exp(2j * np.pi * x * ctrl.dt)), dtype=complex).ravel()

    wc, w180 = brute(resp, f)
    assert np.array(m.gain_crossovers_hz) == pytest.approx(wc, rel=1e-4)
    lo = [x for x in m.phase_crossovers_hz if 5.0 <= x < f[-1]]  # the grid stops short of Nyquist
    assert np.array(lo) == pytest.approx(w180, rel=1e-4)
    # the crossing values themselves: |L| = 1 and L real negative there
    assert np.abs(resp(np.array(m.gain_crossovers_hz))) == pytest.approx(1.0, rel=1e-8)
    assert np.angle(-resp(np.array(m.phase_crossovers_hz))) == pytest.approx(0.0, abs=1e-8)


def test_phase_stabilised_peak_gives_a_second_phase_margin():
    # rigid body with lead, plus an in-phase resonance whose peak rises above 0 dB
    w1 = 2 * np.pi * 5000.0
    plant = control.tf([1.0], [1, 0, 0]) + control.tf([5.0], [1, 2 * 0.01 * w1, w1 * w1])
    wc = 2 * np.pi * 500.0
    ctrl = control.tf([1 / (wc / 3), 1], [1 / (3 * wc), 1])
    loop = plant * ctrl * (1 / abs(complex((plant * ctrl)(1j * wc))))
    m = stability_margins(loop)
    assert len(m.gain_crossovers_hz) == 3
    assert m.pm_freq_hz == pytest.approx(500.0, rel=1e-6)
    assert m.second_phase_margin_deg == pytest.approx(m.phase_margins_deg[1] % 360.0)
    assert 0.0 <= m.second_phase_margin_deg < 360.0
    # each crossover's phase margin is 180 + arg L there
    for f, pm in zip(m.gain_crossovers_hz, m.phase_margins_deg, strict=True):
        arg = np.degrees(np.angle(complex(loop(2j * np.pi * f))))
        assert (pm - 180.0 - arg) % 360.0 == pytest.approx(0.0, abs=1e-6)
