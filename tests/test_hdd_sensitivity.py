"""§4.5.2 case study: the multirate HDD loop and the disturbance ratios (4.70)-(4.71)."""

from __future__ import annotations

import numpy as np
import pytest

from servokit.cases import registry
from servokit.cases.hdd_sensitivity import (
    ALIAS_HZ,
    disturbance_ratios,
    hdd_multirate,
    run,
)
from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data
from servokit.sampled import sampled_data_sensitivity

# book values, eqs. (4.70) at 3.6 kHz and (4.71) at 2.916 kHz
BOOK = {
    3600.0: {"yc": 0.18, "yc0": 0.92, "yd": 0.13, "yd0": 0.90},
    ALIAS_HZ: {"yc": 1.85, "yc0": 0.92, "yd": 0.13, "yd0": 0.90},
}


@pytest.fixture(scope="module")
def sims():
    return {f: disturbance_ratios(f) for f in BOOK}


@pytest.mark.parametrize("freq", list(BOOK))
def test_simulated_ratios_match_book_within_10_percent(sims, freq):
    sim = sims[freq]["simulation"]
    for key, book in BOOK[freq].items():
        assert sim[key] == pytest.approx(book, rel=0.10), key


@pytest.mark.parametrize("freq", list(BOOK))
def test_simulation_matches_exact_steady_state(sims, freq):
    # the hybrid simulator and the alias-sum steady state (4.27)-(4.31) are independent
    sim, exact = sims[freq]["simulation"], sims[freq]["steady_state"]
    for key in sim:
        assert sim[key] == pytest.approx(exact[key], rel=1e-4), key


@pytest.mark.parametrize("freq", list(BOOK))
def test_formulas_match_book_within_10_percent(freq):
    r = sampled_data_sensitivity(
        hdd_sampled_data(),
        controller_eq_4_69(),
        HDD_SAMPLED_DATA_TS,
        [freq],
        multirate=hdd_multirate(),
    )
    book = BOOK[freq]
    assert r.Ssd[0] == pytest.approx(book["yc"], rel=0.10)  # (4.35)
    assert r.Tsd[0] == pytest.approx(book["yc0"], rel=0.10)  # (4.32)
    assert abs(r.Sd[0]) == pytest.approx(book["yd"], rel=0.10)  # (4.36)
    assert abs(r.Td[0]) == pytest.approx(book["yd0"], rel=0.10)  # (4.33)


def test_interpolator_has_no_one_over_m_gain():
    # with a 1/m gain in Ip the ratios at 3.6 kHz would be far from (4.70)
    import control

    mr = hdd_multirate()
    scaled = type(mr)(
        4, interpolator=control.tf([0.25] * 4, [1, 0, 0, 0], mr.interpolator.dt), filter=mr.filter
    )
    r = sampled_data_sensitivity(
        hdd_sampled_data(), controller_eq_4_69(), HDD_SAMPLED_DATA_TS, [3600.0], multirate=scaled
    )
    assert abs(r.Ssd[0] - 0.18) / 0.18 > 0.5


def test_design_specifications_of_4_5_2_1():
    r = sampled_data_sensitivity(
        hdd_sampled_data(),
        controller_eq_4_69(),
        HDD_SAMPLED_DATA_TS,
        np.linspace(5.0, 500.0, 100),
        multirate=hdd_multirate(),
    )
    assert np.all(np.abs(r.Sd) < 1) and np.all(r.Ssd < 1)  # |Sd| < 1 below 500 Hz
    # Ssd is small at 3.6 kHz thanks to Fm, and ~2 at its alias (4.21)
    assert ALIAS_HZ == pytest.approx(1 / HDD_SAMPLED_DATA_TS - 3600.0, rel=1e-12)


def test_case_runs_and_reports(tmp_path):
    assert "hdd-sensitivity" in registry()
    res = run(tmp_path)
    assert len(res.comparisons) == 20
    missed = sorted(c.quantity for c in res.comparisons if not c.ok)
    # the known misses: the gain margin spec (4.13 dB < 4.5 dB) and, at the printed
    # precision, 0.89 vs "0.90" (yd0, both frequencies) and 1.86 vs "1.85"
    assert "gain margin" in missed
    by_name = {c.quantity: c for c in res.comparisons}
    assert by_name["gain margin"].servokit == pytest.approx(4.13, abs=0.01)
    assert by_name["gain margin"].miss_class == "book_inconsistent"
    assert res.extra["margins_without_delay"]["gain_margin_db"] == pytest.approx(4.41, abs=0.01)
    # every miss is classified with its evidence
    assert all(c.miss_class and c.miss_note for c in res.comparisons if not c.ok)
    assert by_name["phase margin"].ok and by_name["max |Sd| below 500 Hz"].ok
    assert len(res.figures) == 11
    for fig in res.figures:
        assert fig.exists() and fig.stat().st_size > 10_000
    assert res.extra["margins"]["phase_margin_deg"] == pytest.approx(30.0, abs=1.0)
