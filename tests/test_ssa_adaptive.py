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
