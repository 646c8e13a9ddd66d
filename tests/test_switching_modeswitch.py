"""Mode switching and reference switching with IVC, against direct closed forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from servokit.switching import (
    equilibrium,
    free_response,
    ivc_additional_input,
    ivc_jmin,
    mode_switching_response,
    pade_double_integrator,
    place_controller,
    reference_switching_response,
    switched_loop,
)


@pytest.fixture(scope="module")
def loop():
    P = pade_double_integrator(1e-4, 0.7e-4)
    return switched_loop(P, place_controller(P, [-0.3, 0.5 + 0.4j, 0.5 - 0.4j, 0.9, 0.95]))


def test_mode_switch_equals_free_response_after_switch(loop):
    seek = np.full(40, 5.0)  # constant acceleration toward the target
    target = 2e-5
    K = ivc_jmin(loop, None, np.diag([1.0, 1e-8, 0.0, 0.0, 0.0]))
    res = mode_switching_response(loop, seek, target, lambda xp, k: xp[0] >= 0.6 * target, K, 200)
    k0 = res.switches[0]
    assert 0 < k0 < 40
    # rebuild the post-switch state from the seek and compare with the free response
    xp = np.zeros(3)
    for k in range(k0):
        xp = loop.Ap @ xp + loop.Bp[:, 0] * seek[k]
    ss = equilibrium(loop, target)
    dev = loop.stack(K) @ (xp - ss[:3])
    expect = ss[0] + free_response(loop.A, loop.C, dev, 200 - k0)[:, 0]
    np.testing.assert_allclose(res.y[k0:], expect, atol=1e-12 * max(1, abs(target)))
    assert res.y[-1] == pytest.approx(target, rel=1e-3)


def test_reference_switch_ivc_replaces_plant_residual_by_d_dynamics(loop):
    # step up at k = 5, back down at k = 20 before settling; with r' on all plant states
    # the run after k = 20 is: the ideal step response from the equilibrium of r = 1, plus
    # the free response of the controller-state residual, plus q(z)/d(z) (d's recursion)
    den = np.poly([0.5] * 4)
    design = ivc_additional_input(loop, 0.5, denominator=den)
    ref = np.concatenate([np.zeros(5), np.ones(15), np.zeros(80)])
    k0 = 20
    for d, ok in ((design, True), (None, False)):
        res = reference_switching_response(loop, ref, d, states=(0, 1, 2))
        assert res.switches == (5, k0)
        ideal = reference_switching_response(loop, np.concatenate([[1.0], ref[k0:]]))
        x = _state(loop, ref, design if d else None, k0)
        xc_res = np.concatenate([np.zeros(3), x[3:] - equilibrium(loop, 1.0)[3:]])
        rest = res.y[k0:] - ideal.y[1:] - free_response(loop.A, loop.C, xc_res, ref.size - k0)[:, 0]
        residual = scipy.signal.lfilter(den, [1.0], rest)[den.size :]
        assert (np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(rest))) == ok


def _state(loop, ref, design, k_stop):
    """Closed-loop state at k_stop, by an independent replay of the first switch."""
    x = equilibrium(loop, ref[0])
    rp = np.zeros(k_stop)
    for k in range(k_stop):
        if k > 0 and ref[k] != ref[k - 1] and design is not None:
            dev = x[:3] - equilibrium(loop, ref[k - 1])[:3]
            for s in range(3):
                rp[k:] += dev[s] * design.impulse(s, k_stop - k)
        x = loop.A @ x + loop.B[:, 0] * ref[k] + loop.Bu[:, 0] * rp[k]
    return x
