"""hdd-pes reports both controllers on one list of discretised plants (issue 24)."""

from __future__ import annotations

import dataclasses

import numpy as np

from servokit.cases.hdd_pes import (
    CASE_FILTER,
    loop_report,
    peak_filtered_controller,
    variants_discretized,
)
from servokit.feedback.factor_response import clear_factor_cache
from servokit.models import (
    HDD_BENCHMARK_TS,
    BenchmarkDisturbances,
    benchmark_controller,
    hdd_benchmark,
)


def _fields(report) -> dict:
    out = {f.name: getattr(report, f.name) for f in dataclasses.fields(report) if f.name != "pes"}
    return {k: np.float64(v).tobytes() for k, v in out.items()}


def test_shared_plants_give_the_fresh_reports():
    """The second controller reuses the plants' margin factors: the same numbers bit for
    bit as reports on freshly discretised plants (cache cleared)."""
    rec = BenchmarkDisturbances().generate(12, seed=1)
    c0 = benchmark_controller()
    c1 = peak_filtered_controller(c0, hdd_benchmark().discretize(HDD_BENCHMARK_TS), CASE_FILTER)
    plants_d = variants_discretized()
    shared = [loop_report(c, rec, plants_d) for c in (c0, c1)]
    fresh = []
    for c in (c0, c1):
        clear_factor_cache()
        fresh.append(loop_report(c, rec))
    for s, f in zip(shared, fresh, strict=True):
        assert _fields(s) == _fields(f)
        assert np.asarray(s.pes.pes).tobytes() == np.asarray(f.pes.pes).tobytes()
