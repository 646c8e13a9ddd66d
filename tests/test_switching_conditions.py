"""H2 switching-cost maps and optimal switching conditions (book §3.3.3, (3.65)-(3.81))."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.switching import (
    free_response,
    ivc_jmin,
    optimal_condition,
    switching_cost_map,
    switching_cost_matrix,
)
from tests.test_switching_ivc import random_loop


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**31), st.integers(2, 3), st.integers(1, 2))
def test_cost_matrix_equals_brute_force_sum(seed, n, m):
    loop = random_loop(seed, n, m)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    xp = np.random.default_rng(seed).standard_normal(n)
    for Cz in (loop.Cu, loop.C):
        for gain in (K, None):
            M = switching_cost_matrix(loop, gain, Cz)
            x0 = loop.stack(np.zeros((m, n)) if gain is None else gain) @ xp
            brute = np.sum(free_response(loop.A, Cz, x0, 5000) ** 2)
            assert abs(xp @ M @ xp - brute) <= 1e-8 * brute


def test_map_and_optimum():
    loop = random_loop(9, 3, 2)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    base = np.array([1.0, 0.0, 0.0])
    cmap = switching_cost_map(loop, K, base, (1, 2), np.linspace(-1, 1, 5), np.linspace(-2, 2, 4))
    assert cmap.ju.shape == (4, 5)
    x = base.copy()
    x[1], x[2] = cmap.x_values[3], cmap.y_values[1]
    u = free_response(loop.A, loop.Cu, loop.stack(K) @ x, 5000)
    assert abs(cmap.ju[1, 3] - np.sum(u**2)) <= 1e-8 * np.sum(u**2)
    M = switching_cost_matrix(loop, K, loop.Cu)
    best = optimal_condition(M, base, [1, 2])
    assert best[0] == 1.0
    grad = (M @ best)[[1, 2]]
    assert np.linalg.norm(grad) < 1e-9 * np.linalg.norm(M)
    rng = np.random.default_rng(0)
    for _ in range(5):
        other = best + np.concatenate([[0], 1e-2 * rng.standard_normal(2)])
        assert other @ M @ other >= best @ M @ best
