"""The chapter-3 cases: book numbers from the fitted loops."""

from __future__ import annotations

import numpy as np
import pytest

from servokit.cases.switching_ivc import (
    POLES_331,
    POLES_332,
    _expand,
    _zeros_331,
    book_loop,
    jmin_loop,
    switching_ivc_case,
)
from servokit.switching import additional_input_response, ivc_additional_input, ivc_jmin


def test_fitted_loops_reproduce_printed_poles():
    for poles in (POLES_331, POLES_332):
        got = np.sort_complex(book_loop(poles).poles())
        np.testing.assert_allclose(got, np.sort_complex(np.array(_expand(poles))), atol=1e-3)


def test_pole_zero_ivc_zeros_331_within_001():
    np.testing.assert_allclose(_zeros_331(book_loop(POLES_331)), [-0.390, 0.169, -0.291], atol=0.01)


def test_additional_input_zero_332():
    loop = book_loop(POLES_332)
    y, _, _ = additional_input_response(loop, ivc_additional_input(loop, 0.6), [1.0, 0, 0], 3)
    assert -(y[1] - 0.6 * y[0]) / y[0] == pytest.approx(-0.393, abs=5e-4)


def test_jmin_case2_has_no_overshoot_case1_has():
    from servokit.switching import free_response

    loop = jmin_loop()
    xp = np.array([5e-6, -5e-3])
    under = {}
    for qv in (0.0, 1e-6):
        K = ivc_jmin(loop, None, np.diag([1.0, qv, 0.0, 0.0]))
        under[qv] = -np.min(free_response(loop.A, loop.C, loop.stack(K) @ xp, 400))
    assert under[0.0] > 1e-7 and under[1e-6] <= 1e-12


@pytest.fixture
def no_plots(monkeypatch, tmp_path):
    """Replace the chapter-3 plot calls by a stub: the reduced tests judge rows, not figures."""
    from servokit.cases import switching_admissible, switching_galvano, switching_ivc

    def stub(*args, path=None, **kwargs):
        return path if path is not None else tmp_path / "stub.png"

    for mod in (switching_ivc, switching_admissible, switching_galvano):
        monkeypatch.setattr(mod, "transient_plot", stub)
    monkeypatch.setattr(switching_admissible, "admissible_plot", stub)
    return tmp_path


@pytest.fixture(scope="module")
def unit_current_set():
    """O_inf of the §3.3.3 loop for |u| <= 1 A (shared: the LP pruning is the slow part)."""
    from servokit.cases.switching_admissible import admissible_loop
    from servokit.switching import max_output_admissible_set

    loop = admissible_loop()
    return loop, max_output_admissible_set(loop.A, loop.Cu, -1.0, 1.0)


def test_case_runs_reduced(no_plots, monkeypatch):
    # the slow test's outcome (every row within tolerance) with 8 rounding draws, not 60
    from servokit.cases import switching_ivc

    monkeypatch.setattr(switching_ivc, "N_DRAWS", 8)
    res = switching_ivc_case(no_plots)
    assert len(res.comparisons) >= 10
    assert [c.quantity for c in res.comparisons if not c.ok] == []
    rows = {c.quantity: c for c in res.comparisons}
    assert rows["zero of xpos[0] -> y after pole-zero IVC"].ok
    pole = [c for c in res.comparisons if "b fitted" in c.quantity]
    assert len(pole) == 1 and pole[0].servokit == pytest.approx(0.999, abs=5e-4)


def test_admissible_case_reduced(no_plots):
    # same rows as the slow test (figures stubbed): 4 of 4 with IVC, 1 with zero reset
    from servokit.cases.switching_admissible import switching_admissible_case

    res = switching_admissible_case(no_plots)
    got = {c.quantity: c.servokit for c in res.comparisons}
    assert got["Table 3.1 conditions admissible with IVC"] == 4.0
    assert got["Table 3.1 conditions admissible with zero reset"] == 1.0
    assert got["zero-reset set inside the IVC set (1 = yes)"] == 1.0
    assert res.extra["gain_factor"] > 0 and all(c.ok for c in res.comparisons)


def test_acoustic_current_sets_reduced(unit_current_set):
    # the case's Fig. 3.21 rows from O_inf(|u| <= 1) scaled by cp (O_inf is linear in the
    # bound): J-min IVC enlarges the set and contains the §3.4.1 switching condition
    from servokit.cases.switching_acoustic import CONDITION, CP_A, _area
    from servokit.cases.switching_admissible import _scaled, _slice
    from servokit.switching import ivc_pole_zero

    loop, unit = unit_current_set
    real = sorted((p.real for p in loop.poles() if abs(p.imag) < 1e-12), key=lambda p: -abs(p))
    gains = {
        "pz": ivc_pole_zero(loop, None, real[:2]),
        "jmin": ivc_jmin(loop, None, output_weight=loop.Cu),
    }
    cur = {k: _scaled(unit, CP_A).restrict(loop.stack(K) @ _slice(loop)) for k, K in gains.items()}
    assert _area(cur["jmin"]) > _area(cur["pz"]) > 0
    assert cur["jmin"].contains(CONDITION)


def test_galvano_case_reduced(no_plots):
    from servokit.cases.switching_galvano import switching_galvano_case

    res = switching_galvano_case(no_plots)
    assert res.extra["closed_loop_roots"] == 13 and res.extra["compensator_order"] == 12
    assert res.comparisons and all(c.ok for c in res.comparisons)


@pytest.mark.slow
def test_case_runs(tmp_path):
    res = switching_ivc_case(tmp_path)
    assert all(p.exists() for p in res.figures)
    misses = [c.quantity for c in res.comparisons if not c.ok]
    assert misses == []


def test_lag_pole_needs_a_damped_plant():
    # the double integrator misses the printed 0.999; b ~ 31.7 1/s of 1/(s(s+b)) reaches it
    from servokit.cases.switching_ivc import _controller_pole

    assert _controller_pole(0.0) == pytest.approx(0.99376, abs=2e-5)
    assert _controller_pole(31.7) == pytest.approx(0.999, abs=5e-5)
    assert _controller_pole(10.0) < _controller_pole(20.0) < _controller_pole(40.0)


@pytest.mark.slow
def test_admissible_case_classification_and_brute_force(tmp_path):
    from servokit.cases.switching_admissible import (
        TABLE_3_1,
        U_MAX,
        _slice,
        admissible_loop,
        switching_admissible_case,
    )
    from servokit.switching import free_response

    res = switching_admissible_case(tmp_path)
    assert all(c.ok for c in res.comparisons)
    gain = res.extra["gain_factor"]
    loop = admissible_loop()
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    for p, v in TABLE_3_1:  # brute force: IVC keeps |u| within the fitted bound
        x0 = loop.stack(K) @ (_slice(loop) @ np.array([p, v]))
        u = free_response(loop.A, loop.Cu, x0, 4000)
        assert np.max(np.abs(u)) <= U_MAX * gain * (1 + 1e-6)


def test_h2_case_fits_phase_margin_and_reports_ranking(tmp_path):
    from servokit.cases.switching_h2 import switching_h2_case

    res = switching_h2_case(tmp_path)
    pm = [c for c in res.comparisons if c.quantity == "phase margin"][0]
    assert pm.ok
    ju = res.extra["ju_conditions"]
    assert ju["B"] > ju["A"]  # faster switching costs more input energy


@pytest.mark.slow
def test_galvano_case_scatter_removed_with_full_ivc(tmp_path):
    from servokit.cases.switching_galvano import switching_galvano_case

    res = switching_galvano_case(tmp_path)
    assert res.extra["closed_loop_roots"] == 13 and res.extra["compensator_order"] == 12
    assert all(c.ok for c in res.comparisons)


def test_ipd_controller_places_rigid_body_poles():
    import dataclasses

    import control

    from servokit.switching import equilibrium, switched_loop
    from servokit.switching.design import ipd_controller

    dt, g, bw = 1e-5, 50.0, 100.0
    rigid = control.c2d(control.ss([[0, 1], [0, 0]], [[0], [g]], [[1, 0]], 0), dt, "zoh")
    fb, Bcr, Dcr = ipd_controller(dt, g, bw, damping=0.7, derivative_hz=1e5)
    loop = dataclasses.replace(switched_loop(rigid, fb), Bcr=Bcr, Dcr=Dcr)
    w = 2 * np.pi * bw
    want = np.exp(np.roots(np.polymul([1, w], [1, 2 * 0.7 * w, w**2])) * dt)
    got = loop.poles()
    for p in want:  # the derivative filter adds one fast pole
        assert np.min(np.abs(got - p)) < 2e-3
    assert equilibrium(loop, 1.0)[0] == pytest.approx(1.0)  # integral action on r - y


def test_optical_case_alpha_is_the_pole_zero_gain(tmp_path):
    from servokit.cases.switching_optical import switching_optical_case

    res = switching_optical_case(tmp_path)
    assert all(c.ok for c in res.comparisons)


def test_pmr_case_ivc_lowers_peak_and_jump(tmp_path):
    from servokit.cases.switching_pmr import switching_pmr_case

    res = switching_pmr_case(tmp_path)
    assert all(c.ok for c in res.comparisons)
    assert res.extra["stats"]["without IVC"]["max_jerk"] == pytest.approx(20.0)  # u drops to 0


@pytest.mark.slow
def test_acoustic_case_sets(tmp_path):
    from servokit.cases.switching_acoustic import switching_acoustic_case

    res = switching_acoustic_case(tmp_path)
    assert all(c.ok for c in res.comparisons)
    areas = res.extra["area_settling_track_mm_s"]
    assert max(areas.values()) < min(res.extra["area_current_track_mm_s"].values())
