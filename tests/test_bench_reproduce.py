"""``bench/reproduce_cpu.py --baseline``: runs alternated, ratio of the best CPU times."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "bench"


@pytest.fixture
def reproduce_cpu(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))
    import reproduce_cpu as module

    yield module
    sys.modules.pop("reproduce_cpu", None)


def test_baseline_runs_alternate_and_the_ratio_is_of_the_best_runs(reproduce_cpu, monkeypatch):
    calls: list[str | None] = []
    cpu = {None: iter([36.0, 34.0, 35.0]), "old/src": iter([110.0, 120.0, 102.0])}

    def fake_run(cases, out, src=None):
        calls.append(src)
        seconds = next(cpu[src])
        return {"user_s": seconds, "sys_s": 0.0, "cpu_s": seconds, "wall_s": seconds / 2,
                "load_avg_1min": 0.0, "n_rows": 7, "runtime_s": {}}  # fmt: skip

    monkeypatch.setattr(reproduce_cpu, "run_reproduce", fake_run)
    res = reproduce_cpu.measure([], Path("out"), 3, "old/src")
    assert calls == ["old/src", None] * 3
    assert res["cpu_s"] == 34.0 and res["baseline"]["cpu_s"] == 102.0
    assert res["ratio"] == pytest.approx(3.0)
    assert res["normalised_cpu_s"] == pytest.approx(reproduce_cpu.ISSUE_BASELINE_CPU_S / 3.0)
    assert res["target_ratio"] == pytest.approx(
        reproduce_cpu.ISSUE_BASELINE_CPU_S / reproduce_cpu.TARGET_CPU_S
    )
    assert res["met_normalised"] == (3.0 >= res["target_ratio"])
    assert not res["met"]  # 34 s absolute is still reported as such


def test_without_a_baseline_only_this_tree_runs(reproduce_cpu, monkeypatch):
    calls: list[str | None] = []

    def fake_run(cases, out, src=None):
        calls.append(src)
        return {"user_s": 19.0, "sys_s": 0.5, "cpu_s": 19.5, "wall_s": 10.0,
                "load_avg_1min": 0.0, "n_rows": 7, "runtime_s": {}}  # fmt: skip

    monkeypatch.setattr(reproduce_cpu, "run_reproduce", fake_run)
    res = reproduce_cpu.measure(["hdd-seek"], Path("out"), 2, None)
    assert calls == [None, None] and res["met"] and "ratio" not in res
