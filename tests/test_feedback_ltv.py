"""LTV peak filter (5.47)-(5.56): schedule, loop simulation against python-control, decay."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.cases.ltv import arm_loop, ltv_transient_case
from servokit.errors import ServokitValueError
from servokit.feedback.ltv import (
    LoopResponse,
    LtvPeakFilter,
    decay_time,
    schedule,
    simulate_peak_filter_loop,
)


@settings(max_examples=50, deadline=None)
@given(a=st.floats(0.01, 10), b=st.floats(0.01, 10), g=st.floats(0, 1e4))
def test_schedule_starts_at_initial_and_tends_to_final(a, b, g):
    th = schedule(a, b, g, np.array([0.0, 1.0 / max(g, 1e-3), 1e3]))
    assert th[0] == pytest.approx(a)  # (5.49); the printed (5.56) would start at a + b
    assert th[1] == pytest.approx(b + (a - b) * np.exp(-g / max(g, 1e-3)))
    if g > 1:
        assert th[2] == pytest.approx(b)


def test_constant_parameters_equal_the_lti_closed_loop():
    pd, cd = arm_loop()
    flt = LtvPeakFilter.lti(7913.0, 0.02, 0.5, 1.9)
    fz = control.sample_system(flt.frozen(0.0), cd.dt, method="zoh")
    n = 400
    d = np.sin(2 * np.pi * 7913.0 * cd.dt * np.arange(n)) + 0.3
    got = simulate_peak_filter_loop(pd, cd, flt, d).e
    ref = control.forced_response(-1 / (1 + pd * cd * (1 + fz)), U=d).outputs
    np.testing.assert_allclose(got, ref, atol=1e-8)


def test_ltv_filter_differs_from_lti_only_while_parameters_move():
    pd, cd = arm_loop()
    d = np.sin(2 * np.pi * 7913.0 * cd.dt * np.arange(3000))
    lti = simulate_peak_filter_loop(pd, cd, LtvPeakFilter.lti(7913.0, 0.01, 0.5, 2.1), d).e
    ltv = LtvPeakFilter(7913.0, 2.1, (2.0, 0.5), (0.1, 0.01), 3000.0)
    e = simulate_peak_filter_loop(pd, cd, ltv, d).e
    assert np.max(np.abs(e[:100] - lti[:100])) > 0.01
    assert np.max(np.abs(e[-60:])) == pytest.approx(np.max(np.abs(lti[-60:])), rel=0.05)


def test_decay_time_of_an_exponential_envelope():
    t = np.arange(3000) / 30000.0
    e = np.exp(-t / 2e-3) * np.sin(2 * np.pi * 1000.0 * t)
    got = decay_time(LoopResponse(t, e), 1000.0)
    assert got == pytest.approx(2e-3 * np.log(10), abs=1.2e-3)  # within one period


def test_ltv_case_shows_the_faster_transient(tmp_path):
    r = ltv_transient_case(tmp_path)
    assert r.extra["time_to_10pct_ltv_s"] < r.extra["time_to_10pct_lti_s"]
    assert r.comparisons[0].ok


def test_bad_schedule():
    with pytest.raises(ServokitValueError):
        schedule(1.0, -1.0, 10.0, np.array([0.0]))
    with pytest.raises(ServokitValueError):
        schedule(1.0, 1.0, -10.0, np.array([0.0]))
