"""Maximal output admissible sets (book §3.3.3): membership against brute-force simulation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.switching import free_response, ivc_jmin, max_output_admissible_set
from tests.test_switching_ivc import random_loop


def violates(A, Cz, x0, lo, hi, horizon=3000) -> bool:
    z = free_response(A, Cz, x0, horizon)
    return bool(np.any(z < lo) or np.any(z > hi))


def test_scalar_closed_form():
    # x+ = a x, z = x, |z| <= 1: O_inf = [-1, 1], determined at t = 0
    S = max_output_admissible_set([[0.5]], [[1.0]], -1.0, 1.0)
    assert S.t_star == 0
    assert S.ray_limit(np.array([1.0])) == pytest.approx(1.0)
    assert S.ray_limit(np.array([-1.0])) == pytest.approx(1.0)


def test_rotation_closed_form():
    # rotation by 90 deg scaled by 0.9, z = x1, |z| <= 1: the square |x1|, |x2| <= 1/0.9
    # is O_1 = {|x1| <= 1, |0.9 x2| <= 1}; steps >= 2 are implied.
    A = 0.9 * np.array([[0.0, -1.0], [1.0, 0.0]])
    S = max_output_admissible_set(A, [[1.0, 0.0]], -1.0, 1.0)
    assert S.t_star == 1
    assert S.ray_limit(np.array([0.0, 1.0])) == pytest.approx(1 / 0.9)
    assert len(S.h) == 4


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 3), st.integers(1, 2))
def test_membership_matches_simulation(seed, n, m):
    loop = random_loop(seed, n, m)
    S = max_output_admissible_set(loop.A, loop.Cu, -0.5, 1.0)
    rng = np.random.default_rng(seed)
    for _ in range(6):
        d = rng.standard_normal(n + m)
        s = S.ray_limit(d)
        assert np.isfinite(s)
        assert not violates(loop.A, loop.Cu, 0.999 * s * d, -0.5, 1.0)
        assert violates(loop.A, loop.Cu, 1.001 * s * d, -0.5, 1.0)


def test_ivc_set_in_plant_coordinates_matches_simulation():
    # (3.92): the set of xp[0] admissible with xc[0] = K xp[0]; containment of the
    # zero-reset set is not a theorem (it holds on the book's HDD loop, tested there)
    loop = random_loop(2, 2, 2)
    S = max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    ivc = S.restrict(loop.stack(K))
    assert ivc.polygon().shape[1] == 2
    rng = np.random.default_rng(0)
    for _ in range(10):
        d = rng.standard_normal(2)
        s = ivc.ray_limit(d)
        x0 = loop.stack(K) @ (0.999 * s * d)
        assert not violates(loop.A, loop.Cu, x0, -1.0, 1.0)
        assert violates(loop.A, loop.Cu, loop.stack(K) @ (1.001 * s * d), -1.0, 1.0)


def test_bad_input():
    with pytest.raises(ServokitValueError, match="zmin < 0 < zmax"):
        max_output_admissible_set([[0.5]], [[1.0]], 0.1, 1.0)
    with pytest.raises(ServokitValueError, match="Schur"):
        max_output_admissible_set([[1.5]], [[1.0]], -1, 1)
    # an unobservable direction is left free (the set is a cylinder)
    S = max_output_admissible_set(np.diag([0.5, 0.9]), [[1.0, 0.0]], -1, 1)
    assert S.ray_limit(np.array([0.0, 1.0])) == np.inf
    # a slow, lightly damped rotation needs many steps: refused within t_max = 3
    c, s_ = np.cos(0.05), np.sin(0.05)
    A = 0.999 * np.array([[c, -s_], [s_, c]])
    with pytest.raises(ServokitValueError, match="t_max"):
        max_output_admissible_set(A, [[1.0, 0.0]], -1, 1, t_max=3)


def test_gauge_is_homogeneous_in_the_bound():
    loop = random_loop(4, 2, 1)
    S1 = max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)
    S3 = max_output_admissible_set(loop.A, loop.Cu, -3.0, 3.0)
    x = np.random.default_rng(1).standard_normal((3, 5))
    np.testing.assert_allclose(S1.gauge(x), 3.0 * S3.gauge(x), rtol=1e-9)
    np.testing.assert_array_equal(S1.contains(x), S1.gauge(x) <= 1 + 1e-9)
