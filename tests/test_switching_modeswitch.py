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


def test_reference_step_with_ivc_obeys_d_recursion(loop):
    # from the equilibrium of r = 0 a step to 1: the plant deviation is [-1, 0, 0] and the
    # controller's equilibrium state is zero for this type-2 loop, so with r' compensating
    # the plant states the error after the step is q(z)/d(z): it obeys d's recursion
    den = np.poly([0.5] * 4)
    design = ivc_additional_input(loop, 0.5, denominator=den)
    assert np.allclose(equilibrium(loop, 1.0)[3:], 0.0, atol=1e-9)
    ref = np.concatenate([np.zeros(5), np.ones(80)])
    for d, ok in ((design, True), (None, False)):
        res = reference_switching_response(loop, ref, d, states=(0, 1, 2))
        assert res.switches == (5,)
        err = res.y[5:] - 1.0
        residual = scipy.signal.lfilter(den, [1.0], err)[den.size :]
        small = np.max(np.abs(residual)) < 1e-9 * np.max(np.abs(err))
        assert small == ok
