"""Robust seek validated over the variation box (servokit.robust.validated, issue 22 item 4)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.models import ModalPlant, Mode, VariationSet
from servokit.seek import robust_minimum_time, robust_seek_over_box
from servokit.seek.validated import box_seek_scores
from servokit.simulate import seek_time

DT, TARGET, BAND, U_MAX = 1e-4, 1.0, 0.01, 1.0
PLANT = ModalPlant(gain=4e6, modes=(Mode(0, 0, 1.0), Mode(2000, 0.02, -0.3)), name="small")
#: a 2-D box (frequency and damping of the one resonance): small enough to brute-force
BOX = VariationSet.per_mode(PLANT, freq_rel=0.08, damping_rel=0.5, seed=3)
SMALL = {"n_validation": 300, "n_corners": 0, "n_samples": 2, "margin": 0.0}


def _grid_plants(n: int) -> list[ModalPlant]:
    """Every plant of an ``n x n`` grid over the box, vertices included."""
    g = np.linspace(-1.0, 1.0, n)
    f, z = np.meshgrid(g, g)
    rel = np.column_stack([f.ravel() * 0.08, z.ravel() * 0.5])
    return BOX.from_draws(rel, np.zeros(len(rel)))


@pytest.fixture(scope="module")
def validated():
    return robust_seek_over_box(BOX, DT, TARGET, band=BAND, u_max=U_MAX, **SMALL)


@pytest.mark.slow
def test_validated_worst_equals_brute_force_over_the_box(validated):
    """The reported worst is the worst of a dense grid over the box plus a fresh Monte-Carlo
    sample (independent plants, seek times from the plain simulator), within one grid step;
    and the plain design on the first design set alone is beaten inside the box."""
    h = DT / 10
    plants = _grid_plants(41) + BOX.monte_carlo(1000, seed=1234)
    brute = seek_time(plants, validated.ff, TARGET, band=BAND).max()
    assert validated.converged
    assert abs(validated.seek_time - brute) <= h + 1e-12
    assert validated.seek_time <= validated.design_seek_time + h + 1e-12
    first = robust_minimum_time(
        [PLANT, *BOX.monte_carlo(2, seed=3)], DT, TARGET, band=BAND, u_max=U_MAX, margin=0.0
    )
    plain = seek_time(plants, first, TARGET, band=BAND).max()
    assert plain > first.guaranteed_seek_time + 5 * h  # what item 4 is about


def test_loop_terminates_and_reports_rounds():
    """``max_rounds`` bounds the loop; an unconverged result says so and keeps its numbers."""
    res = robust_seek_over_box(BOX, DT, TARGET, band=BAND, u_max=U_MAX, max_rounds=1, **SMALL)
    assert len(res.rounds) == 1
    assert res.n_design == 3  # nominal + 2 samples, no violators added after the last round
    worst = max(res.rounds[0].mc_worst, res.rounds[0].adversarial_worst)
    assert res.seek_time == pytest.approx(worst)
    assert res.converged == (res.seek_time <= res.design_seek_time + DT / 10 * 1.001)
    assert res.n_validation == 300 and res.validation_seek_times.shape == (300,)
    # the Monte-Carlo part of the validation is the plain simulator's seek time
    mc = BOX.monte_carlo(300, seed=BOX.seed + 1)
    np.testing.assert_allclose(res.validation_seek_times, seek_time(mc, res.ff, TARGET, BAND))


_NOMINAL_DESIGN: list = []


def _nominal_design():
    if not _NOMINAL_DESIGN:
        _NOMINAL_DESIGN.append(
            robust_minimum_time(PLANT, DT, TARGET, band=BAND, u_max=U_MAX, margin=0.0)
        )
    return _NOMINAL_DESIGN[0]


@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), band=st.sampled_from([0.01, 0.03, 0.1]))
def test_scores_floor_to_the_seek_time(seed, band):
    """The tie-break never crosses a grid step: floor(score / h) h is the seek time."""
    plants = _grid_plants(3) + BOX.monte_carlo(6, seed=seed)
    ff = _nominal_design()
    sc = box_seek_scores(plants, ff, TARGET, band)
    st_ = seek_time(plants, ff, TARGET, band=band)
    h = DT / 10
    np.testing.assert_allclose(np.floor(sc / h + 1e-6) * h, st_, atol=1e-12)
    fin = np.isfinite(st_)
    assert fin.any()
    assert np.all(sc[fin] >= st_[fin]) and np.all(sc[fin] < st_[fin] + h)


def test_settle_below_gives_the_same_design():
    """Starting the settle search above a subset's guarantee does not change the optimum."""
    plants = [PLANT, *BOX.monte_carlo(3, seed=9)]
    full = robust_minimum_time(plants, DT, TARGET, band=BAND, u_max=U_MAX, N=11, margin=0.0)
    sub = robust_minimum_time(plants[:2], DT, TARGET, band=BAND, u_max=U_MAX, N=11, margin=0.0)
    fast = robust_minimum_time(
        plants,
        DT,
        TARGET,
        band=BAND,
        u_max=U_MAX,
        N=11,
        margin=0.0,
        settle_below=sub.guaranteed_seek_time - DT / 10,
    )
    assert fast.guaranteed_seek_time == pytest.approx(full.guaranteed_seek_time)
    assert fast.n_lp <= full.n_lp


def test_delay_range_is_refused():
    box = VariationSet.per_mode(PLANT.replace(delay=1e-5), freq_rel=0.05, delay_rel=0.1)
    with pytest.raises(ServokitValueError, match="delay_rel"):
        robust_seek_over_box(box, DT, TARGET, band=BAND, u_max=U_MAX, **SMALL)
