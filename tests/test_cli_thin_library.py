"""Library homes of the compute steps the thin commands used to do themselves (issue 19):
each against an independent computation (a direct call, a brute-force sum, a closed form)."""

from __future__ import annotations

import numpy as np
import pytest

from servokit.errors import ServokitValueError
from tests.test_switching_ivc import random_loop


def test_switching_cost_grid_is_the_quadratic_form_on_the_grid():
    from servokit.switching import ivc_jmin, switching_cost_grid, switching_cost_matrix

    loop = random_loop(3, 3, 2)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    g = switching_cost_grid(loop, K, 0.7, (-2.0, 3.0), (-1.0, 1.0), 5)
    Mu, My = switching_cost_matrix(loop, K, loop.Cu), switching_cost_matrix(loop, K, loop.C)
    for i, a in enumerate(g.acceleration):
        for j, v in enumerate(g.velocity):
            x = np.array([0.7, v, a])
            assert g.cost.ju[i, j] == pytest.approx(x @ Mu @ x, rel=1e-12)
            assert g.cost.jy[i, j] == pytest.approx(x @ My @ x, rel=1e-12)
    # the optimum keeps the position and beats every grid point
    assert g.optimal_state[0] == 0.7 and g.free == [1, 2]
    assert g.optimal_state @ Mu @ g.optimal_state <= g.cost.ju.min() * (1 + 1e-12)


def test_switching_cost_grid_refusals_name_parameters():
    from servokit.switching import switching_cost_grid

    loop = random_loop(4, 2, 1)
    with pytest.raises(ServokitValueError, match="acc_range"):
        switching_cost_grid(loop, None, 1.0, (0.0, 1.0), (0.0, 1.0), 3)
    with pytest.raises(ServokitValueError, match="position"):
        switching_cost_grid(loop, None, 1e300, (0.0, 1.0), (0.0, 0.0), 3)


def test_admissible_conditions_gauge_matches_membership():
    from servokit.switching import admissible_conditions

    loop = random_loop(5, 3, 2)
    pts = [(0.0, 0.0), (0.01, -0.02), (5.0, 5.0), (-40.0, 20.0)]
    res = admissible_conditions(loop, 0.5, pts, t_max=200)
    assert res.n_inequalities == len(res.ivc.h) or res.n_inequalities >= 1
    for x, row in zip(pts, res.conditions, strict=True):
        # admissible <=> the slice contains the point <=> the needed bound is <= u_max
        assert row["admissible_ivc"] == bool(res.ivc.contains(np.array(x)))
        assert row["admissible_zero_reset"] == bool(res.zero_reset.contains(np.array(x)))
        assert row["admissible_ivc"] == (row["needed_u_ivc"] <= 0.5 * (1 + 1e-9))
    # the needed bound scales linearly with the state (the sets are symmetric polytopes)
    twice = admissible_conditions(loop, 0.5, [(0.02, -0.04)], t_max=200).conditions[0]
    assert twice["needed_u_ivc"] == pytest.approx(2 * res.conditions[1]["needed_u_ivc"])


def test_spectrum_in_chunks_equals_one_call():
    from servokit.sampled.srs import half_sine, shock_response_spectrum, spectrum_in_chunks

    f = np.linspace(100.0, 20e3, 37)
    ticks = []
    whole = shock_response_spectrum(half_sine(5e-4), None, f, 0.02, duration=5e-4)
    parts = spectrum_in_chunks(
        half_sine(5e-4), None, f, 0.02, duration=5e-4, chunk=10, progress=lambda: ticks.append(1)
    )
    assert len(ticks) == 4
    np.testing.assert_allclose(parts.freq_hz, f)
    # each chunk integrates on panels of its own fastest oscillator: equal to rounding
    np.testing.assert_allclose(parts.magnitude, whole.magnitude, rtol=1e-9)


def test_sensitivity_in_chunks_equals_one_call():
    from servokit.models import get_discrete_controller, get_plant
    from servokit.sampled import sampled_data_sensitivity
    from servokit.sampled.sensitivity import sensitivity_in_chunks

    p, c = get_plant("hdd-sampled-data"), get_discrete_controller("eq-4.69")
    f = np.linspace(10.0, 3000.0, 25)
    whole = sampled_data_sensitivity(p, c, float(c.dt), f)
    parts = sensitivity_in_chunks(p, c, float(c.dt), f, chunk=7)
    np.testing.assert_allclose(parts.Ssd, whole.Ssd, rtol=1e-10)
    np.testing.assert_allclose(parts.Sd, whole.Sd, rtol=1e-10)
    assert parts.alias_terms >= 1 and parts.freq_hz.size == 25


def test_variance_against_bound_is_the_three_library_results():
    import control

    from servokit.limits import (
        output_variance,
        rolloff_bandwidth,
        variance_against_bound,
        variance_lower_bound,
    )

    loop, dist = control.tf([40000.0], [1, 300, 0]), control.tf([1.0], [0.01, 1])
    res = variance_against_bound(loop, dist, delta=0.5, k=1)
    omega = rolloff_bandwidth(loop, delta=0.5, k=1)
    assert res.bandwidth_hz == omega
    assert res.variance == pytest.approx(output_variance(loop, dist), rel=1e-12)
    assert res.bound.bound == pytest.approx(variance_lower_bound(dist, omega).bound, rel=1e-12)
    # closed form: S D with L = 40000/(s(s+300)), D = 1/(0.01 s + 1): var >= bound
    assert res.bound.bound <= res.variance


def test_variance_against_bound_refuses_an_unstable_loop():
    import control

    from servokit.limits import variance_against_bound

    # L = -2/(s + 1): closed-loop pole at +1, the integral (6.13) diverges
    with pytest.raises(ServokitValueError, match="disturbance and loop"):
        variance_against_bound(control.tf([-2.0], [1, 1]), control.tf([1.0], [1, 1]))


def test_excitation_frequencies():
    from servokit.sampled.identification import excitation_frequencies

    np.testing.assert_allclose(excitation_frequencies(50, 200, 50), [50, 100, 150, 200])
    # an end within rounding of the grid is kept, one beyond it is not
    assert excitation_frequencies(0.1, 0.3, 0.1).size == 3
    assert excitation_frequencies(10, 24.9, 5).tolist() == [10, 15, 20]
    with pytest.raises(ServokitValueError, match="fmax_hz"):
        excitation_frequencies(10, 5, 1)


def test_discretize_filter_refuses_a_degenerate_tustin_filter():
    import control

    from servokit.feedback import discretize_filter, notch

    n = notch(4449.0, 0.09)
    with pytest.raises(ServokitValueError, match="^dt .*numerator equals its denominator"):
        discretize_filter(n, 1e-300, 4449.0)
    with pytest.raises(ServokitValueError, match="^freq_hz .*Nyquist"):
        discretize_filter(n, 2e-4, 4449.0)
    # a fine but usable period: exact at the prewarp frequency (Tustin prewarped)
    dt = 1e-7
    fd = discretize_filter(n, dt, 4449.0)
    w = 2 * np.pi * 4449.0
    exact = control.evalfr(n, 1j * w)
    assert abs(control.evalfr(fd, np.exp(1j * w * dt)) - exact) < 1e-6 * max(abs(exact), 1e-3)


def test_state_size_estimate_counts_modes_delay_and_controller():
    from servokit.cli._options import check_state_size, controller_states, discrete_states
    from servokit.models import get_discrete_controller, get_plant

    p = get_plant("hdd-sampled-data")
    c = get_discrete_controller("eq-4.69")
    dt = float(c.dt)
    n = discrete_states(p, dt, controller_states(c))
    built = p.discretize(dt).nstates + controller_states(c)
    assert built <= n <= built + 1  # the estimate never undercounts the model built
    check_state_size(n, what="--plant x", max_memory_mb=1.0)
    with pytest.raises(ServokitValueError, match="--max-memory-mb"):
        check_state_size(40_000, what="--plant big.toml", max_memory_mb=2000.0)
    with pytest.raises(ServokitValueError, match="evaluations"):
        check_state_size(5_000, what="--plant big.toml", max_memory_mb=1e6)
