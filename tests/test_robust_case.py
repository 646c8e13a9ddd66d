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
