"""The chapter-5 resonance cases run, and their computed rows rest on checked quantities."""

from __future__ import annotations

import numpy as np
import pytest

from servokit.cases.peak_filters import (
    SEARCH_GRID,
    _candidate,
    _designs,
    constrained_baseline,
    ltv_locus_case,
    peak_example_baseline,
    peak_filter_case,
)
from servokit.cases.resonance import resonance_filters_case
from servokit.feedback import design_peak_filter


def rows(result):
    return {c.quantity: c for c in result.comparisons}


def test_resonance_filters_case(tmp_path):
    r = resonance_filters_case(tmp_path)
    got = rows(r)
    assert got["complex lag phase at ωm = -2φm"].ok
    assert r.extra["margins_4_5"]["phase_margin_deg"] == pytest.approx(30.17, abs=0.01)
    assert all(p.exists() for p in r.figures) and r.chapter == 5


def test_searched_baseline_is_a_grid_point_with_the_stated_loop():
    ex = peak_example_baseline()
    assert (ex.residue, ex.crossover_hz, ex.lead_spread) in SEARCH_GRID
    wc = 2 * np.pi * ex.crossover_hz
    assert abs(complex((ex.plant * ex.controller)(1j * wc))) == pytest.approx(1.0, rel=1e-9)
    assert np.all(ex.sh.poles().real < 0)
    # a candidate's pseudo plant is PC/(1+PC) at any frequency
    other = _candidate(-1e-4, 1000.0, 2.0)
    s = 2j * np.pi * 3000.0
    loop = complex((other.plant * other.controller)(s))
    assert complex(other.sh(s)) == pytest.approx(loop / (1 + loop), rel=1e-9)


@pytest.mark.parametrize("baseline", [peak_example_baseline, constrained_baseline])
def test_designs_kept_from_the_fit_equal_a_fresh_design(baseline):
    """The rows read the designs kept by the fit: the same numbers as designing again."""
    ex = baseline()
    assert set(ex.designs) == {"stable", "phase-shift", "frequency-shift"}
    fresh = _designs(ex, ex.gain)
    for method, (flt, phi, loc) in ex.designs.items():
        f2, phi2, loc2 = fresh[method]
        assert phi == phi2
        np.testing.assert_array_equal(flt.num[0][0], f2.num[0][0])
        np.testing.assert_array_equal(flt.den[0][0], f2.den[0][0])
        for name in ("k_crit", "plant_k_crit", "filter_k_crit"):
            assert getattr(loc, name) == getattr(loc2, name)
        assert loc.filter_departure_deg == loc2.filter_departure_deg
        assert loc.plant_departure_deg == loc2.plant_departure_deg


def test_peak_filter_case_rows(tmp_path):
    r = peak_filter_case(tmp_path)
    got = rows(r)
    assert got["phase shift (5.38): extra attenuation at 12 kHz"].servokit == pytest.approx(10.0)
    ex = peak_example_baseline()
    flt, _ = design_peak_filter(ex.sh, 12000.0, 0.01, r.extra["filter_gain_k"], "stable")
    k = r.extra["stable"]["plant_k_crit"]
    # at the reported critical multiplier a closed-loop root sits on the imaginary axis
    den = np.polymul(ex.sh.den[0][0], flt.den[0][0])
    num = np.polymul(ex.sh.num[0][0], flt.num[0][0])
    roots = np.roots(np.polyadd(den, k * num))
    assert np.min(np.abs(roots.real)) < 1e-6 * np.max(np.abs(roots))
    assert len(r.figures) == 4


def test_ltv_locus_case_runs(tmp_path):
    r = ltv_locus_case(tmp_path)
    # each stage's reported finite critical multiplier puts a closed-loop root of
    # 1 + k Sh F on the imaginary axis (recomputed from the stage's filter)
    ex = peak_example_baseline()
    for method, k, zeta in (("transient", 1.0, 0.1), ("phase-shift", 0.2, 0.02)):
        flt, _ = design_peak_filter(ex.sh, 12000.0, zeta, k, method)
        crit = [v for v in (r.extra[method]["plant_k_crit"], r.extra[method]["filter_k_crit"])]
        finite = [v for v in crit if np.isfinite(v)]
        assert finite, method
        den = np.polymul(ex.sh.den[0][0], flt.den[0][0])
        num = np.polymul(ex.sh.num[0][0], flt.num[0][0])
        roots = np.roots(np.polyadd(den, min(finite) * num))
        assert np.min(np.abs(roots.real)) < 1e-6 * np.max(np.abs(roots)), method
    # every missed row of the case carries its class and evidence
    assert all(
        c.miss_class == "under_determined" and c.miss_note for c in r.comparisons if not c.ok
    )
