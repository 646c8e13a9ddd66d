"""The kept HiGHS feasibility model of the robust seek search against fresh ``linprog``.

The settle search answers its feasibility questions from one HiGHS model per step
number, kept between questions (rows generated for earlier settle indices stay, warm
start; :mod:`servokit.seek._highs_feasibility`).  Every answer must be the decision of a
fresh ``linprog`` of the same question, and the designs must be the same arrays.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servokit.models import ModalPlant, Mode
from servokit.seek import _highs_feasibility as hf
from servokit.seek import robust as R
from servokit.seek import robust_minimum_time
from servokit.seek._matrices import PulseBank

DT, TARGET, BAND, U_MAX = 0.01, 1.0, 0.05, 4.0

pytestmark = pytest.mark.skipif(not hf.available(), reason="no SciPy HiGHS binding")


def _plants(gains, freqs, dampings, residues, scale=1.0) -> list[ModalPlant]:
    return [
        ModalPlant(gain=g * scale, modes=(Mode(0.0, 0.0, 1.0), Mode(f, z, r)), delay=0.0)
        for g, f, z, r in zip(gains, freqs, dampings, residues, strict=True)
    ]


def _lp(plants, N, scale=1.0, horizon=0.2) -> R._SeekLP:
    """The LP of ``plants`` (output units scaled by ``scale``: target and band too)."""
    bank = PulseBank.build(plants, DT, 10, N * DT + horizon + 2 * DT)
    return R._SeekLP(bank, N, TARGET * scale, BAND * scale, U_MAX, horizon, None)


def _fresh(lp: R._SeekLP, s: int) -> np.ndarray | None:
    return lp._solve_fresh(s, "feasible")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    gains=st.tuples(st.floats(60.0, 140.0), st.floats(60.0, 140.0)),
    freqs=st.tuples(st.floats(12.0, 30.0), st.floats(12.0, 30.0)),
    dampings=st.tuples(st.sampled_from([1e-6, 1e-3, 0.05, 0.3]), st.floats(0.01, 0.3)),
    residues=st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),
    N=st.integers(4, 14),
    scale=st.sampled_from([1e-6, 1.0, 1e6]),
    order=st.permutations(range(8)),
)
def test_kept_answers_equal_fresh_linprog(gains, freqs, dampings, residues, N, scale, order):
    """Questions in any order (bisection, gallop, repeats): the fresh LP's decisions.

    ``scale`` multiplies the plant gains and the target and band: the same problem in
    other output units (the LP rows are in band units, so it stays well scaled).
    """
    plants = _plants(gains, freqs, dampings, residues, scale)
    kept = _lp(plants, N, scale)
    fresh = _lp(plants, N, scale)
    points = np.linspace(0, kept.J, 8).astype(int)
    for s in [*points[list(order)], *points[list(order[:3])]]:
        x = kept.solve(int(s))
        y = _fresh(fresh, int(s))
        assert (x is None) == (y is None), s
        if x is not None:  # the kept answer meets every fine-grid row and the tail rows
            assert np.all(np.abs(kept.outputs(x, int(s))) <= 1.0 + 1e-6)
            assert np.all(kept.tail_A @ x <= kept.tail_b + 1e-6)
            assert abs(x[: kept.N].sum()) <= 1e-6 and np.all(np.abs(x[: kept.N]) <= 1 + 1e-9)


@pytest.mark.parametrize("scale", [1e-6, 1.0, 1e6])
def test_a_dual_simplex_solve_error_is_decided_by_the_interior_point(scale):
    """Hypothesis found a 16-row LP (coefficients 8e-11 to 28) on which HiGHS's dual
    simplex stops with "Solve error" at every scale: the fresh path asks the interior point
    method instead of raising, and agrees with the kept model (infeasible)."""
    plants = _plants((97.0, 109.0), (28.75, 21.0), (0.3, 0.125), (0.5, 0.5), scale)
    kept, fresh = _lp(plants, 13, scale), _lp(plants, 13, scale)
    assert _fresh(fresh, fresh.J) is None
    assert kept.solve(kept.J) is None


def test_rigid_body_only():
    """No flexible mode (no envelope columns): the same decisions as linprog."""
    plants = [ModalPlant(gain=g, modes=(Mode(0.0, 0.0, 1.0),), delay=0.0) for g in (100, 90)]
    kept, fresh = _lp(plants, 6), _lp(plants, 6)
    for s in (kept.J, 0, kept.J // 2, 30, 60, 61):
        assert (kept.solve(s) is None) == (_fresh(fresh, s) is None)


def _design(plants, **kw):
    return robust_minimum_time(plants, DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.2, **kw)


@pytest.mark.parametrize("how", ["no binding", "every re-solve stalls"])
def test_design_equal_to_linprog_path(monkeypatch, how):
    """The design (input, scan, guarantee) is the same arrays without the kept model."""
    plants = _plants((100.0, 95.0), (20.0, 24.0), (0.05, 0.08), (-0.3, -0.4))
    d_kept = _design(plants)
    if how == "no binding":
        monkeypatch.setattr(hf, "_core", lambda: None)
        hf.available.cache_clear()  # (its answer is kept per process)
    else:  # past the pivot limit every question goes to a fresh linprog
        monkeypatch.setattr(hf, "ITERATION_LIMIT", 1)
    try:
        d_old = _design(plants)
    finally:
        hf.available.cache_clear()
    np.testing.assert_array_equal(d_kept.u, d_old.u)
    np.testing.assert_array_equal(d_kept.seek_times, d_old.seek_times)
    assert d_kept.guaranteed_seek_time == d_old.guaranteed_seek_time
    assert d_kept.binding_plant == d_old.binding_plant


def test_stalled_resolve_falls_back(monkeypatch):
    """A re-solve past the pivot limit raises, and the search answers it fresh."""
    plants = _plants((100.0, 95.0), (20.0, 24.0), (0.05, 0.08), (-0.3, -0.4))
    lp = _lp(plants, 8)
    monkeypatch.setattr(hf, "ITERATION_LIMIT", 1)
    assert (lp.solve(lp.J) is None) == (_fresh(_lp(plants, 8), lp.J) is None)
    assert lp._kept is None  # dropped: rebuilt for the next question


def test_tail_maps_of_one_bank_equal_fresh_banks():
    """The modal ZOH cached on the bank: every N's tail rows as from a new bank."""
    plants = _plants((100.0, 95.0), (20.0, 24.0), (1e-6, 0.08), (-0.3, 0.4))
    bank = PulseBank.build(plants, DT, 10, 0.5)
    for N in (3, 7, 5):
        J = bank.horizon_index(N, 0.2)
        kept, fresh = bank.tail_maps(N, J), PulseBank.build(plants, DT, 10, 0.5).tail_maps(N, J)
        for name in ("rigid", "a", "b"):
            np.testing.assert_array_equal(getattr(kept, name), getattr(fresh, name))


def test_a_changed_private_binding_keeps_linprog(monkeypatch: pytest.MonkeyPatch) -> None:
    # SciPy's binding is private: one whose calls fail in any way (here a changed
    # solution type) is not used, rather than failing the design
    def changed(self: object) -> None:
        raise AttributeError("'HighsSolution' object has no attribute 'col_value'")

    hf.available.cache_clear()
    monkeypatch.setattr(hf.HighsFeasibility, "solve", changed)
    try:
        assert not hf.available()
    finally:
        hf.available.cache_clear()
    monkeypatch.undo()
    assert hf.available()
