"""Dual-stage loop structures (book §5.5.1) and the grid measurements of Table 5.4."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.dual_stage import (
    dual_stage_loops,
    dual_stage_open_loop,
    handoff,
    loop_margins,
)

FREQ = np.geomspace(1.0, 1e5, 4000)


def _resp(sys: control.LTI, f: np.ndarray = FREQ) -> np.ndarray:
    return np.asarray(sys(2j * np.pi * f)).ravel()


def _block_diagram(PV, CV, PM, CM, structure, PM_hat=None):
    """r -> y and r -> e of the Fig. 5.35-5.37 block diagrams, built by interconnect."""
    est = PM if PM_hat is None else PM_hat
    blocks = [
        control.ss(PV, inputs="uV", outputs="yV", name="PV"),
        control.ss(PM, inputs="uM", outputs="yM", name="PM"),
        control.ss(CM, inputs="e", outputs="uM", name="CM"),
        control.ss(est, inputs="uM", outputs="yMh", name="PMh"),
        control.summing_junction(["r", "-y"], "e", name="err"),
        control.summing_junction(["yV", "yM"], "y", name="out"),
    ]
    cv_in = {"parallel": "e", "cms": "yMh", "dms": "eV"}[structure]
    blocks.append(control.ss(CV, inputs=cv_in, outputs="uV", name="CV"))
    if structure == "dms":
        blocks.append(control.summing_junction(["e", "yMh"], "eV", name="dms"))
    return control.interconnect(blocks, inputs="r", outputs=["y", "e"], check_unused=False)


def _plants():
    PV = control.tf([1.4e8], [1, 2 * 0.2 * 120, 120**2])
    PM = 0.36 * control.tf([1], [1 / (2 * np.pi * 9e3) ** 2, 0.02 / (2 * np.pi * 9e3), 1])
    CV = 5.0 * control.tf([1, 200 * np.pi, (100 * np.pi) ** 2], [1, 2 * np.pi * 3e4, 0]) * 1e-4
    CM = 0.2 * control.tf([1, 2 * np.pi * 3e4], [1, 2 * np.pi * 900])
    return PV, CV, PM, CM


@pytest.mark.parametrize("structure", ["parallel", "cms", "dms"])
def test_formulas_match_block_diagram(structure: str) -> None:
    PV, CV, PM, CM = _plants()
    loops = dual_stage_loops(PV, CV, PM, CM, structure)
    sys = _block_diagram(PV, CV, PM, CM, structure)
    ry, re = _resp(sys[0, 0]), _resp(sys[1, 0])
    np.testing.assert_allclose(_resp(loops.T), ry, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(_resp(loops.S), re, rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("structure", ["cms", "dms"])
def test_imperfect_estimator_matches_block_diagram(structure: str) -> None:
    PV, CV, PM, CM = _plants()
    PMh = 1.1 * PM
    loops = dual_stage_loops(PV, CV, PM, CM, structure, PM_hat=PMh)
    sys = _block_diagram(PV, CV, PM, CM, structure, PM_hat=PMh)
    np.testing.assert_allclose(_resp(loops.S), _resp(sys[1, 0]), rtol=1e-8, atol=1e-12)


complex_arrays = st.lists(
    st.tuples(
        st.floats(0.01, 100.0),
        st.floats(-np.pi, np.pi),
        st.floats(0.01, 100.0),
        st.floats(-np.pi, np.pi),
        st.floats(0.01, 100.0),
        st.floats(-np.pi, np.pi),
        st.floats(0.01, 100.0),
        st.floats(-np.pi, np.pi),
    ),
    min_size=1,
    max_size=20,
)


@settings(max_examples=80, deadline=None)
@given(complex_arrays)
def test_dms_identities_on_random_responses(rows) -> None:
    a = np.array(rows)
    pv, cv, pm, cm = (a[:, 2 * k] * np.exp(1j * a[:, 2 * k + 1]) for k in range(4))
    ld = dual_stage_open_loop(pv, cv, pm, cm, "dms")
    # (5.87) SD = SV SM, compared as return differences 1 + LD = (1 + CV PV)(1 + CM PM):
    # the inverses blow up where hypothesis draws 1 + L ~ 0, the products do not
    rv, rm = 1 + cv * pv, 1 + cm * pm
    scale = (1 + np.abs(cv * pv)) * (1 + np.abs(cm * pm))
    np.testing.assert_allclose((1 + ld) / scale, rv * rm / scale, rtol=0, atol=1e-12)
    # (5.89) DMS == parallel with CVP = (1 + CM PM) CV
    par = dual_stage_open_loop(pv, (1 + cm * pm) * cv, pm, cm, "parallel")
    np.testing.assert_allclose(ld, par, rtol=1e-12)
    # (5.83): CMS sensitivity
    lc = dual_stage_open_loop(pv, cv, pm, cm, "cms")
    np.testing.assert_allclose(lc, cm * pm + cv * pv * cm * pm, rtol=1e-12)


def test_dms_statespace_product() -> None:
    PV, CV, PM, CM = _plants()
    loops = dual_stage_loops(PV, CV, PM, CM, "dms")
    sv = control.feedback(1, CV * PV)
    sm = control.feedback(1, CM * PM)
    np.testing.assert_allclose(_resp(loops.S), _resp(sv * sm), rtol=1e-9)


def test_loop_margins_against_python_control() -> None:
    L = control.tf([2e3**2 * 3], [1, 0, 0]) * control.tf([1 / 600, 1], [1 / 6000, 1])
    L = L * control.tf([1], [1 / (2 * np.pi * 2e4), 1])
    L = L * control.tf([1], [1 / 1e5, 1])
    gm, pm, wcg, wcp = control.margin(L)
    m = loop_margins(FREQ, _resp(L))
    assert m.gain_crossover_hz == pytest.approx(wcp / (2 * np.pi), rel=1e-4)
    assert m.phase_margin_deg == pytest.approx(pm, abs=0.02)
    assert m.gain_margin_db == pytest.approx(20 * np.log10(gm), abs=0.02)
    assert m.phase_crossover_hz == pytest.approx(wcg / (2 * np.pi), rel=1e-4)


def test_second_phase_margin_of_a_phase_stabilised_mode() -> None:
    # rigid body + lead, plus an in-phase resonance above 0 dB: crossings 3 times
    wr = 2 * np.pi * 5e3
    P = control.tf([1e8], [1, 0, 0]) + control.tf([4e8 * 1.0], [1, 2 * 0.01 * wr, wr**2])
    C = control.tf([1 / 300, 1], [1 / 3000, 1]) * 0.03
    m = loop_margins(FREQ, _resp(P * C))
    assert m.crossovers_hz.size >= 3
    # each margin is 180 + phase at that crossover (later ones in [0, 360))
    ph = np.degrees(np.unwrap(np.angle(_resp(P * C))))
    for f, pm in zip(m.crossovers_hz[1:], m.phase_margins_deg[1:], strict=True):
        want = (180 + np.interp(np.log(f), np.log(FREQ), ph)) % 360
        assert pm == pytest.approx(want, abs=1e-9)
        assert 0 <= pm < 360
    assert -180 < m.phase_margin_deg <= 180
    assert m.second_phase_margin_deg == m.phase_margins_deg[1]


def test_handoff_closed_form() -> None:
    # |k/s^2| = |c| at f = sqrt(k/c)/(2 pi); the phase difference is 180 deg there
    f = FREQ
    s = 2j * np.pi * f
    a, b = 1e8 / s**2, np.full_like(s, 0.5)
    h = handoff(f, a, b)
    assert h.freq_hz == pytest.approx(np.sqrt(1e8 / 0.5) / (2 * np.pi), rel=1e-5)
    assert h.phase_difference_deg == pytest.approx(180.0, abs=1e-9)
    h2 = handoff(f, 1e4 / s, b)
    assert h2.phase_difference_deg == pytest.approx(90.0, abs=1e-9)


def test_bad_input() -> None:
    PV, CV, PM, CM = _plants()
    with pytest.raises(ServokitValueError, match="structure"):
        dual_stage_loops(PV, CV, PM, CM, "serial")
    with pytest.raises(ServokitValueError, match="PV"):
        dual_stage_loops(1.0, CV, PM, CM)
    with pytest.raises(ServokitValueError, match="never crosses"):
        loop_margins(FREQ, np.full(FREQ.size, 0.1 + 0j))
    with pytest.raises(ServokitValueError, match="NaN"):
        loop_margins(FREQ, np.full(FREQ.size, np.nan + 0j))


@settings(max_examples=40, deadline=None)
@given(st.floats(50.0, 5e3), st.floats(1e-6, 1e-4))
def test_loop_margins_integrator_with_delay_closed_form(fc: float, tau: float) -> None:
    # L = wc/s e^{-s tau}: crossover fc, PM = 90 deg - wc tau, phase crossover where
    # w tau = pi/2, GM = 20 log10(w180 / wc)
    wc = 2 * np.pi * fc
    w180 = np.pi / (2 * tau)
    if w180 < 3 * wc or w180 > 2 * np.pi * 5e5:
        return
    f = np.geomspace(1.0, 1e6, 60000)
    s = 2j * np.pi * f
    m = loop_margins(f, wc / s * np.exp(-s * tau))
    assert m.gain_crossover_hz == pytest.approx(fc, rel=1e-6)
    assert m.phase_margin_deg == pytest.approx(90 - np.degrees(wc * tau), abs=1e-3)
    assert m.phase_crossover_hz == pytest.approx(w180 / (2 * np.pi), rel=1e-4)
    assert m.gain_margin_db == pytest.approx(20 * np.log10(w180 / wc), abs=1e-3)


@pytest.mark.slow
def test_cached_joint_searches_are_what_the_searches_find():
    # the Table 5.4 gain/inverse rows rest on JOINT_FIT and cite MAX_GM_DB: re-run both
    from servokit.feedback.dual_stage_fitted import JOINT_FIT, JOINT_SEARCH, MAX_GM_DB
    from servokit.feedback.dual_stage_search import (
        BOOK_RANGES,
        WIDE_RANGES,
        joint_table_search,
        max_gain_margin,
    )

    for box, bounds in (("inside", BOOK_RANGES), ("outside", WIDE_RANGES)):
        fit = joint_table_search(bounds, **JOINT_SEARCH["table"][box])
        assert fit.values == pytest.approx(JOINT_FIT[box], rel=1e-3)
        gm = max_gain_margin(bounds, **JOINT_SEARCH["gain_margin"][box])
        assert gm == pytest.approx(MAX_GM_DB[box], abs=0.01)
        assert gm < 14.1 - 1.0  # the printed 14.1 dB is out of reach


def test_joint_fit_inside_the_book_ranges_and_its_rows():
    # the cached inside optimum respects √2/2 < ζD <= 1 and the delay boxes, and gives the
    # rows the case reports: 10 of 12 gain/inverse rows, gain margin far below 14.1 dB
    from servokit.feedback.dual_stage_design import evaluate_design
    from servokit.feedback.dual_stage_fitted import JOINT_FIT, MAX_GM_DB, joint_unknowns
    from servokit.feedback.dual_stage_search import BOOK_RANGES, rows_within

    for name, (lo, hi) in BOOK_RANGES.items():
        assert lo <= JOINT_FIT["inside"][name] <= hi
    assert np.sqrt(2) / 2 < JOINT_FIT["inside"]["notch_damping"] <= 1.0
    u = joint_unknowns("inside")
    gain, inverse = evaluate_design("gain", u), evaluate_design("inverse", u)
    assert rows_within(gain)[0] + rows_within(inverse)[0] == 10
    assert rows_within(inverse) == (6, 6)
    assert gain.gain_margin_db <= MAX_GM_DB["inside"] + 0.05 < 14.1 - 1.0


def test_pzt_peak_filter_phase_cannot_reach_the_printed_value():
    # arg T(j w1) - 90 deg of the phase method's baseline PZT loop over delays 0-100 us
    from servokit.feedback.dual_stage_search import pzt_phase_span

    span = pzt_phase_span(np.linspace(0.0, 1e-4, 21), np.array([0.05, 0.7]))
    assert span["n"] == 42 and span["max_deg"] < np.degrees(4.2603) - 5.0
    # with no delay the phase is largest: the delay only adds lag at 2484 Hz
    top = pzt_phase_span(np.array([0.0]), np.array([0.05]))["max_deg"]
    assert top == pytest.approx(span["max_deg"], abs=1e-9)


def test_joint_cost_skip_leaves_out_the_gain_margin_row():
    # skip removes exactly the gain column's gain-margin term (5.5.2 search option)
    from servokit.feedback.dual_stage_design import SEARCH_GRID_HZ, evaluate_design, table_cost
    from servokit.feedback.dual_stage_fitted import JOINT_FIT, joint_unknowns
    from servokit.feedback.dual_stage_search import _joint_cost

    values = JOINT_FIT["inside"]
    u = joint_unknowns("inside")
    gain = evaluate_design("gain", u, SEARCH_GRID_HZ)
    full = table_cost(gain) + table_cost(evaluate_design("inverse", u, SEARCH_GRID_HZ))
    assert _joint_cost(values, SEARCH_GRID_HZ) == pytest.approx(full)
    gm_term = (gain.gain_margin_db - 14.1) ** 2
    assert _joint_cost(values, SEARCH_GRID_HZ, ("gain_margin_db",)) == pytest.approx(full - gm_term)
