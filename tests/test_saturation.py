"""Actuator saturation and anti-windup (servokit.simulate.saturation).

Independent checks: without active limits the sample-by-sample loop equals the batched
engine of servokit.simulate.simulate at the samples; the limits hold on every sample;
a windup that makes the unprotected loop diverge is removed by the observer anti-windup.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.errors import ServokitValueError
from servokit.simulate import Actuator, simulate, simulate_saturated

PLANT = sk.models.hdd_sampled_data()
DT = sk.models.HDD_SAMPLED_DATA_TS
CTRL = sk.models.get_discrete_controller("eq-4.69", DT)


def test_without_limits_equals_the_linear_engine():
    K = 300
    variants = [PLANT, PLANT.replace(gain=PLANT.gain * 1.1)]
    ref = simulate(variants, dt=DT, n_samples=K, substeps=1, controller=CTRL, reference=np.ones(K))
    for aw in (False, True):  # unsaturated, the anti-windup correction is zero
        got = simulate_saturated(
            variants,
            dt=DT,
            n_samples=K,
            controller=CTRL,
            reference=np.ones(K),
            actuator=Actuator(anti_windup=aw),
        )
        np.testing.assert_allclose(got.yd, ref.yd, rtol=0, atol=1e-12 * np.abs(ref.yd).max())
        assert got.saturated_fraction == 0.0


@settings(max_examples=25, deadline=None)
@given(
    st.floats(0.05, 2.0),
    st.one_of(st.none(), st.floats(1e-3, 0.5)),
    st.booleans(),
    st.floats(0.5, 50.0),
)
def test_limits_hold_on_every_sample(u_max, slew, aw, target):
    act = Actuator(u_max=u_max, slew_max=slew, anti_windup=aw)
    res = simulate_saturated(
        PLANT, dt=DT, n_samples=150, controller=CTRL, reference=[target], actuator=act
    )
    assert np.all(np.abs(res.u) <= u_max * (1 + 1e-12))
    if slew is not None:
        du = np.diff(np.concatenate([np.zeros((1, 1)), res.u], axis=1), axis=1)
        assert np.all(np.abs(du) <= slew * (1 + 1e-12))
    assert res.peak_input <= u_max * (1 + 1e-12)


def test_anti_windup_removes_the_windup_of_a_long_seek():
    K = 2000
    runs = {
        aw: simulate_saturated(
            PLANT,
            dt=DT,
            n_samples=K,
            controller=CTRL,
            reference=[100.0],
            actuator=Actuator(u_max=0.3, anti_windup=aw),
        )
        for aw in (False, True)
    }
    wound, guarded = runs[False].yd[0], runs[True].yd[0]
    assert np.max(np.abs(wound)) > 1e3  # the integrator winds up: the loop runs away
    assert guarded.max() < 100 * 1.01  # no overshoot beyond 1 %
    assert np.all(np.abs(guarded[-200:] - 100) < 0.1)  # settled within 0.1 track
    # saturated at the start: the input sits at the limit while the head accelerates
    assert runs[True].u[0, 0] == pytest.approx(0.3)


def test_open_loop_feedforward_is_clipped():
    ff = np.concatenate([np.full(20, 2.0), np.full(20, -2.0)])
    res = simulate_saturated(
        PLANT, dt=DT, n_samples=60, feedforward=ff, actuator=Actuator(u_max=1.0)
    )
    np.testing.assert_array_equal(res.u[0], np.clip(np.concatenate([ff, np.zeros(20)]), -1, 1))
    assert res.saturated_fraction == pytest.approx(40 / 60)


def test_bad_arguments():
    with pytest.raises(ServokitValueError, match="u_max"):
        Actuator(u_max=0.0)
    with pytest.raises(ServokitValueError, match="slew_max"):
        Actuator(slew_max=-1.0)
    with pytest.raises(ServokitValueError, match="observer_poles"):
        simulate_saturated(
            PLANT,
            dt=DT,
            n_samples=5,
            controller=CTRL,
            reference=[1.0],
            actuator=Actuator(u_max=1.0, observer_poles=(0.5, 0.5, 0.5)),
        )
    with pytest.raises(ServokitValueError, match="dt"):
        simulate_saturated(
            PLANT,
            dt=DT / 2,
            n_samples=5,
            controller=CTRL,
            reference=[1.0],
            actuator=Actuator(u_max=1.0),
        )


@settings(max_examples=40, deadline=None)
@given(
    u=st.lists(st.floats(-5, 5), min_size=1, max_size=40),
    u_max=st.floats(0.1, 6),
    slew=st.one_of(st.none(), st.floats(0.05, 3)),
)
def test_limit_input_holds_the_limits_from_rest_to_rest(u, u_max, slew):
    from servokit.simulate.saturation import limit_input

    applied, n = limit_input(np.array(u), Actuator(u_max, slew, anti_windup=False))
    assert applied.size >= len(u) and np.all(np.abs(applied) <= u_max)
    if slew is not None:  # at rest before and after: zeros padded on both ends
        steps = np.diff(np.concatenate([[0.0], applied, [0.0]]))
        assert np.all(np.abs(steps) <= slew * (1 + 1e-12))
    else:  # amplitude only: a plain clip, its changed samples counted independently
        np.testing.assert_array_equal(applied, np.clip(u, -u_max, u_max))
        assert n == int(np.sum(np.abs(np.array(u)) > u_max))
    loose = limit_input(np.array(u), Actuator(10.0, None if slew is None else 20.0))
    np.testing.assert_array_equal(loose[0], u)
    assert loose[1] == 0
