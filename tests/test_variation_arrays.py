"""Draws straight to modal arrays (issue 24) against the plant-object path."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.cases.hdd_seek import DESIGNS
from servokit.models import hdd_benchmark, hdd_benchmark_variation_set
from servokit.models.variation_arrays import modal_arrays_from_draws
from servokit.seek.sweep import sweep_seek_times
from servokit.simulate import seek_time
from servokit.simulate._bank import modal_arrays

VSET = hdd_benchmark_variation_set()
FF = DESIGNS[2].design(hdd_benchmark())  # Design 2, 1 track


@settings(max_examples=20, deadline=None)
@given(n=st.integers(1, 40), seed=st.integers(0, 2**31))
def test_arrays_equal_those_of_the_plants_bit_for_bit(n, seed):
    draws, gains = VSET.draw(n, seed)
    got = modal_arrays_from_draws(VSET, draws, gains)
    ref = modal_arrays(VSET.from_draws(draws, gains))
    for a, b in zip(got, ref, strict=True):
        np.testing.assert_array_equal(a, b)


def test_threaded_sweep_with_gain_range_equals_plant_path():
    n, seed = 23, 5
    res = sweep_seek_times(VSET, FF, 1.0, n=n, seed=seed, chunk_size=4, threads=2)
    direct = seek_time(VSET.monte_carlo(n, seed=seed), FF, 1.0, band=0.1)
    np.testing.assert_array_equal(res.seek_times, direct)
    assert np.ptp(direct[np.isfinite(direct)]) > 0  # the plants differ
