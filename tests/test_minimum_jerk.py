"""Bang-bang (2.10), minimum jerk (2.14)-(2.15) and its ZOH implementation (Fig. 2.10)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.integrate
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedforward.minimum_jerk import (
    bang_bang_input,
    bang_bang_time,
    bang_bang_trajectory,
    held_input_response,
    minimum_jerk_input,
    minimum_jerk_trajectory,
    minimum_jerk_zoh_plot,
    minimum_jerk_zoh_response,
)
from servokit.feedforward.polynomial import sampled_polynomial


def _brute_force(u: np.ndarray, tau: float, t_end: float, sub: int = 200) -> tuple[float, float]:
    """Position/velocity at t_end by cell-wise integration on a fine grid through every edge."""
    edges = np.arange(u.size + 1) * tau
    t = np.union1d(np.linspace(0.0, t_end, u.size * sub + 1), edges[edges < t_end])
    mid = 0.5 * (t[:-1] + t[1:])
    k = np.floor(mid / tau).astype(int)
    a = np.where(k < u.size, u[np.minimum(k, u.size - 1)], 0.0)
    v = np.concatenate(([0.0], np.cumsum(a * np.diff(t))))
    p = scipy.integrate.cumulative_trapezoid(v, t, initial=0.0)
    return float(p[-1]), float(v[-1])


def test_bang_bang_time_and_profile() -> None:
    assert bang_bang_time(4.0, 1.0) == pytest.approx(4.0)
    tr = bang_bang_trajectory(np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0]), 4.0, 1.0)
    np.testing.assert_allclose(tr.position, [0, 0.5, 2.0, 3.5, 4.0, 4.0])
    np.testing.assert_allclose(tr.velocity, [0, 1, 2, 1, 0, 0])
    np.testing.assert_allclose(bang_bang_input([-1, 0.5, 2.5, 4.5], -4.0, 1.0), [0, -1, 1, 0])


@settings(max_examples=30, deadline=None)
@given(r=st.floats(0.01, 100.0), umax=st.floats(0.1, 100.0))
def test_bang_bang_trajectory_is_integral_of_input(r: float, umax: float) -> None:
    T = bang_bang_time(r, umax)
    t = np.linspace(0, 1.2 * T, 24001)
    a = bang_bang_input(t, r, umax)
    v = scipy.integrate.cumulative_trapezoid(a, t, initial=0)
    p = scipy.integrate.cumulative_trapezoid(v, t, initial=0)
    tr = bang_bang_trajectory(t, r, umax)
    np.testing.assert_allclose(tr.position, p, atol=1e-3 * r)
    assert tr.position[-1] == pytest.approx(r, rel=1e-12)


def test_minimum_jerk_closed_forms() -> None:
    T, r = 0.7, 2.5
    t = np.linspace(0, T, 7001)
    tr = minimum_jerk_trajectory(t, T, r)
    # (2.15) factored form equals the expanded (2.14)
    tn = t / T
    np.testing.assert_allclose(
        tr.acceleration, 60 * r / T**2 * (2 * tn**3 - 3 * tn**2 + tn), atol=1e-9
    )
    # boundary conditions of §2.2.2
    assert tr.position[-1] == pytest.approx(r, rel=1e-14)
    assert abs(tr.velocity[-1]) < 1e-12 and abs(tr.acceleration[-1]) < 1e-9
    # velocity and position are the integrals of the acceleration
    v = scipy.integrate.cumulative_trapezoid(tr.acceleration, t, initial=0)
    np.testing.assert_allclose(tr.velocity, v, atol=1e-6 * r / T)
    p = scipy.integrate.cumulative_trapezoid(tr.velocity, t, initial=0)
    np.testing.assert_allclose(tr.position, p, atol=1e-6 * r)
    assert minimum_jerk_input(np.array([-0.1, 1.1 * T]), T, r).tolist() == [0.0, 0.0]


def test_minimum_jerk_is_jerk_optimal_among_admissible_perturbations() -> None:
    # delta vanishes at 0 and T, is symmetric about T/2 and integrates to zero, so it keeps
    # a(0) = a(T) = 0, v(T) = 0 and p(T) = r: the jerk cost must grow for either sign.
    T, r = 1.0, 1.0
    t = np.linspace(0, T, 20001)
    delta = t**2 * (T - t) ** 2 - t * (T - t) / 5
    assert abs(np.trapezoid(delta, t)) < 1e-9 and abs(np.trapezoid(t * delta, t)) < 1e-9
    base = np.trapezoid(np.gradient(minimum_jerk_input(t, T, r), t) ** 2, t)
    for eps in (1.0, -1.0, 0.1, -0.1):
        u = minimum_jerk_input(t, T, r) + eps * delta
        assert np.trapezoid(np.gradient(u, t) ** 2, t) > base


@pytest.mark.parametrize("tau", [0.01, 0.1])
def test_fig_2_10_final_error_closed_form(tau: float) -> None:
    # T = M tau: the sampled umjc is (2.24)/g, so it stops at r (1-1/M^2)(1-4/M^2) at rest
    res = minimum_jerk_zoh_response(1.0, 1.0, tau)
    M = round(1.0 / tau)
    assert res.final_error == pytest.approx((1 - 1 / M**2) * (1 - 4 / M**2) - 1, rel=1e-12)
    assert abs(res.final_velocity) < 1e-12
    g = 1 / ((1 - 1 / M**2) * (1 - 4 / M**2))
    np.testing.assert_allclose(res.u * g, sampled_polynomial(3, M, tau, 1.0)[:-1], rtol=1e-12)
    # the position stays at the final value after T
    assert np.ptp(res.position[res.t >= 1.0]) < 1e-12


def test_fig_2_10_values() -> None:
    # tau = 100 ms leaves ~5 % error, tau = 10 ms ~0.05 % (Fig. 2.10, text of §2.2.3)
    e100 = minimum_jerk_zoh_response(1.0, 1.0, 0.1).final_error
    e10 = minimum_jerk_zoh_response(1.0, 1.0, 0.01).final_error
    assert e100 == pytest.approx(-0.0496, rel=1e-9)
    assert e10 == pytest.approx(-4.9996e-4, rel=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    T=st.floats(0.2, 3.0),
    tau=st.floats(0.005, 0.2),
    r=st.floats(-5.0, 5.0).filter(lambda x: abs(x) > 1e-3),
)
def test_held_response_matches_brute_force(T: float, tau: float, r: float) -> None:
    res = minimum_jerk_zoh_response(T, r, tau, t=np.array([T]))
    p_bf, v_bf = _brute_force(res.u, tau, T)
    assert res.final_error == pytest.approx(p_bf - r, abs=1e-9 * abs(r))
    assert res.final_velocity == pytest.approx(v_bf, abs=1e-9 * abs(r) / T)
    assert res.position[0] == pytest.approx(p_bf, abs=1e-9 * abs(r))


@settings(max_examples=25, deadline=None)
@given(m=st.integers(1, 40), tau=st.floats(1e-3, 1.0), seed=st.integers(0, 2**31 - 1))
def test_held_input_response_matches_ode_solution(m: int, tau: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    u = rng.normal(size=m)
    t = np.sort(rng.uniform(-tau, (m + 3) * tau, size=50))
    p, v = held_input_response(u, tau, t)
    # independent: sum of ramp-squared differences, y = sum u_k/2 [(t-k tau)+^2 - (t-(k+1)tau)+^2]
    k = np.arange(m)
    r1 = np.maximum(t[:, None] - k * tau, 0.0)
    r2 = np.maximum(t[:, None] - (k + 1) * tau, 0.0)
    p_ref = 0.5 * (u * (r1**2 - r2**2)).sum(axis=1)
    v_ref = (u * (r1 - r2)).sum(axis=1)
    np.testing.assert_allclose(p, p_ref, atol=1e-10 * (m * tau) ** 2 * np.abs(u).max())
    np.testing.assert_allclose(v, v_ref, atol=1e-10 * m * tau * np.abs(u).max())


def test_brute_force_agrees_on_fig_2_10() -> None:
    res = minimum_jerk_zoh_response(1.0, 1.0, 0.1)
    p_bf, v_bf = _brute_force(res.u, 0.1, 1.0, sub=5000)
    assert res.final_error == pytest.approx(p_bf - 1.0, rel=1e-9)
    assert abs(v_bf) < 1e-9


def test_errors() -> None:
    with pytest.raises(ServokitValueError, match="tau"):
        minimum_jerk_zoh_response(1.0, 1.0, 0.0)
    with pytest.raises(ServokitValueError, match="T"):
        minimum_jerk_trajectory(np.zeros(3), -1.0, 1.0)
    with pytest.raises(ServokitValueError, match="u_max"):
        bang_bang_time(1.0, 0.0)
    with pytest.raises(ServokitValueError, match="responses"):
        minimum_jerk_zoh_plot([])


def test_plot(tmp_path: Path) -> None:
    import matplotlib.pyplot as plt

    fig = minimum_jerk_zoh_plot([minimum_jerk_zoh_response(1.0, 1.0, tau) for tau in (0.01, 0.1)])
    out = tmp_path / "fig_2_10.png"
    fig.savefig(out)
    plt.close(fig)
    assert out.stat().st_size > 10_000
