"""The beyond-the-book case hdd-robust-seek (issue 13)."""

from __future__ import annotations

import numpy as np
import pytest

from servokit.cases import registry
from servokit.cases.robust_seek import held_out_plants
from servokit.models import hdd_benchmark


def test_held_out_plants_vary_modes_not_gain():
    plants = held_out_plants(20, seed=1)
    nominal = hdd_benchmark()
    assert len(plants) == 20
    assert all(p.gain == nominal.gain and p.delay == 0.0 for p in plants)
    f3 = np.array([p.modes[2].freq_hz for p in plants])
    assert np.all((f3 >= 0.95 * 4100.0) & (f3 <= 1.025 * 4100.0)) and f3.std() > 0
    assert [p.modes for p in held_out_plants(3, seed=1)] == [p.modes for p in plants[:3]]


def test_registered_beyond_the_book():
    assert "hdd-robust-seek" in registry()


@pytest.mark.slow
def test_case_rows_all_met(tmp_path):
    res = registry()["hdd-robust-seek"](tmp_path)
    assert len(res.comparisons) == 6
    assert all(c.ok for c in res.comparisons), [c.quantity for c in res.comparisons if not c.ok]
    assert {c.kind for c in res.comparisons} == {"spec", "consistency"}
    assert all(p.exists() for p in res.figures)
    w = res.extra["worst_seek_ms"]
    assert w["10"]["robust"] <= 0.85 * w["10"]["d2"]
    assert w["1"]["robust"] <= 0.85 * w["1"]["d2"]


@pytest.mark.parametrize("n, seed", [(1, 0), (37, 1), (300, 2026)])
def test_held_out_arrays_give_the_plants_seek_times(n, seed):
    """The case reads the held-out seek times from arrays: the plant path's bits (issue 24)."""
    from servokit.cases.robust_seek import held_out_arrays
    from servokit.models import hdd_benchmark_variants, without_delay
    from servokit.seek.hdd import BAND, DESIGNS
    from servokit.simulate import seek_time
    from servokit.simulate._bank import modal_arrays
    from servokit.simulate.metrics import seek_time_of_arrays

    arrays, plants = held_out_arrays(n, seed), held_out_plants(n, seed)
    for a, b in zip(arrays, modal_arrays(plants), strict=True):
        assert np.array_equal(a, b)
    nominal = without_delay(hdd_benchmark_variants())[0]
    for design in (DESIGNS[0], DESIGNS[3]):
        ff = design.design(nominal)
        fast = seek_time_of_arrays(arrays, 0.0, ff, design.tracks, band=BAND)
        # a small memory budget: the plant path in several chunks
        plain = seek_time(plants, ff, design.tracks, band=BAND, max_memory_mb=1.0)
        assert np.array_equal(fast, plain)
