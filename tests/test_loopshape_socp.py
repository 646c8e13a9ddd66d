"""One convex loop-shaping step: constraint generation gives the optimum of every row (issue 24).

The reference is the program with every row of the step's masks (``generate=False``;
its matrices equal the earlier implementation's bit for bit, checked once on the 12
programs of the hdd-loopshape design), solved as before (1e-6 / 1e-7) and at the
generation's 1e-8 / 1e-9. The rows are also re-evaluated from their definitions in the
module docstring (tangent bounds of ``|Y + P X|`` and ``|P X|``, trust region),
independently of the program's assembly. Data: a few of the HDD loops from the
benchmark controller, as the hdd-loopshape case starts.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.feedback import loopshape_socp as socp
from servokit.feedback.loopshape_init import initial_parameters
from servokit.feedback.loopshape_iterate import _masks, _Problem
from servokit.feedback.loopshape_problem import (
    fixed_order_structure,
    model_frfs,
    model_resonances,
    packed_grid,
)
from servokit.feedback.loopshape_socp import StepData, WarmStart, _valleys, solve_step
from servokit.models import HDD_BENCHMARK_TS as DT
from servokit.models import benchmark_controller, hdd_benchmark_variants


@functools.lru_cache(maxsize=4)
def _frfs(n_freq: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid packed around the resonances of the 18 Table 2.3 plants and their FRFs."""
    plants = hdd_benchmark_variants()
    f = packed_grid(DT, model_resonances(plants, DT), n_freq=n_freq)
    return f, model_frfs(plants, DT, f)


def _problem(pick: tuple[int, ...], gain: float, n_freq: int, structure, t_max=None):
    """A few HDD loops (Table 2.3 plants ``pick`` x ``gain``) from the benchmark controller."""
    f, P = _frfs(n_freq)
    pb = _Problem(f, gain * P[list(pick)], DT, structure, 9.0, t_max, 2, None)
    theta0, _ = initial_parameters(pb, benchmark_controller())
    tab = pb.table(theta0)
    pb.set_floor(theta0, tab.min_crossover_hz, 0.9)
    return pb, theta0, tab


def _data(pb, theta, tab, *, phase1: bool, rho: float) -> StepData:
    """The step's data as :func:`loopshape` builds it (phase 1: a 0.5 dB lower ``‖S‖∞`` goal)."""
    s_hard = tab.worst_s_peak_db
    s_lin = 10 ** (s_hard / 20)
    f_t = None if phase1 else 1.03 * tab.min_crossover_hz
    s_mask, c_mask = _masks(pb, theta, f_t, s_lin)
    return StepData(
        basis=pb.basis,
        P=pb.P,
        theta_k=theta,
        w_s=1.0 / s_lin,
        s_mask=s_mask,
        c_mask=c_mask,
        w_obj_s=10 ** (-(s_hard - 0.5) / 20) if phase1 else None,
        w_t=None if pb.t_max is None else 10 ** (-pb.t_max / 20),
        tr_idx=pb.tr_idx,
        rho=rho,
        floor_idx=pb.floor_idx,
        floor_w=pb.floor_w,
    )


def _worst_row(d: StepData, theta: np.ndarray, tau: float) -> float:
    """Most negative row of the step at ``(θ, τ)`` from the definitions (module doc).

    Each row's gap is relative to the larger of its two sides; the trust region
    ``|X - K_k Y| ≤ ρ |K_k|`` is included.
    """
    xk, F = d.basis.polys(d.theta_k)
    x, y = d.basis.polys(theta)
    X, Y, K_k = x / F, y / F, xk / F
    c = 1.0 + d.P * K_k[None, :]
    tangent = np.real(np.conj(c) * (Y + d.P * X)) / np.abs(c)  # <= |Y + P X|
    L_k = d.P * K_k[None, :]
    lx = np.real(np.conj(L_k) * d.P * X) / np.abs(L_k)  # <= |P X|
    ya = np.abs(Y)[None, :]

    def rel(big, small, mask):
        return np.min(((big - small) / np.maximum(np.abs(big), np.abs(small)))[mask])

    worst = [rel(tangent, d.w_s * ya, d.s_mask)]  # |W_S Y| <= |Y + P X|
    if d.w_obj_s is not None:
        worst.append(rel(tangent, d.w_obj_s * ya + tau, d.s_mask))
    if d.w_t is not None:
        worst.append(rel(tangent, d.w_t * np.abs(d.P * X), d.s_mask))
    if d.c_mask is not None:
        worst.append(rel(lx, ya + tau, d.c_mask))  # |P X| >= |Y| + τ below the target
    j = d.floor_idx
    worst.append(rel(lx[:, j], d.floor_w * ya[:, j], np.ones(d.floor_w.shape, dtype=bool)))
    t = d.tr_idx
    trust = d.rho * np.abs(K_k[t])
    worst.append(rel(trust, np.abs(X[t] - K_k[t] * Y[t]), np.ones(t.size, dtype=bool)))
    return float(min(worst))


def _same_optimum(d: StepData, pb, warm: socp.WarmStart | None = None) -> dict:
    """Generated (from ``warm``) and one-program optimum agree; every row holds at both."""
    stats: dict = {}
    gen = solve_step(d, stats=stats, warm=warm)
    assert gen is not None
    assert "one_program" not in stats  # the generated programs were solved
    # the one program of every row as before (1e-6 / 1e-7) and at the generation's 1e-8
    one = solve_step(d, generate=False)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(socp, "TOL_ONE", socp.TOL_GEN)
        tight = solve_step(d, generate=False)
    assert one is not None and tight is not None
    # tau to the programs' precision: the one program at 1e-6 / 1e-7 (as before) ends up to
    # ~1e-3 (relative) outside its trust-region cones, 2e-4 at 1e-8 / 1e-9 ("AlmostSolved")
    assert gen[1] == pytest.approx(one[1], abs=2e-4)
    if not stats["loose"]:  # every generated program reached 1e-8 / 1e-9
        assert gen[1] == pytest.approx(tight[1], abs=1e-5)
    # every row holds about as well as at the one program's optimum (same order, or 1e-5)
    # (programs stopped at the looser tolerance hold their rows as loosely: picks 0, 12,
    # 1, 2 at gain 0.90625, rho 0.0234, phase 1, two loose programs: -5.8e-4 against the
    # one program's -2.6e-4, tau 2.5e-7 from it)
    # Solves taken without Clarabel's iterative refinement (PROGRAM_FEAS) hold their rows
    # about 3x less tightly on this relative measure: frac 1.0, rho 0.25, phase 1 (every
    # row in the first program): -3.1e-5 against the one program's -1.15e-5, while the
    # program's own scaled rows hold to -1.6e-8 (refined: -6.1e-9) and tau agrees to 4e-8
    worst = [_worst_row(d, *sol) for sol in (gen, one, tight)]
    unrefined = stats["refined"] < len(stats["rows"])
    factor = 3.0 if stats["loose"] or unrefined else 2.0
    assert worst[0] > factor * min(worst[1], worst[2], -1e-5)
    # θ itself need not agree: where few rows bind (phase 1, a small trust radius) the
    # optimal set is not a point, and an interior-point method returns its analytic
    # centre, which depends on every row (and on the tolerance)
    return stats


@pytest.mark.parametrize("phase1", [False, True])
def test_generation_equals_the_program_of_every_row(phase1: bool) -> None:
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 600, fixed_order_structure(12))
    d = _data(pb, theta0, tab, phase1=phase1, rho=0.3)
    stats = _same_optimum(d, pb)
    # a fraction of the rows: the last program is much smaller than the one of every row
    # (phase 1: 195 of 377 rows from the unrefined solves, 183 with refinement; the
    # optimal set is not a point, its analytic centre moves with the solves' accuracy)
    n_all = int(d.s_mask.sum()) * (2 if phase1 else 1) + pb.floor_w.size
    n_all += 0 if d.c_mask is None else int(d.c_mask.sum())
    assert stats["rows"][-1] < 0.6 * n_all


def test_generation_with_complementary_sensitivity() -> None:
    # ||T||inf cones are generated with the sensitivity rows of their point
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 600, fixed_order_structure(12), t_max=12.0)
    _same_optimum(d := _data(pb, theta0, tab, phase1=False, rho=0.3), pb)
    assert d.w_t is not None


@pytest.mark.slow
@settings(max_examples=10, deadline=None)
@given(
    pick=st.lists(st.integers(0, 17), min_size=1, max_size=4, unique=True),
    gain=st.floats(0.9, 1.1),
    n_freq=st.sampled_from([300, 600, 900]),
    rho=st.floats(0.02, 0.5),
    phase1=st.booleans(),
)
def test_generation_property(pick, gain: float, n_freq: int, rho: float, phase1: bool) -> None:
    pb, theta0, tab = _problem(tuple(pick), gain, n_freq, fixed_order_structure(12))
    _same_optimum(_data(pb, theta0, tab, phase1=phase1, rho=rho), pb)


def test_valleys_are_local_minima_per_segment() -> None:
    v = np.array([3.0, 1.0, 2.0, 2.0, 0.5, 0.5, 4.0, 1.0, 5.0])
    seg = np.array([0, 0, 0, 0, 0, 0, 0, 1, 1])
    keep = np.ones(v.size, dtype=bool)
    np.testing.assert_array_equal(np.nonzero(_valleys(v, seg, keep))[0], [1, 4, 7])
    keep[4] = False  # a left-out neighbour does not count: 5 becomes a valley, 3 does not
    np.testing.assert_array_equal(np.nonzero(_valleys(v, seg, keep))[0], [1, 5, 7])
    np.testing.assert_array_equal(np.nonzero(_valleys(v, seg, v < 1.5))[0], [1, 4, 7])


def _all_keys(d: StepData) -> np.ndarray:
    """The keys of every row of the step's masks (as :class:`WarmStart` holds them)."""
    xk, F = d.basis.polys(d.theta_k)
    lin, _ = socp._candidates(d, F, xk / F)
    return socp._keys(d, lin)


def test_warm_start_from_the_previous_step() -> None:
    # a second step started from the rows binding at the first: the same optimum as
    # the program of every row, in fewer programs than a cold start
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 600, fixed_order_structure(12))
    warm = WarmStart()
    first = solve_step(_data(pb, theta0, tab, phase1=False, rho=0.3), warm=warm)
    assert first is not None and 0 < warm.keys.size
    assert np.isin(warm.keys, _all_keys(_data(pb, theta0, tab, phase1=False, rho=0.3))).all()
    theta1 = first[0]
    d = _data(pb, theta1, pb.table(theta1), phase1=False, rho=0.3)
    stats = _same_optimum(d, pb, warm)
    cold: dict = {}
    solve_step(d, stats=cold)
    assert len(stats["rows"]) <= len(cold["rows"])


@pytest.mark.slow
@settings(max_examples=8, deadline=None)
@given(
    frac=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**31),
    stray=st.integers(0, 50),
    rho=st.floats(0.02, 0.5),
    phase1=st.booleans(),
)
def test_warm_start_any_rows_same_optimum(frac, seed, stray, rho, phase1) -> None:
    # whatever rows the warm start holds (a random share of the masks' rows, keys of no
    # row), the generation ends at the optimum of every row
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 300, fixed_order_structure(12))
    d = _data(pb, theta0, tab, phase1=phase1, rho=rho)
    keys = _all_keys(d)
    rng = np.random.default_rng(seed)
    pick = keys[rng.random(keys.size) < frac]
    junk = rng.integers(keys.max() + 1, keys.max() + 10**6, stray)
    _same_optimum(d, pb, WarmStart(np.concatenate([pick, junk]).astype(np.int64)))


def test_warm_resolve_of_a_grown_mask() -> None:
    # the step re-solved with a grown mask (as loopshape does where the first optimum
    # broke the true bound at points outside it) from the warm start of its first solve:
    # the optimum of every row of the grown mask, the valleys only of the new rows seeded
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 600, fixed_order_structure(12))
    d = _data(pb, theta0, tab, phase1=False, rho=0.3)
    warm = WarmStart()
    first = solve_step(d, warm=warm)
    assert first is not None and np.array_equal(warm.theta_k, theta0)
    assert np.isin(warm.keys, warm.seen).all() and warm.seen.size == _all_keys(d).size
    grown = StepData(**{**d.__dict__, "s_mask": d.s_mask | (np.abs(pb.P) > 0.5)})
    keys = _all_keys(grown)
    new = ~np.isin(keys, warm.seen)
    assert new.any()
    np.testing.assert_array_equal(socp._unseen(grown, _lin(grown), warm), new)
    # the first program: warm rows, rows violated at θ_k, valleys of new rows only
    lin = _lin(grown)
    xk, F = grown.basis.polys(theta0)
    sel = socp._start(grown, F, lin, warm)[lin.pt]
    v = socp._lin_slack(lin, theta0, 0.0, np.abs(grown.basis.polys(theta0)[1] / F))
    assert (np.isin(keys, warm.keys) | (v <= 0))[sel & ~new].all()
    assert (sel & new).any()
    _same_optimum(grown, pb, warm)
    # a new step (θ_k moved) seeds no valleys; a cold start seeds every row's
    moved = StepData(**{**d.__dict__, "theta_k": first[0]})
    assert not socp._unseen(moved, _lin(moved), warm).any()
    assert socp._unseen(moved, _lin(moved), WarmStart()).all()


def _lin(d: StepData):
    """Every linear row of the step's masks."""
    xk, F = d.basis.polys(d.theta_k)
    return socp._candidates(d, F, xk / F)[0]


def test_unrefined_solves_are_checked() -> None:
    # a program solved without Clarabel's iterative refinement is taken only when its own
    # rows hold to PROGRAM_FEAS at z (slack from the definitions, not from the program);
    # always refusing it (every program solved again with refinement) gives the same step
    pb, theta0, tab = _problem((0, 6, 12), 1.0, 600, fixed_order_structure(12))
    d = _data(pb, theta0, tab, phase1=False, rho=0.3)
    fast: dict = {}
    got = solve_step(d, stats=fast)
    assert got is not None and fast["refined"] < len(fast["rows"])
    assert _worst_row(d, *got) > -10 * socp.PROGRAM_FEAS
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(socp, "PROGRAM_FEAS", -1.0)  # no z is good enough: always refined
        slow: dict = {}
        ref = solve_step(d, stats=slow)
    assert ref is not None and slow["refined"] == len(slow["rows"])
    assert got[1] == pytest.approx(ref[1], abs=1e-6)
    # None: no unrefined attempt at all (one refined solve per program, as before)
    calls: list[bool] = []
    solve = socp._solve
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(socp, "PROGRAM_FEAS", None)
        mp.setattr(
            socp, "_solve", lambda *a, **k: calls.append(k.get("refine", True)) or solve(*a, **k)
        )
        before: dict = {}
        old = solve_step(d, stats=before)
    assert old is not None and all(calls) and len(calls) == len(before["rows"])
    assert old[1] == pytest.approx(ref[1], abs=1e-6)


def test_worst_slack_from_the_definitions() -> None:
    # the program's slack at z: linear rows b - A z and cones t - |q| (two-row example)
    pb, theta0, tab = _problem((0,), 1.0, 300, fixed_order_structure(12))
    d = _data(pb, theta0, tab, phase1=False, rho=0.3)
    xk, F = d.basis.polys(theta0)
    lin, _ = socp._candidates(d, F, xk / F)
    prog = socp._program(d, F, lin.take(np.arange(5)), None, socp._trust(d, F, xk / F))
    rng = np.random.default_rng(1)
    z = rng.standard_normal(prog.nz)
    s = prog.b - prog.A.toarray() @ z
    c = s[prog.n_lin :].reshape(-1, 3)
    want = min(s[: prog.n_lin].min(), (c[:, 0] - np.sqrt(c[:, 1] ** 2 + c[:, 2] ** 2)).min())
    assert socp._worst_slack(prog, z) == pytest.approx(min(want, 0.0), rel=1e-12)


class _Stalled:
    """A Clarabel solver stand-in returning ``x`` with ``status``."""

    def __init__(self, status: str, x: np.ndarray) -> None:
        self.status, self.x = status, x

    def __call__(self, *args, **kwargs):
        return self

    def solve(self):
        return self


@pytest.mark.parametrize(
    ("status", "violation", "rescue", "taken"),
    [
        ("InsufficientProgress", 5e-5, True, True),  # rows off by 5e-5: offered
        ("NumericalError", 5e-5, True, True),
        ("InsufficientProgress", 5e-3, True, False),  # beyond RESCUE_FEAS: not offered
        ("InsufficientProgress", 5e-5, False, False),  # only the last fallback rescues
        ("PrimalInfeasible", 0.0, True, False),  # not a stall
    ],
)
def test_a_stalled_solve_is_offered_only_where_its_rows_hold(
    monkeypatch, status, violation, rescue, taken
):
    import types

    import clarabel
    import scipy.sparse as sparse

    # rows b - A z >= 0 (two linear rows, one cone (t, u, v) with t >= |(u, v)|)
    A = sparse.csc_matrix(np.eye(5))
    b = np.array([1.0, 1.0, 1.0, 0.0, 0.0])
    z = np.array([1.0 + violation, 0.5, 0.0, 0.0, 0.0])  # first row violated by `violation`
    prog = types.SimpleNamespace(n_lin=2, n_soc=1, nz=5, nt=1, A=A, b=b)
    assert socp._worst_slack(prog, z) == pytest.approx(-violation)
    monkeypatch.setattr(clarabel, "DefaultSolver", _Stalled(status, z))
    out = socp._solve(prog, socp.TOL_ONE, ("Solved", "AlmostSolved"), rescue=rescue)
    assert (out is not None) == taken
