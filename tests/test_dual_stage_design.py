"""The §5.5.2 design example: filter factors, controller orders, Table 5.4 measurements."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.dual_stage import dual_stage_open_loop
from servokit.feedback.dual_stage_design import (
    BOOK_TABLE_5_4,
    METHODS,
    Unknowns,
    design_responses,
    evaluate_design,
    peak_filter_addon,
    plant_zeros,
    pzt_controller,
    vcm_controller,
    zero_pole_pair,
)
from servokit.models import pzt_active_suspension, vcm_dual_stage


def _at(sys, f_hz: float) -> complex:
    return complex(sys(2j * np.pi * f_hz))


@settings(max_examples=40, deadline=None)
@given(st.floats(100, 1e4), st.floats(0.001, 0.5), st.floats(0.01, 2.0), st.floats(-4, 4))
def test_peak_filter_addon_is_one_plus_f(f1: float, z1: float, k: float, phi: float) -> None:
    one_plus_f = peak_filter_addon(f1, z1, k, phi)
    w1 = 2 * np.pi * f1
    for f in (0.3 * f1, f1, 3 * f1):
        s = 2j * np.pi * f
        peak = k * s * (s * np.cos(phi) + w1 * np.sin(phi)) / (s * s + 2 * z1 * w1 * s + w1 * w1)
        assert _at(one_plus_f, f) == pytest.approx(1 + peak, rel=1e-9)
    # (5.17) at w1: F = K (cos phi + j sin phi) (j w1)^2 / (2 j zeta1 w1^2) -> angle phi + pi/2
    F = _at(one_plus_f, f1) - 1
    assert abs(F) == pytest.approx(k / (2 * z1), rel=1e-9)


def test_inverse_pair_cancels_mode_and_zero() -> None:
    pair = zero_pole_pair(2484, 2751, 0.02, 0.0185)
    assert abs(_at(pair, 1e6)) == pytest.approx(1.0, rel=1e-4)
    assert abs(_at(pair, 0.0)) == pytest.approx((2484 / 2751) ** 2, rel=1e-12)


def test_plant_zeros_match_the_printed_pair_poles() -> None:
    # the book's pole frequencies of the inverse pairs are zeros of the tabulated models,
    # except 4775 Hz (VCM) and 9549 Hz (PZT)
    vz = np.array(sorted(plant_zeros(vcm_dual_stage())))
    pz = np.array(sorted(plant_zeros(pzt_active_suspension())))
    for f in (5691, 6973, 7515):
        assert np.min(np.abs(vz - f)) / f < 2e-3
    for f in (2751, 5686, 6646, 11672):
        assert np.min(np.abs(pz - f)) / f < 2e-3
    assert np.min(np.abs(vz - 4775)) / 4775 > 0.15
    assert np.min(np.abs(pz - 9549)) / 9549 > 0.05


@pytest.mark.parametrize("method", METHODS)
def test_controller_orders_match_table_5_4(method: str) -> None:
    assert vcm_controller(method).order == int(BOOK_TABLE_5_4[method]["order_cv"])
    assert pzt_controller(method).order == int(BOOK_TABLE_5_4[method]["order_cm"])


def test_inverse_gain_matches_gain_method_at_low_frequency() -> None:
    # monic pairs: 3.3302 * prod (fz/fp)^2 = 5.04, the gain method's KCV = 5 (to 1 %)
    f = np.array([1.0])
    ratio = vcm_controller("inverse").freqresp(f) / vcm_controller("gain").freqresp(f)
    assert abs(ratio[0]) == pytest.approx(1.0, abs=0.01)


def test_cascade_equals_product_tf() -> None:
    c = pzt_controller("phase")
    f = np.geomspace(10, 2e4, 7)
    np.testing.assert_allclose(c.freqresp(f), c.tf()(2j * np.pi * f), rtol=1e-6)


def test_dms_sensitivity_is_product_on_the_design() -> None:
    f = np.geomspace(10, 5e4, 500)
    r = design_responses("gain", Unknowns(), f)
    sv = 1 / (1 + r.vcm_loop)
    sm = 1 / (1 + r.pzt_loop)
    np.testing.assert_allclose(r.sensitivity, sv * sm, rtol=1e-12)
    ld = dual_stage_open_loop(r.vcm_loop, 1.0, r.pzt_loop, 1.0, "dms")
    np.testing.assert_allclose(ld, r.open_loop, rtol=1e-12)


def test_naive_reading_of_the_gain_design() -> None:
    # the naive reading (zeta_D 0.5, continuous, no delay): 1.48 kHz / 24 deg /
    # 2.5 dB / 12 dB (an independent earlier computation)
    row = evaluate_design("gain", Unknowns(notch_damping=0.5))
    assert row.crossover_hz == pytest.approx(1480, rel=0.01)
    assert row.phase_margin_deg == pytest.approx(24, abs=0.5)
    assert row.gain_margin_db == pytest.approx(2.5, abs=0.3)
    assert row.s_inf_db == pytest.approx(12, abs=1)


def test_unknowns_are_checked() -> None:
    with pytest.raises(ServokitValueError, match="notch_damping"):
        Unknowns(notch_damping=0.0)
    with pytest.raises(ServokitValueError, match="delay_pzt_s"):
        Unknowns(delay_pzt_s=-1e-6)
    with pytest.raises(ServokitValueError, match="method"):
        vcm_controller("lqg")


@pytest.mark.slow
def test_search_refinds_the_inverse_unknowns() -> None:
    from servokit.cases.dual_stage import FITTED
    from servokit.feedback.dual_stage_design import fit_unknowns, table_cost

    res = fit_unknowns("inverse")
    assert res.cost < 0.05  # every inverse row within a twentieth of its tolerance
    for key, value in FITTED["inverse"].items():
        assert getattr(res.unknowns, key) == pytest.approx(value, rel=0.05, abs=1e-6)
    assert table_cost(evaluate_design("inverse", Unknowns(**FITTED["inverse"]))) < 0.05


@pytest.mark.parametrize("method", METHODS)
def test_grid_margins_agree_with_stability_margins(method: str) -> None:
    # two independent margin readers: dense grid + interpolation vs root refinement (h10)
    from servokit.cases.dual_stage import fitted_unknowns

    u = fitted_unknowns(method)
    grid, refined = evaluate_design(method, u), evaluate_design(method, u, refine=True)
    assert grid.crossover_hz == pytest.approx(refined.crossover_hz, rel=1e-5)
    assert grid.phase_margin_deg == pytest.approx(refined.phase_margin_deg, abs=1e-3)
    assert grid.gain_margin_db == pytest.approx(refined.gain_margin_db, abs=1e-2)


def test_vcm_peak_filter_phase_confirms_the_inverse_delay() -> None:
    # the printed phi = 2.5414 rad is arg T0(j w1) - pi/2 of the VCM baseline loop with the
    # delay found on the inverse column (independent of that fit's targets)
    from servokit.cases.dual_stage import FITTED
    from servokit.feedback.dual_stage_design import peak_filter_phases

    u = Unknowns(
        notch_damping=0.7,
        extra_notch_depth_damping=0.005,
        delay_vcm_s=FITTED["inverse"]["delay_vcm_s"],
    )
    assert peak_filter_phases(u)["phi_vcm_deg"] == pytest.approx(np.degrees(2.5414), abs=0.5)
    # without the delay the reading misses by ~27 deg
    no_delay = peak_filter_phases(Unknowns(notch_damping=0.7, extra_notch_depth_damping=0.005))
    assert abs(no_delay["phi_vcm_deg"] - np.degrees(2.5414)) > 20


def test_plant_responses_kept_are_the_fresh_ones():
    """The kept ``PV``, ``PM`` of a (delays, grid) pair equal a fresh evaluation bit for bit."""
    from servokit.feedback import dual_stage_design as dsd

    dsd._PLANTS.clear()
    f = np.geomspace(10.0, 5.0e4, 300)
    for delays in ((0.0, 0.0), (2e-5, 1e-5), (-0.0, 0.0), (2e-5, 1e-5)):
        u = dsd.Unknowns(delay_vcm_s=delays[0], delay_pzt_s=delays[1])
        for grid in (f, f[::-1].copy(), f.tolist()):
            pv, pm = dsd._plant_responses(u, np.asarray(grid))
            np.testing.assert_array_equal(
                pv, vcm_dual_stage().replace(delay=delays[0]).freqresp(grid)
            )
            np.testing.assert_array_equal(
                pm, pzt_active_suspension().replace(delay=delays[1]).freqresp(grid)
            )
            assert not pv.flags.writeable and not pm.flags.writeable
    assert len(dsd._PLANTS) == 6  # (-0.0, 0.0) is its own entry; the repeat is found
    for k in range(dsd._PLANTS_MAX + 3):  # bounded
        dsd._plant_responses(dsd.Unknowns(delay_vcm_s=k * 1e-6), f)
    assert len(dsd._PLANTS) == dsd._PLANTS_MAX
