"""Row generation for the constrained FSC QP (feedforward/_qp_rows.py): the same optimum.

The generated-rows path must give what the full solve gives: a candidate meeting every
row, polished to the same optimum (compared with the full PIQP solve polished alike, and
with an independent SLSQP-free check of the KKT conditions through the polish), and it
must fall back to the full solve when a subproblem fails.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit.feedforward._qp_rows as qp_rows
from servokit.feedforward._qp_rows import MIN_ROWS, solve_by_rows
from servokit.feedforward._qp_solve import _polish, _run_solver, _stationary_point
from servokit.feedforward._qp_solve import max_violation as _max_violation
from servokit.feedforward.constraints import (
    InputLimit,
    VelocityLimit,
    constraint_rows,
    solve_fsc_qp,
)
from servokit.feedforward.ffsc import augmented_design_model
from servokit.feedforward.fsc import final_state_control, lifted_model
from servokit.models import ModalPlant, Mode


def _problem(seed: int, n: int, p: int, cond: float, scale: float):  # noqa: ANN202
    """A positive definite cost with condition ``cond`` and ``p`` normalised rows, feasible
    at 0, most of them far from the unconstrained optimum (as in the FSC designs)."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    P = scale * (Q * np.geomspace(1.0, 1.0 / cond, n)) @ Q.T
    P = 0.5 * (P + P.T)
    w0 = 3.0 * rng.standard_normal(n)
    q = -P @ w0
    G = rng.standard_normal((p, n))
    G /= np.linalg.norm(G, axis=1)[:, None]
    h = rng.uniform(0.5, 1.0, p) * np.abs(G @ w0) + rng.uniform(0.0, 0.2, p)
    return P, q, G, h


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(3, 30),
    extra=st.integers(0, 400),
    cond=st.sampled_from([1.0, 1e3, 1e6]),
    scale=st.sampled_from([1e-12, 1.0, 1e9]),
)
def test_rows_give_the_full_optimum(seed, n, extra, cond, scale):  # noqa: ANN001
    P, q, G, h = _problem(seed, n, MIN_ROWS + extra, cond, scale)
    P, q = P / np.max(np.diag(P)), q / np.max(np.diag(P))  # solve_fsc_qp's cost scaling
    run = functools.partial(_run_solver, "piqp")
    start = _stationary_point(P, q)
    cand = solve_by_rows(run, P, q, G, h, start)
    full = run(P, q, G, h)
    assert cand is not None and full is not None
    assert _max_violation(G, h, cand) <= 1e-6  # every row, not only the generated ones
    w_rows, w_full = _polish(P, q, G, h, cand), _polish(P, q, G, h, full)
    cost = lambda w: float(w @ (P @ w) + 2 * q @ w)  # noqa: E731
    assert cost(w_rows) == pytest.approx(cost(w_full), rel=1e-7, abs=1e-12)
    assert np.allclose(w_rows, w_full, rtol=1e-5, atol=1e-6 * np.max(np.abs(w_full)))


def test_falls_back_to_the_full_solve():
    P, q, G, h = _problem(3, 8, MIN_ROWS + 10, 1e3, 1.0)
    calls = []

    def run(P, q, G, h):  # noqa: ANN001, ANN202 - a backend failing on every subproblem
        calls.append(G.shape[0])
        return None if G.shape[0] < MIN_ROWS + 10 else _run_solver("piqp", P, q, G, h)

    w = solve_by_rows(run, P, q, G, h, _stationary_point(P, q))
    assert calls[-1] == MIN_ROWS + 10 and len(calls) == 2 and w is not None
    # few rows: one full solve, no subproblem
    calls.clear()
    plain = functools.partial(_run_solver, "piqp")
    w_few = solve_by_rows(lambda *a: calls.append(a[2].shape[0]) or plain(*a), P, q, G[:100],
                          h[:100], np.zeros(8))  # fmt: skip
    assert calls == [100] and w_few is not None


def _rigid_qp(N: int, frac: float, vfrac: float):  # noqa: ANN202
    """Minimum-energy rigid-body FSC seek (2.64) with input and velocity limits: 4 N rows."""
    dt = 0.1
    A, B, n = augmented_design_model(ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="r"), dt)
    lm = lifted_model(
        A, B, N, np.zeros(n + 1), dt=dt, position=[1, 0, 0], velocity=[0, 1, 0],
        input_row=[0, 0, 1],
    )  # fmt: skip
    xN = np.array([1.0, 0.0, 0.0])
    U0 = final_state_control(A, B, N, np.zeros(3), xN)
    u_lim = frac * float(np.abs(lm.plant_input(U0)).max())
    v_lim = vfrac * float(np.abs(VelocityLimit(1.0).signal(lm)[1] @ U0).max())
    G, h, groups = constraint_rows([InputLimit(u_lim), VelocityLimit(v_lim)], lm)
    return lm.x_gain[N], xN - lm.x_offset[N], G, h, groups


@settings(max_examples=8, deadline=None)
@given(N=st.integers(MIN_ROWS // 4 + 1, 160), frac=st.floats(0.75, 0.95))
def test_fsc_design_is_the_same_as_the_full_solve(N, frac):  # noqa: ANN001
    Sigma, X, G, h, groups = _rigid_qp(N, frac, 0.97)
    assert G.shape[0] >= MIN_ROWS
    with_rows = solve_fsc_qp(np.eye(N), np.zeros(N), Sigma, X, G, h, groups=groups)
    old = qp_rows.MIN_ROWS
    try:
        qp_rows.MIN_ROWS = 10**9  # the full solve only
        full = solve_fsc_qp(np.eye(N), np.zeros(N), Sigma, X, G, h, groups=groups)
    finally:
        qp_rows.MIN_ROWS = old
    np.testing.assert_allclose(with_rows, full, rtol=0, atol=1e-9 * np.abs(full).max())
