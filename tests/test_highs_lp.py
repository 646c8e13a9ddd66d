"""``linprog_highs`` (servokit/_highs_lp.py) answers as ``scipy.optimize.linprog``, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

import servokit._highs_lp as highs_lp
from servokit._highs_lp import linprog_highs


def _same(c, A, b, bounds, presolve=True):  # noqa: ANN001, ANN202
    ref = linprog(c, A_ub=A, b_ub=b, bounds=bounds, method="highs", options={"presolve": presolve})
    got = linprog_highs(c, A, b, bounds, presolve=presolve)
    assert got.status == ref.status
    if ref.x is None:
        assert got.x is None
    else:
        np.testing.assert_array_equal(got.x, ref.x)
        assert got.fun == ref.fun
    return got


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(1, 20),
    m=st.integers(1, 200),
    kind=st.sampled_from(["free", "box", "default", "half"]),
    scale=st.sampled_from([1e-9, 1.0, 1e8]),
    shift=st.floats(-2.0, 1.0),
    presolve=st.booleans(),
)
def test_same_answer_as_linprog(seed, n, m, kind, scale, shift, presolve):  # noqa: ANN001
    """Bounded, unbounded (few rows, free variables) and infeasible (``shift < 0``) LPs."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((m, n)) * scale
    A[rng.random((m, n)) < 0.2] = 0.0  # exact zeros, dropped by the sparse matrix
    b = (rng.random(m) + shift) * scale
    c = rng.standard_normal(n)
    bounds = {
        "free": [(None, None)] * n,
        "box": [(-1.0, 2.0)] * n,
        "default": None,
        "half": [(None, 1.0) if i % 2 else (0.0, None) for i in range(n)],
    }[kind]
    _same(c, A, b, bounds, presolve)


def test_statuses_and_the_fallback(monkeypatch):
    """Optimal, infeasible, unbounded; without the private binding, linprog itself."""
    free = [(None, None)]
    assert _same([1.0], [[1.0], [-1.0]], [2.0, 1.0], free).status == 0
    assert _same([1.0], [[1.0], [-1.0]], [-2.0, 1.0], free).status == 2
    assert _same([-1.0], [[-1.0]], [1.0], free, presolve=False).status == 3
    monkeypatch.setattr(highs_lp, "_parts", lambda: None)
    res = linprog_highs([1.0], [[-1.0]], [-0.5], free)
    assert res.status == 0 and res.x[0] == pytest.approx(0.5)
