"""The case runner's CPU economy (issue 24): grouping, BLAS threads, the slycot probe."""

from __future__ import annotations

import os
import sys

import pytest

from servokit.cases.runner import _groups, one_blas_thread, skip_missing_slycot


def test_cases_of_one_module_share_a_worker_in_run_order() -> None:
    names = ["hdd-seek", "peak-filter-12khz", "identification-vcm", "hdd-loopshape",
             "ltv-peak-filter-locus", "identification-pzt", "zz-run-time-case"]  # fmt: skip
    assert _groups(names) == [
        ["hdd-seek"],
        ["peak-filter-12khz", "ltv-peak-filter-locus"],
        ["identification-vcm", "identification-pzt"],
        ["hdd-loopshape"],
        ["zz-run-time-case"],
    ]


def test_one_blas_thread_limits_and_restores(monkeypatch: pytest.MonkeyPatch) -> None:
    import numpy  # noqa: F401  (its BLAS is loaded)
    from threadpoolctl import threadpool_info

    monkeypatch.setenv("OMP_NUM_THREADS", "3")
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    before = [p["num_threads"] for p in threadpool_info()]
    with one_blas_thread():
        assert all(p["num_threads"] == 1 for p in threadpool_info())
        assert os.environ["OPENBLAS_NUM_THREADS"] == os.environ["OMP_NUM_THREADS"] == "1"
    assert [p["num_threads"] for p in threadpool_info()] == before
    assert os.environ["OMP_NUM_THREADS"] == "3" and "OPENBLAS_NUM_THREADS" not in os.environ


def test_missing_slycot_fails_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    monkeypatch.delitem(sys.modules, "slycot", raising=False)
    absent = importlib.util.find_spec("slycot") is None
    skip_missing_slycot()
    if absent:
        assert sys.modules["slycot"] is None
        with pytest.raises(ImportError):
            import slycot  # noqa: F401
    else:  # installed: left alone
        assert sys.modules.get("slycot") is not None or "slycot" not in sys.modules
    monkeypatch.delitem(sys.modules, "slycot", raising=False)
