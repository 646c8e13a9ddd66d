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


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 300),
    seed=st.integers(0, 2**63),
    cut=st.tuples(st.floats(0, 1), st.floats(0, 1)),
    normal=st.booleans(),
    gain=st.booleans(),
)
def test_draw_rows_are_rows_of_draw_bit_for_bit(n, seed, cut, normal, gain):
    # a Dask task draws its own rows: they must be exactly those of the whole draw
    import dataclasses

    vset = dataclasses.replace(
        VSET,
        distribution="normal" if normal else "uniform",
        gain=(-0.1, 0.2) if gain else (0.0, 0.0),
    )
    lo, hi = sorted(int(c * n) for c in cut)
    draws, gains = vset.draw(n, seed)
    rows, row_gains = vset.draw_rows(n, seed, lo, hi)
    np.testing.assert_array_equal(rows, draws[lo:hi])
    np.testing.assert_array_equal(row_gains, gains[lo:hi])
    assert rows.shape == (hi - lo, len(vset.ranges))


def test_draw_rows_refuses_rows_outside_the_set():
    import pytest

    from servokit.errors import ServokitValueError

    with pytest.raises(ServokitValueError, match="lo <= hi <= n"):
        VSET.draw_rows(5, 0, 3, 6)
