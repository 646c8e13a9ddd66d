"""Monte-Carlo seek-time sweeps (servokit.robust.sweep) and `servokit sweep`."""

from __future__ import annotations

import dataclasses
import json
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.cases.hdd_seek import DESIGNS
from servokit.cli import _discover
from servokit.cli._app import main
from servokit.errors import ServokitValueError
from servokit.models import hdd_benchmark, hdd_benchmark_variation_set
from servokit.seek.sweep import SweepResult, connect_dask, sweep_seek_times
from servokit.simulate import seek_time

_discover()
VSET = dataclasses.replace(hdd_benchmark_variation_set(), gain=(0.0, 0.0))
FF = DESIGNS[2].design(hdd_benchmark())  # Design 2, 1 track


@settings(max_examples=3, deadline=None)
@given(n=st.integers(1, 12), seed=st.integers(0, 2**31), chunk=st.integers(1, 15))
def test_sweep_equals_direct_monte_carlo(n, seed, chunk):
    """Chunking changes nothing: the plants and seek times of monte_carlo(n, seed)."""
    res = sweep_seek_times(VSET, FF, 1.0, n=n, seed=seed, chunk_size=chunk)
    direct = seek_time(VSET.monte_carlo(n, seed=seed), FF, 1.0, band=0.1)
    np.testing.assert_array_equal(res.seek_times, direct)
    worst = VSET.monte_carlo(n, seed=seed)[int(np.argmax(direct))]
    assert VSET.from_draws(res.draws, res.gains)[0].modes == worst.modes


@settings(max_examples=30, deadline=None)
@given(t=st.lists(st.one_of(st.floats(0.0, 1.0), st.just(float("inf"))), min_size=1, max_size=200))
def test_percentiles_are_nearest_rank(t):
    res = SweepResult(np.array(t), np.zeros(1), np.zeros(1), 1, 0.0, "numpy")
    pct = res.percentiles((50.0, 99.0, 100.0))
    for key, q in (("p50", 50.0), ("p99", 99.0), ("p100", 100.0)):
        assert pct[key] == np.percentile(np.array(t), q, method="inverted_cdf")


def test_memory_is_bounded_by_the_chunk():
    peaks = []
    for n in (100, 400):
        tracemalloc.start()
        res = sweep_seek_times(VSET, FF, 1.0, n=n, seed=1, chunk_size=50)
        peaks.append(tracemalloc.get_traced_memory()[1] / 1e6)
        tracemalloc.stop()
    assert peaks[1] < 1.25 * peaks[0]  # four times the plants, about the same memory
    assert peaks[1] < res.chunk_mb + 5.0  # and below the estimate of one chunk


def test_memory_limit_refused_before_allocating():
    with pytest.raises(ServokitValueError, match="max-memory-mb"):
        sweep_seek_times(VSET, FF, 1.0, n=10**9, max_memory_mb=100.0)


@pytest.mark.parametrize("distribution", ["uniform", "normal"])
@pytest.mark.parametrize("task_bytes", [None, 1000])
def test_dask_local_cluster_matches_numpy(task_bytes, distribution, monkeypatch):
    """Same numbers on Dask; with ``task_bytes`` the set is split into tasks of at most
    that many bytes of draws (1000: 18 variants of 7 numbers each, 23 tasks instead of 8).
    Uniform draws are made by each task (it carries ``(n, seed, lo, hi)``, no arrays);
    normal draws travel with their task."""
    import dataclasses

    distributed = pytest.importorskip("distributed")
    import servokit.seek.sweep as sweep_mod

    vset = dataclasses.replace(VSET, distribution=distribution)
    submitted = []
    if task_bytes is not None:
        monkeypatch.setattr(sweep_mod, "TASK_BYTES", task_bytes)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        submit = client.submit

        def counting(fn, *a, **k):  # noqa: ANN001, ANN002, ANN003, ANN202
            submitted.append(a[1])  # the task's rows
            return submit(fn, *a, **k)

        monkeypatch.setattr(client, "submit", counting)
        on_dask = sweep_seek_times(vset, FF, 1.0, n=400, seed=5, client=client)
    in_proc = sweep_seek_times(vset, FF, 1.0, n=400, seed=5)
    assert on_dask.backend == "dask" and on_dask.chunk_size == 50  # 4 chunks per worker
    np.testing.assert_array_equal(on_dask.seek_times, in_proc.seek_times)
    np.testing.assert_array_equal(on_dask.draws, in_proc.draws)  # the worst plant
    assert on_dask.gains == in_proc.gains
    assert on_dask.percentiles() == in_proc.percentiles()
    per_variant = (VSET.draw(1, 0)[0].shape[1] + 1) * 8
    cap = 50 if task_bytes is None else task_bytes // per_variant
    assert len(submitted) == -(-400 // cap)
    if distribution == "uniform":
        assert all(len(r) == 4 and r[:2] == (400, 5) for r in submitted)
        sizes = [r[3] - r[2] for r in submitted]
    else:
        sizes = [r[0].shape[0] for r in submitted]
    assert sum(sizes) == 400 and max(sizes) <= cap


def test_missing_dask_extra_is_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ServokitValueError, match=r"servokit\[dask\]"):
        connect_dask(workers=1)


# ------------------------------------------------------------------ CLI
def _cli(monkeypatch, capsys, *args: str) -> tuple[int, str, str]:
    monkeypatch.setattr(sys, "argv", ["servokit", "sweep", *args])
    try:
        main()
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_json_plot_and_design_file(monkeypatch, capsys, tmp_path: Path):
    design = tmp_path / "d.json"
    design.write_text(json.dumps({"input": FF.u.tolist(), "dt": FF.dt}))
    png = tmp_path / "sweep.png"
    code, out, err = _cli(
        monkeypatch,
        capsys,
        "--design",
        str(design),
        "--n-variants",
        "300",
        "--seed",
        "4",
        "--json",
        "--plot",
        str(png),
    )
    assert code == 0, err
    data = json.loads(out)
    direct = seek_time(VSET.monte_carlo(300, seed=4), FF, 1.0, band=0.1)
    assert data["worst_seek_time_s"] == direct.max()
    assert data["percentiles_s"]["p100"] == direct.max()
    assert data["backend"] == "numpy" and data["n_unsettled"] == 0
    assert png.stat().st_size > 10_000 and f"wrote {png}" in err


def test_cli_human_output_method(monkeypatch, capsys):
    code, out, err = _cli(
        monkeypatch,
        capsys,
        "--method",
        "fsc",
        "--n-samples",
        "12",
        "--n-variants",
        "200",
        "--no-delay",
    )
    assert code == 0, err
    assert "FSC (N = 12): 200 plants" in out and "p99" in out


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (("--n-variants", "0"), "--n-variants"),
        (("--design", "missing.json"), "--design"),
        (("--scheduler", "tcp://127.0.0.1:1", "--workers", "2"), "not both"),
        (("--n-variants", "100000000", "--max-memory-mb", "10"), "--max-memory-mb"),
        (("--method", "robust"), "--u-max"),
        (("--method", "lqr"), "--method"),
        (("--plot", "out.pdf"), "--plot"),
    ],
)
def test_cli_bad_input_one_line_exit_2(monkeypatch, capsys, args, flag):
    code, out, err = _cli(monkeypatch, capsys, *args)
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("servokit: error:") and flag in err


@pytest.mark.slow
def test_cli_on_a_dask_scheduler_with_worker_processes(monkeypatch, capsys):
    """`--scheduler ADDRESS`: worker processes give the in-process percentiles."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        args = ("--method", "fsc", "--n-samples", "12", "--n-variants", "600", "--json")
        code, out, err = _cli(monkeypatch, capsys, *args, "--scheduler", cluster.scheduler_address)
        assert code == 0, err
    on_dask = json.loads(out)
    code, out, err = _cli(monkeypatch, capsys, *args)
    in_proc = json.loads(out)
    assert on_dask["backend"] == "dask" and in_proc["backend"] == "numpy"
    assert on_dask["percentiles_s"] == in_proc["percentiles_s"]
    assert on_dask["worst_index"] == in_proc["worst_index"]


def test_cli_u_max_clips_the_held_input(monkeypatch, capsys, tmp_path: Path):
    """--u-max above the peak changes nothing; below it the sweep runs the clipped input."""
    design = tmp_path / "d.json"
    design.write_text(json.dumps({"input": FF.u.tolist(), "dt": FF.dt}))
    peak = float(np.abs(FF.u).max())
    runs = {}
    for lim in (None, 2 * peak, 0.5 * peak):
        extra = () if lim is None else ("--u-max", repr(lim))
        code, out, err = _cli(
            monkeypatch, capsys, "--design", str(design), "--n-variants", "50", "--json", *extra
        )
        assert code == 0, err
        runs[lim] = json.loads(out)
    assert runs[2 * peak]["percentiles_s"] == runs[None]["percentiles_s"]
    assert runs[2 * peak]["design"]["n_clipped"] == 0
    clipped = runs[0.5 * peak]["design"]
    assert clipped["n_clipped"] == int(np.sum(np.abs(FF.u) > 0.5 * peak)) > 0
    assert clipped["peak_input"] == 0.5 * peak
    direct = seek_time(
        VSET.monte_carlo(50, seed=0),
        dataclasses.replace(FF, u=np.clip(FF.u, -0.5 * peak, 0.5 * peak)),
        1.0,
        band=0.1,
    )
    assert runs[0.5 * peak]["n_unsettled"] == int(np.sum(~np.isfinite(direct))) == 50
    # (an open-loop seek cannot land with half its peak current: every plant is unsettled)


def test_worker_chunk_tunes_the_heap_and_gives_the_same_numbers(monkeypatch):
    # the Dask task (heap thresholds set once per process first) is the in-process chunk
    from servokit.seek import sweep as sweep_mod

    calls = []
    real = sweep_mod.keep_freed_arrays
    monkeypatch.setattr(sweep_mod, "keep_freed_arrays", lambda: calls.append(1) or real())

    draws, gains = VSET.draw(7, 3)
    held = sweep_mod._Held(np.asarray(FF.u, dtype=float), FF.dt)
    args = (held, 1.0, 0.1, None, None)
    ref = sweep_mod._chunk_seek_times(VSET, draws, gains, *args)
    for chunk in (7, 3, 1):  # a task in chunks; the heap set up once (idempotent)
        task = sweep_mod._chunk_on_worker(VSET, (draws, gains), args, chunk)
        np.testing.assert_array_equal(task, ref)
        # a task that draws its own rows (2:6 of the same seven) gives theirs
        task = sweep_mod._chunk_on_worker(VSET, (7, 3, 2, 6), args, chunk)
        np.testing.assert_array_equal(task, ref[2:6])
    assert calls  # the task set the heap up


def test_default_chunk_fits_the_budget():
    from servokit.seek.sweep import _CHUNK_BUDGET, plan_chunks

    size, per_plant = plan_chunks(VSET, FF, 10**6)
    assert size * per_plant <= _CHUNK_BUDGET < (size + 1) * per_plant
    size2, _ = plan_chunks(VSET, FF, 10**6, n_workers=2)
    assert size2 == size  # a million plants: plenty of chunks for every worker


@pytest.mark.parametrize("threads", [1, 2])
def test_in_process_chunks_run_on_one_blas_thread(threads, monkeypatch):
    """The sweep's parallelism is across chunks: BLAS inside a chunk runs one thread (on
    2 cores OpenBLAS's extra threads spun: 7.4 vs 3.1 CPU s at 10^5), and the limit is
    lifted after the sweep. The seek times are those of the direct computation."""
    from threadpoolctl import threadpool_info

    import servokit.seek.sweep as sweep_mod

    def blas_threads() -> list[int]:
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]

    seen: list[list[int]] = []
    real = sweep_mod._chunk_seek_times

    def spy(*a, **k):
        seen.append(blas_threads())
        return real(*a, **k)

    before = blas_threads()
    monkeypatch.setattr(sweep_mod, "_chunk_seek_times", spy)
    res = sweep_seek_times(VSET, FF, 1.0, n=6, seed=3, chunk_size=2, threads=threads)
    assert seen and all(t == [1] * len(t) for t in seen)
    assert blas_threads() == before
    direct = seek_time(VSET.monte_carlo(6, seed=3), FF, 1.0, band=0.1)
    np.testing.assert_array_equal(res.seek_times, direct)


@pytest.mark.slow
def test_dask_worker_readied_for_chunks():
    """connect_dask readies each worker: the heap kept for arrays, one BLAS thread, no
    statistical profiler sampling the task thread and rare health checks and monitors (a
    local cluster has no dashboard); the client's own configuration is left as it was."""
    pytest.importorskip("distributed")
    from servokit.seek.sweep import LOCAL_CLUSTER_CONFIG, connect_dask

    client = connect_dask(workers=1)
    try:

        def state() -> tuple:
            import dask
            from threadpoolctl import threadpool_info

            from servokit import _heap

            blas = [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]
            keys = (*LOCAL_CLUSTER_CONFIG, "distributed.admin.tick.limit")
            return _heap._TUNED, blas, {k: dask.config.get(k) for k in keys}

        ((tuned, blas, worker_config),) = client.run(state).values()
        # the scheduler and the nanny (in this process) run the same rare callbacks
        tick_s = client.run_on_scheduler(lambda dask_scheduler: dask_scheduler._tick_interval)
    finally:
        client.close()
    import dask
    from dask.utils import parse_timedelta

    assert tuned and blas and all(n == 1 for n in blas)
    assert worker_config.pop("distributed.worker.profile.enabled") is False
    assert worker_config.pop("distributed.admin.tick.limit") == "3s"  # still reported
    assert parse_timedelta(worker_config.pop("distributed.admin.tick.interval")) == 1.0
    assert parse_timedelta(worker_config.pop("distributed.admin.system-monitor.interval")) == 5.0
    assert parse_timedelta(worker_config.pop("distributed.worker.memory.monitor-interval")) == 1.0
    assert not worker_config  # every setting checked
    assert tick_s == pytest.approx(1.0)
    # the client's own configuration is the default again
    assert dask.config.get("distributed.worker.profile.enabled") is True
    assert parse_timedelta(dask.config.get("distributed.admin.tick.interval")) == 0.02
