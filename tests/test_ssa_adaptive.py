"""Adaptive non-model-based SSA control (book §5.4.4): the Lyapunov function (5.76)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import trapezoid

from servokit.errors import ServokitValueError
from servokit.feedback.adaptive import (
    AdaptiveGains,
    cantilever_beam,
    simulate_adaptive,
)

BEAM = cantilever_beam(3)


def test_lyapunov_non_increasing_and_matches_5_78() -> None:
    run = simulate_adaptive(BEAM, AdaptiveGains(), duration=2e-3, n_out=2000)
    assert run.max_increase() < 1e-9
    # V(0) - V(T) equals the integrated dissipation -V' of (5.78): the adaptation terms cancel
    lost = trapezoid(run.dissipation, run.t)
    assert run.V[0] - run.V[-1] == pytest.approx(lost, rel=2e-3)
    assert run.amplitude_ratio() < 0.6  # the vibration amplitude falls


def test_a_wrong_integral_law_breaks_the_identity(monkeypatch) -> None:
    # ki must be k0^2 for the k0 adaptation to cancel in V'; with ki = 2 k0^2 it does not
    import servokit.feedback.adaptive as ad

    def gap(run) -> float:
        return abs(run.V[0] - run.V[-1] - trapezoid(run.dissipation, run.t)) / run.V[0]

    good = gap(simulate_adaptive(BEAM, AdaptiveGains(), duration=1e-3, n_out=1000))
    right = ad._control

    def wrong(beam, g, x):
        u, y, f = right(beam, g, x)
        n = beam.tip.size
        return u - x[2 * n + 3] ** 2 * x[2 * n], y, f

    monkeypatch.setattr(ad, "_control", wrong)
    bad = gap(simulate_adaptive(BEAM, AdaptiveGains(), duration=1e-3, n_out=1000))
    assert bad > 20 * good


@settings(max_examples=5, deadline=None)
@given(st.floats(5e7, 2e8), st.floats(10.0, 1e3), st.floats(1e3, 3e4))
def test_lyapunov_non_increasing_for_other_gains(kp, beta, ys0) -> None:
    run = simulate_adaptive(
        cantilever_beam(2), AdaptiveGains(kp=kp, beta=beta, ys0=ys0), duration=1e-3, n_out=800
    )
    assert run.max_increase() < 1e-9


def test_beam_and_bad_input() -> None:
    b = cantilever_beam(3, first_hz=5400.0)
    assert b.freq_hz[1] / b.freq_hz[0] == pytest.approx((4.6941 / 1.8751) ** 2)
    with pytest.raises(ServokitValueError, match="n_modes"):
        cantilever_beam(9)
    with pytest.raises(ServokitValueError, match="duration"):
        simulate_adaptive(b, duration=0.0)
    assert np.all(np.isfinite(b.strain))


def _numpy_rhs(beam, g, x):
    """The right-hand side as numpy array expressions (the form before issue 24)."""
    n = beam.tip.size
    q, qd, iy, i_f, ys, k0 = x[:n], x[n : 2 * n], x[2 * n], x[2 * n + 1], x[2 * n + 2], x[-1]
    y, f, yd = float(beam.tip @ q), float(beam.strain @ q), float(beam.tip @ qd)
    kf = ys * ys if g.adaptive else 0.0
    u = -g.kp * y - k0 * k0 * iy - kf * f * i_f
    dys = g.alpha * ys * yd * f * i_f - g.beta * ys if g.adaptive else 0.0
    dk0 = g.gamma * k0 * yd * iy
    qdd = beam.tip * u - 2 * beam.damping * beam.omega * qd - beam.omega * beam.omega * q
    return np.concatenate([qd, qdd, [y, f, dys, dk0]])


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 4),
    damping=st.sampled_from([1e-6, 1e-3, 0.01, 0.5]),
    first_hz=st.floats(1.0, 1e5),
    scale_exp=st.integers(-12, 3),
    adaptive=st.booleans(),
    seed=st.integers(0, 10_000),
)
def test_float_rhs_is_the_numpy_rhs_bitwise(n, damping, first_hz, scale_exp, adaptive, seed):
    """The Python-float right-hand side does the numpy form's arithmetic, bit for bit."""
    import servokit.feedback.adaptive as ad

    beam = cantilever_beam(n, first_hz=first_hz, damping=damping)
    g = AdaptiveGains(adaptive=adaptive)
    rng = np.random.default_rng(seed)
    scale = np.r_[np.full(2 * n, 10.0**scale_exp), 1e-9, 1e-9, 1e4, 1e4]
    rhs = ad._rhs(beam, g)
    for x in rng.standard_normal((20, 2 * n + 4)) * scale:
        assert np.array_equal(np.asarray(rhs(0.0, x)), _numpy_rhs(beam, g, x))
