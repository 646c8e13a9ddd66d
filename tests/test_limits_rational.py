"""servokit.limits.RationalLoop: the numpy-only loop against python-control.

The CLI's ``limits`` commands hand the limit functions a :class:`RationalLoop` instead of a
``control.TransferFunction`` (start-up, issue 23); every number must be the same.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitError
from servokit.limits import (
    RationalLoop,
    continuous_bode_integral,
    discrete_bode_integral,
    high_frequency_gain,
    rolloff_bandwidth,
    variance_against_bound,
)
from servokit.limits.rational import as_rational


def _assert_same_roots(mine: np.ndarray, ref: np.ndarray, scale: float) -> None:
    """Same roots, compared through the monic polynomial they span: a root of
    multiplicity m moves by eps^(1/m) under round-off (a triple pole by 6e-6), its
    polynomial by eps."""
    assert mine.size == ref.size
    powers = scale ** np.arange(mine.size + 1)  # coefficient c_j scales as scale^j
    np.testing.assert_allclose(
        np.real(np.poly(mine)) / powers, np.real(np.poly(ref)) / powers, rtol=0, atol=1e-9
    )


@st.composite
def resonant_loops(draw):
    """``k w^2 / (s^2 + 2 zeta w s + w^2)`` times a lead ``(s/z + 1)/(s/p + 1)``, with
    damping down to 1e-6 and frequencies from 1e-3 to 1e6 rad/s; discrete or not."""
    w = draw(st.floats(1e-3, 1e6))
    zeta = draw(st.floats(1e-6, 2.0))
    k = draw(st.floats(1e-3, 1e3))
    z, p = w * draw(st.floats(0.01, 10.0)), w * draw(st.floats(0.01, 10.0))
    num = np.polymul([k * w * w], [1.0 / z, 1.0])
    den = np.polymul([1.0, 2.0 * zeta * w, w * w], [1.0 / p, 1.0])
    return num, den, w


@settings(max_examples=60, deadline=None)
@given(resonant_loops(), st.booleans())
def test_roots_and_response_match_python_control(loop, discrete):
    num, den, w = loop
    if discrete:  # a discrete loop of the same coefficients (just a polynomial ratio)
        num, den = num / den[0], den / den[0]
    dt = 1.0 if discrete else None
    mine = RationalLoop(num, den, dt)
    ref = control.tf(num, den, dt) if discrete else control.tf(num, den)
    scale = float(np.max(np.abs(ref.poles()))) + 1.0
    _assert_same_roots(mine.poles(), np.asarray(ref.poles()), scale)
    _assert_same_roots(mine.zeros(), np.asarray(ref.zeros()), scale)
    cl = control.feedback(ref, 1)
    _assert_same_roots(mine.closed_loop_poles(), np.asarray(cl.poles()), scale)
    x = 1j * w * np.geomspace(1e-3, 1e3, 64)
    np.testing.assert_allclose(mine(x), np.asarray(ref(x)), rtol=1e-12)
    assert mine.isdtime() == ref.isdtime()


def test_as_rational_reads_tf_and_state_space_and_refuses_others():
    tf = control.tf([0.5, 0.1], [1.0, -0.5, 0.1], 1e-4)
    r = as_rational(control.ss(tf))
    np.testing.assert_allclose(r.num, np.asarray(tf.num[0][0]).ravel()[-2:], rtol=1e-12)
    np.testing.assert_allclose(r.den, tf.den[0][0], rtol=1e-12)
    assert r.dt == 1e-4 and as_rational(r) is r
    with pytest.raises(ServokitError, match="RationalLoop"):
        as_rational([1.0, 2.0])
    with pytest.raises(ServokitError, match="SISO"):
        as_rational(control.ss(np.eye(2), np.eye(2), np.eye(2), 0))
    with pytest.raises(ServokitError, match="den"):
        RationalLoop([1.0], [0.0, 0.0])
    with pytest.raises(ServokitError, match="dt"):
        RationalLoop([1.0], [1.0, 1.0], -1.0)


@st.composite
def stable_discrete_loops(draw):
    """A stable discrete loop ``k (z - c) / prod (z - p)`` with poles up to radius 0.95."""
    n = draw(st.integers(1, 3))
    poles = [
        draw(st.floats(0.0, 0.95)) * np.exp(1j * draw(st.floats(0.0, np.pi))) for _ in range(n)
    ]
    den = np.real(np.poly(poles + [np.conj(p) for p in poles if abs(p.imag) > 1e-12]))
    gain = draw(st.floats(1e-3, 0.05))
    num = gain * np.array([1.0, -draw(st.floats(-0.9, 0.9))])
    return num, den


@settings(max_examples=30, deadline=None)
@given(stable_discrete_loops())
def test_discrete_bode_integral_equals_the_python_control_path(loop):
    num, den = loop
    ref = control.tf(num, den, 1.0)
    try:
        want = discrete_bode_integral(ref, n_freq=1 << 12)
    except ServokitError:  # an unstable closed loop: the same refusal on both paths
        with pytest.raises(ServokitError, match="unstable"):
            discrete_bode_integral(RationalLoop(num, den, 1.0), n_freq=1 << 12)
        return
    got = discrete_bode_integral(RationalLoop(num, den, 1.0), n_freq=1 << 12)
    assert got.integral == pytest.approx(want.integral, rel=1e-12, abs=1e-12)
    assert got.theory == pytest.approx(want.theory, rel=1e-12, abs=1e-14)
    assert (got.limit_gain, got.corollary) == (want.limit_gain, want.corollary)


@pytest.mark.parametrize(
    ("num", "den"),
    [([3.0], [1.0, -1.0]), ([4e4], [1.0, 300.0, 0.0]), ([2.0, 1.0], [1.0, 3.0, 4.0, 1.0])],
)
def test_continuous_integral_and_variance_equal_the_python_control_path(num, den):
    ref, mine = control.tf(num, den), RationalLoop(num, den)
    want, got = continuous_bode_integral(ref), continuous_bode_integral(mine)
    assert got.integral == pytest.approx(want.integral, rel=1e-12)
    assert (got.theory, got.limit_gain) == pytest.approx((want.theory, want.limit_gain), rel=1e-12)
    assert high_frequency_gain(mine) == high_frequency_gain(ref)
    assert rolloff_bandwidth(mine) == pytest.approx(rolloff_bandwidth(ref), rel=1e-12)


def test_variance_against_bound_equals_the_python_control_path():
    loop, dist = ([4e4], [1.0, 300.0, 0.0]), ([1.0], [0.01, 1.0])
    want = variance_against_bound(control.tf(*loop), control.tf(*dist))
    got = variance_against_bound(RationalLoop(*loop), RationalLoop(*dist))
    assert got.bandwidth_hz == pytest.approx(want.bandwidth_hz, rel=1e-12)
    assert got.variance == pytest.approx(want.variance, rel=1e-12)
    assert got.bound.bound == pytest.approx(want.bound.bound, rel=1e-12)
    assert got.bound.printed == pytest.approx(want.bound.printed, rel=1e-12)
    # discrete, and an unstable closed loop refused alike
    dl, dd = (
        RationalLoop([0.5, 0.1], [1.0, -0.5, 0.1], 1e-4),
        RationalLoop([1.0], [1.0, -0.5], 1e-4),
    )
    ref = variance_against_bound(control.tf([0.5, 0.1], [1.0, -0.5, 0.1], 1e-4),
                                 control.tf([1.0], [1.0, -0.5], 1e-4))  # fmt: skip
    assert variance_against_bound(dl, dd).variance == pytest.approx(ref.variance, rel=1e-12)
    with pytest.raises(ServokitError, match="unstable"):
        variance_against_bound(RationalLoop([0.5], [1.0, -1.0]), RationalLoop([1.0], [1.0, 1.0]))
