"""The case runner's CPU economy (issue 24): grouping, BLAS threads, the slycot probe."""

from __future__ import annotations

import os
import sys
from pathlib import Path

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


def test_pool_takes_the_longest_groups_first() -> None:
    from servokit.cases.runner import _longest_first

    groups = [["a"], ["b", "c"], ["d"], ["e"]]
    costs = {"a": 1.0, "b": 0.5, "c": 2.0, "d": 4.0}  # "e" unknown: 0
    assert _longest_first(groups, costs) == [["d"], ["b", "c"], ["a"], ["e"]]
    assert _longest_first(groups, {}) == groups  # no history: the run order


def test_previous_runtimes_is_a_hint_never_an_error(tmp_path) -> None:
    import json

    from servokit.cases.runner import previous_runtimes

    good = tmp_path / "results.json"
    cases = [{"name": "a", "runtime_s": 1.5}, {"name": "b", "runtime_s": float("nan")},
             {"name": "c", "runtime_s": -1}, {"name": "d", "runtime_s": "2"},
             {"name": 3, "runtime_s": 1}, {"name": "e", "runtime_s": True}, "junk"]  # fmt: skip
    good.write_text(json.dumps({"cases": cases}))
    assert previous_runtimes(good) == {"a": 1.5}
    good.write_text('{"cases": [{"name": "a", "runtime_s": 1%s}]}' % ("0" * 400))
    assert previous_runtimes(good) == {}  # an integer beyond float: not an error
    assert previous_runtimes(good, max_bytes=10) == {}  # oversized: not read
    assert previous_runtimes(tmp_path / "missing.json") == {}
    assert previous_runtimes(tmp_path) == {}  # a directory
    for text in ("[1, 2]", "{", '{"cases": 5}', "[" * 100_000):
        good.write_text(text)
        assert previous_runtimes(good) == {}
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    assert previous_runtimes(fifo) == {}  # not opened: no hang


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc mallopt")
def test_kept_heap_stops_page_faulting_each_temporary() -> None:
    import subprocess

    # arrays of 0.5, 1, ..., 20 MB made, written and freed: by default glibc maps each
    # new, larger size afresh (its threshold adapts only after the free), which
    # page-faults every array afresh; with the setting the heap is reused and
    # faults only as it grows to the largest array (20 MB: 5120 pages)
    code = (
        "import resource, numpy as np\n"
        "from servokit._heap import keep_freed_arrays\n"
        "tuned = {tuned} and keep_freed_arrays()\n"
        "before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt\n"
        "for k in range(1, 41): np.ones(k << 16).sum()\n"
        "print(int(tuned), resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)\n"
    )
    thp = Path("/sys/kernel/mm/transparent_hugepage/enabled")
    if thp.is_file() and "[always]" in thp.read_text():
        pytest.skip("transparent huge pages for every mapping: fault counts depend on them")
    # numpy asks for huge pages on large arrays; whether the kernel has them free varies
    # (26818 or 9955 faults untuned on the same machine): counted in 4 kB pages
    env = dict(os.environ, NUMPY_MADVISE_HUGEPAGE="0")
    counts = {}
    for tuned in (False, True):
        out = subprocess.run([sys.executable, "-c", code.format(tuned=tuned)],
                             capture_output=True, text=True, check=True,
                             env=env).stdout.split()  # fmt: skip
        assert out[0] == str(int(tuned))
        counts[tuned] = int(out[1])
    growth = (40 << 16) * 8 // 4096  # pages of the largest array: 5120
    assert counts[True] <= 1.2 * growth  # measured 5109
    assert counts[False] >= 3 * counts[True]  # measured 105001 (every array afresh)


def test_workers_fork_from_a_frozen_heap(tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    import gc
    from concurrent.futures import ProcessPoolExecutor

    from servokit.cases import register
    from servokit.cases.registry import _REGISTRY
    from servokit.cases.runner import WORKER_GC_THRESHOLD, iter_cases
    from servokit.report import CaseResult

    def probe(name: str):
        def case(out):
            # the parent's objects are frozen in the worker: its collections skip them
            from servokit import _heap

            seen = {
                "pid": os.getpid(),
                "frozen": gc.get_freeze_count(),
                "heap": _heap._TUNED,
                "young": gc.get_threshold()[0],
            }
            return CaseResult(name, "probe", [], [], extra=seen)

        return case

    submitted = []
    real_submit = ProcessPoolExecutor.submit

    def submit(self, fn, outdir, group, svg):  # noqa: ANN001, ANN202
        submitted.append(list(group))
        return real_submit(self, fn, outdir, group, svg)

    monkeypatch.setattr(ProcessPoolExecutor, "submit", submit)
    names = ["zz-probe-a", "zz-probe-b"]
    for i, name in enumerate(names):
        register(name, order=600 + i)(probe(name))
    try:
        assert gc.get_freeze_count() == 0
        # the pool is handed "b" first (the longer); the yield order stays the run order
        runs = list(iter_cases(tmp_path, names, workers=2, costs={"zz-probe-b": 5.0}))
        seen = [r.extra for _, done, _ in runs for r in done]
        assert [name for name, _, _ in runs] == names
        assert [r.name for _, done, _ in runs for r in done] == names
        assert submitted == [["zz-probe-b"], ["zz-probe-a"]]  # the longest handed out first
    finally:
        for name in names:
            _REGISTRY.pop(name, None)
    assert len(seen) == 2
    assert all(s["pid"] != os.getpid() and s["frozen"] > 1000 for s in seen)
    assert all(s["young"] == WORKER_GC_THRESHOLD for s in seen)
    assert gc.get_threshold()[0] != WORKER_GC_THRESHOLD  # the parent's is left alone
    if sys.platform.startswith("linux"):  # glibc: the thresholds of a short-lived worker
        from servokit._heap import WORKER_MMAP_THRESHOLD_BYTES, WORKER_TRIM_THRESHOLD_BYTES

        worker = (WORKER_MMAP_THRESHOLD_BYTES, WORKER_TRIM_THRESHOLD_BYTES)
        assert all(s["heap"] == worker for s in seen)
    assert gc.get_freeze_count() == 0  # the parent unfrozen again


def test_a_worker_freezes_what_each_case_leaves(monkeypatch: pytest.MonkeyPatch) -> None:
    import gc

    from servokit.cases import runner

    calls: list[str] = []
    monkeypatch.setattr(runner, "_run_one", lambda out, name, svg: calls.append(name) or name)
    monkeypatch.setattr(gc, "collect", lambda *a: calls.append("collect") or 0)
    monkeypatch.setattr(gc, "freeze", lambda: calls.append("freeze"))
    assert runner._run_group(Path("."), ["a", "b"], False) == ["a", "b"]
    # the next case's collections walk only its own objects
    assert calls == ["a", "collect", "freeze", "b", "collect", "freeze"]


def test_heap_setting_is_tried_once_per_process(monkeypatch: pytest.MonkeyPatch) -> None:
    from servokit import _heap

    tries = []
    monkeypatch.setattr(_heap, "_TUNED", None)
    monkeypatch.setattr(_heap, "_MALLOPT", None)
    monkeypatch.setattr(_heap, "_find_mallopt", lambda: tries.append(1) or False)
    assert _heap.keep_freed_arrays() is False  # e.g. not glibc: remembered, not retried
    assert _heap.keep_freed_arrays(1 << 20, 2 << 20) is False
    assert tries == [1]


def test_heap_thresholds_are_set_as_asked(monkeypatch: pytest.MonkeyPatch) -> None:
    from servokit import _heap

    calls = []
    monkeypatch.setattr(_heap, "_TUNED", None)
    monkeypatch.setattr(_heap, "_MALLOPT", lambda key, value: calls.append((key, value)) or 1)
    assert _heap.keep_freed_arrays()
    assert _heap.keep_freed_arrays()  # the same values: set once
    assert _heap.keep_freed_arrays(_heap.WORKER_MMAP_THRESHOLD_BYTES,
                                   _heap.WORKER_TRIM_THRESHOLD_BYTES)  # fmt: skip
    assert calls == [(-3, 32 << 20), (-1, 64 << 20), (-3, 128 << 20), (-1, 256 << 20)]


def test_reproduce_hands_the_last_runs_times_to_the_pool(tmp_path, monkeypatch) -> None:
    import json

    from servokit.cases import runner
    from servokit.cli.reproduce import _run_cases

    (tmp_path / "results.json").write_text(
        json.dumps({"cases": [{"name": "hdd-seek", "runtime_s": 2.5}]})
    )
    given = {}

    def no_cases(stage, names, *, svg, costs):  # noqa: ANN001, ANN202
        given.update(costs)
        return iter(())

    monkeypatch.setattr(runner, "iter_cases", no_cases)
    _run_cases(tmp_path, ["hdd-seek"], False)
    assert given == {"hdd-seek": 2.5}


@pytest.mark.parametrize(
    ("argv", "preset", "numpy_first", "want"),
    [
        (["servokit", "reproduce", "--out", "x"], None, False, "1"),
        (["servokit", "--json", "reproduce"], None, False, "1"),
        (["servokit", "margins", "reproduce"], None, False, None),  # another command
        (["servokit", "reproduce"], "4", False, "4"),  # the user's own setting wins
        (["servokit", "reproduce"], None, True, None),  # numpy loaded: too late, untouched
    ],
)
def test_reproduce_asks_one_blas_thread_before_numpy_loads(argv, preset, numpy_first, want):
    import subprocess

    code = (
        "import os, sys\n"
        f"sys.argv = {argv!r}\n"
        + ("import numpy\n" if numpy_first else "")
        + "import servokit.cli\n"
        "print(os.environ.get('OPENBLAS_NUM_THREADS'))\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if preset is not None:
        env["OPENBLAS_NUM_THREADS"] = preset
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, env=env).stdout.strip()  # fmt: skip
    assert out == str(want)
