"""Banded (sparse) constrained-FSC QP against the dense path it replaces for large N."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from servokit.feedforward import (
    InfeasibleConstraintsError,
    InputLimit,
    MotorModel,
    VelocityLimit,
    VoltageLimit,
    fsc_input,
    sparse_qp,
)
from servokit.models import ModalPlant, Mode


def _both(monkeypatch, plant, dt, N, **kw):
    """``fsc_input`` through the banded QP and through the dense QP."""
    calls = []
    real = sparse_qp.solve_banded_fsc_qp

    def spy(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(sparse_qp, "solve_banded_fsc_qp", spy)
    fast = fsc_input(plant, dt, N, 1.0, **kw)
    assert calls, "the banded QP was not used"
    monkeypatch.setattr(sparse_qp, "SPARSE_MIN_STEPS", 10**9)
    dense = fsc_input(plant, dt, N, 1.0, **kw)
    monkeypatch.undo()
    return fast, dense


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@settings(max_examples=3, deadline=None)
@given(N=st.integers(200, 240), umax=st.floats(0.8, 1.5), vmax=st.floats(0.5, 0.8))
def test_banded_equals_dense_rigid_body(N, umax, vmax):
    with pytest.MonkeyPatch.context() as mp:
        plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
        cons = [InputLimit(umax), VelocityLimit(vmax)]
        fast, dense = _both(mp, plant, 3.0 / N, N, constraints=cons)
    # "same optimum": the optimal cost (the sum of squared jerk the FSC minimises) agrees
    # to the solvers' tolerance; the minimiser itself is fixed only to about the square
    # root of it along weakly curved directions (seen: N=126, umax=1, vmax=0.5 gives cost
    # 3e-11 apart, jerk 8e-6 apart, u 1e-6 apart)
    cost_fast, cost_dense = np.sum(fast.jerk**2), np.sum(dense.jerk**2)
    assert abs(cost_fast - cost_dense) < 1e-9 * cost_dense
    assert _rel(fast.u, dense.u) < 1e-5
    assert np.abs(fast.u).max() <= umax * (1 + 1e-6)


def test_banded_equals_dense_with_modes_bands_and_voltage(monkeypatch):
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0), Mode(3.0, 0.05, -0.2)), name="flex")
    N, dt = 200, 2.5 / 200
    motor = MotorModel(resistance=1.0, inductance=0.02, back_emf=0.5)
    cons = [InputLimit(1.0), VoltageLimit(1.2, motor=motor)]
    fast, dense = _both(
        monkeypatch, plant, dt, N, constraints=cons, band_weights=[(2.0, 4.0, 50.0, 6)]
    )
    assert _rel(fast.jerk, dense.jerk) < 1e-6


def test_infeasible_falls_back_to_the_dense_diagnosis():
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
    N = 120
    with pytest.raises(InfeasibleConstraintsError, match=r"input \|u\| <= 0.25"):
        fsc_input(plant, 3.0 / N, N, 1.0, constraints=[VelocityLimit(10.0), InputLimit(0.25)])


def test_limit_violation_and_final_state_of_the_banded_solution():
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
    N = 200
    ff = fsc_input(plant, 3.0 / N, N, 1.0, constraints=[InputLimit(0.6), VelocityLimit(0.5)])
    # independent check: integrate the held input twice
    v = np.concatenate([[0.0], np.cumsum(ff.u) * ff.dt])
    y = np.concatenate([[0.0], np.cumsum(v[:-1] * ff.dt + 0.5 * ff.u * ff.dt**2)])
    assert y[-1] == pytest.approx(1.0, rel=1e-9) and abs(v[-1]) < 1e-9
    assert np.abs(v).max() <= 0.5 * (1 + 1e-6)


def test_banded_solution_itself_matches_dense_with_binding_voltage(monkeypatch):
    """The banded QP's own answer (not a fallback) equals the dense optimum, with the
    voltage limit (input, rate and back-EMF terms) binding."""
    from servokit.feedforward import ffsc

    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0), Mode(3.0, 0.05, -0.2)), name="flex")
    N, dt = 200, 2.5 / 200
    motor = MotorModel(resistance=1.0, inductance=0.02, back_emf=0.5)
    cons = [InputLimit(1.0), VoltageLimit(1.0, motor=motor)]
    monkeypatch.setattr(sparse_qp, "SPARSE_MIN_STEPS", 10**9)
    dense = fsc_input(plant, dt, N, 1.0, constraints=cons)
    A, B, n = ffsc.augmented_design_model(plant, dt)
    pos, vel, row = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n + 1)
    pos[0:n:2], vel[1:n:2], row[n] = 1.0, 1.0, 1.0
    limits = sparse_qp.limits_of(cons, pos, vel)
    x0, xN = np.zeros(n + 1), ffsc._final_state(plant, 1.0, n)
    U = sparse_qp.solve_banded_fsc_qp(
        A, B, N, x0, xN, dt=dt, input_row=row, limits=limits, rho=1 / N
    )
    assert U is not None and _rel(U, dense.jerk) < 1e-6
    viol = sparse_qp.limit_violation(A, B, x0, U, dt=dt, input_row=row, limits=limits[1:])
    assert -1e-6 < viol <= 1e-6  # the voltage limit is reached, not exceeded


def _hdd_banded_problem(N):
    """HDD benchmark plant, Table 2.4 bands, |u| <= 0.8 x the unconstrained peak (issue 24)."""
    from servokit.cases.hdd_seek import table_2_4_weights
    from servokit.feedforward import ffsc
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark

    plant, dt, bands = hdd_benchmark(), HDD_BENCHMARK_TS, table_2_4_weights(1)
    free = fsc_input(plant, dt, N, 1.0, band_weights=bands)
    lim = 0.8 * float(np.abs(free.u).max())
    A, B, n = ffsc.augmented_design_model(plant, dt)
    row = np.zeros(n + 1)
    row[n] = 1.0
    Wb = ffsc._band_rows(dt, N, bands)
    return plant, dt, bands, lim, (A, B, n, row, Wb, ffsc._final_state(plant, 1.0, n)), free


def test_hdd_bands_banded_qp_equals_dense_optimum():
    """The scaled banded QP (forced, with the compressed band rows) and the dense QP give
    the same optimum on the problem where both used to be wrong (objective ~1e-13 in SI
    units: absolute solver tolerances stopped them early)."""
    N = 300
    plant, dt, bands, lim, (A, B, n, row, Wb, xN), free = _hdd_banded_problem(N)
    dense = fsc_input(plant, dt, N, 1.0, band_weights=bands, constraints=[InputLimit(lim)],
                      qp="dense")  # fmt: skip
    x0 = np.zeros(n + 1)
    U = sparse_qp.solve_banded_fsc_qp(
        A, B, N, x0, xN, dt=dt, input_row=row, limits=[(None, 1.0, 0.0, lim)], rho=1 / N,
        band_rows=Wb,
    )  # fmt: skip
    assert U is not None
    assert _rel(U, dense.jerk) < 1e-6

    def cost(v):
        return v @ v / N + np.sum((Wb @ v) ** 2)

    assert abs(cost(U) - cost(dense.jerk)) < 1e-9 * cost(dense.jerk)
    # the limit binds: the constrained optimum costs more than the free one, |u| reaches it
    assert cost(dense.jerk) > cost(free.jerk) * (1 + 1e-3)
    assert np.abs(dense.u).max() == pytest.approx(lim, rel=1e-9)


def test_default_path_picks_dense_for_dominant_band_rows():
    assert not sparse_qp.prefers_banded(3000, 15, 480)  # HDD Table 2.4: 480 band rows
    assert sparse_qp.prefers_banded(3000, 15, 0)
    assert sparse_qp.prefers_banded(300, 5, 12)
    assert not sparse_qp.prefers_banded(sparse_qp.SPARSE_MIN_STEPS - 1, 2, 0)


@settings(max_examples=10, deadline=None)
@given(N=st.integers(20, 400), m=st.integers(1, 60), seed=st.integers(0, 2**31 - 1),
       log_rho=st.floats(-6, 2))  # fmt: skip
def test_compressed_band_rows_keep_the_cost(N, m, seed, log_rho):
    rng = np.random.default_rng(seed)
    # low-rank rows of very different sizes, as band rows are
    Wb = (rng.standard_normal((m, 3)) * 10.0 ** rng.uniform(-8, 3, 3)) @ rng.standard_normal((3, N))
    rho = 10.0**log_rho
    R = sparse_qp.compress_band_rows(Wb, rho)
    U = rng.standard_normal(N)
    assert R.shape[0] <= min(3, m, N)
    assert abs(np.sum((R @ U) ** 2) - np.sum((Wb @ U) ** 2)) <= 1e-10 * (
        rho * U @ U + np.sum((Wb @ U) ** 2)
    )


@settings(max_examples=4, deadline=None)
@given(N=st.integers(200, 230), q=st.floats(1.0, 1e3), umax=st.floats(0.9, 1.3))
# an inactive limit: the interior point stopped 1.2e-6 (jerk) from the optimum before the
# active-set polish; the dense path and the free closed form agree to 2e-11
@example(N=228, q=689.5, umax=1.146159295094329)
def test_banded_equals_dense_with_random_bands(N, q, umax):
    """Default (banded: few band rows) vs dense with a flexible mode and a band on it."""
    with pytest.MonkeyPatch.context() as mp:
        plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0), Mode(3.0, 0.02, -0.3)), name="flex")
        fast, dense = _both(
            mp, plant, 2.5 / N, N, constraints=[InputLimit(umax)],
            band_weights=[(2.7, 3.3, q, 5)],
        )  # fmt: skip
    assert _rel(fast.jerk, dense.jerk) < 1e-6


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_polish_reaches_the_optimum_found_by_enumerating_active_sets(seed):
    """Clarabel's answer at its default tolerance, polished, is the exact optimum: the one
    active set whose KKT solution is feasible with signed multipliers (enumerated)."""
    import itertools

    import scipy.sparse as sp
    from qpsolvers import Problem, solve_problem

    rng = np.random.default_rng(seed)
    n, p, m = 6, 2, 4
    L = rng.standard_normal((n, n))
    P = L @ L.T + 0.1 * np.eye(n)
    E, b = rng.standard_normal((p, n)), rng.standard_normal(p)
    # feasible by construction: a point of E x = b strictly inside every inequality
    null = np.linalg.svd(E)[2][p:].T
    x_in = np.linalg.lstsq(E, b, rcond=None)[0] + null @ rng.standard_normal(n - p)
    G = rng.standard_normal((m, n))
    h = G @ x_in + rng.uniform(0.1, 1.0, m)
    best = None
    for k in range(m + 1):
        for act in itertools.combinations(range(m), k):
            A = np.vstack([E, G[list(act)]])
            kkt = np.block([[P, A.T], [A, np.zeros((A.shape[0], A.shape[0]))]])
            try:
                sol = np.linalg.solve(kkt, np.r_[np.zeros(n), b, h[list(act)]])
            except np.linalg.LinAlgError:
                continue
            x, y = sol[:n], sol[n + p :]
            if np.all(G @ x <= h + 1e-9) and np.all(y >= -1e-9):
                best = x
    assert best is not None  # a strictly convex feasible problem has one optimum
    Ps, Gs, Es = sp.csc_matrix(P), sp.csc_matrix(G), sp.csc_matrix(E)
    v = solve_problem(Problem(Ps, np.zeros(n), Gs, h, Es, b), solver="clarabel").x
    out = sparse_qp.polish_active_set(Ps, Gs, h, Es, b, v)
    np.testing.assert_allclose(out, best, rtol=1e-9, atol=1e-11)
