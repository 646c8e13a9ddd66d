"""The hdd-loopshape reproduce case (issue 25): slow, runs the full 54-loop design."""

from __future__ import annotations

import pytest

from servokit.cases import registry


@pytest.mark.slow
def test_hdd_loopshape_case(tmp_path) -> None:
    res = registry()["hdd-loopshape"](tmp_path)
    rows = {c.quantity: c for c in res.comparisons}
    base, design = res.extra["baseline"], res.extra["loopshape"]
    # the baseline numbers come out of the evaluation (servokit's benchmark controller)
    assert base["all_stable"] and 940 < base["min_crossover_hz"] < 960
    assert design["all_stable"]
    assert design["worst_s_peak_db"] <= base["worst_s_peak_db"] + 1e-6
    assert design["min_crossover_hz"] > 1.1 * base["min_crossover_hz"]
    assert rows["controller states"].ok
    assert res.extra["held_out"]["loopshape"]["max_pole_radius"] < 1.0
    assert all(p.exists() for p in res.figures)
