"""Seek-time sweeps of the HDD benchmark (Table 2.3 ranges, Design 2, 10 tracks): draws
straight to arrays (issue 24), 10^5 and 10^6 variants in chunks, in-process; and the
same 10^5-variant sweep on Dask (:func:`dask_scaling`).

Per size: wall seconds with 2 threads and the share of the time spent outside the
simulation kernel ``run_chunk`` (draws, arrays, plant bank, settling-time read-out); at
10^5 also 1 thread and the plant-object path it replaced (``seek_time(vset.from_draws(...))``
per chunk, same numbers required).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from servokit.cases.hdd_seek import DESIGNS
from servokit.models import hdd_benchmark, hdd_benchmark_variation_set
from servokit.seek import sweep as sweep_mod
from servokit.simulate import _core, seek_time


def _timed_kernel() -> tuple[list[float], object]:
    """Patch ``run_chunk`` to add up its wall time; returns (accumulator, original)."""
    spent = [0.0]
    original = _core.run_chunk

    def timed(*a, **k):
        t0 = time.perf_counter()
        out = original(*a, **k)
        spent[0] += time.perf_counter() - t0
        return out

    _core.run_chunk = timed
    return spent, original


def _plant_path(vset, ff, n: int, seed: int, chunk: int) -> np.ndarray:
    draws, gains = vset.draw(n, seed)
    out = np.empty(n)
    for lo in range(0, n, chunk):
        sl = slice(lo, min(n, lo + chunk))
        out[sl] = seek_time(vset.from_draws(draws[sl], gains[sl]), ff, 10.0, band=0.1)
    return out


def _run(vset, ff, n: int, threads: int) -> tuple[object, float, float]:
    """One sweep: (result, wall seconds, kernel seconds summed over threads, CPU seconds
    of the process: on a shared machine the CPU time is the steadier figure)."""
    spent, original = _timed_kernel()
    try:
        t0, c0 = time.perf_counter(), time.process_time()
        res = sweep_mod.sweep_seek_times(vset, ff, 10.0, n=n, seed=2026, threads=threads)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    finally:
        _core.run_chunk = original
    return res, wall, spent[0], cpu


def sweeps(sizes: tuple[int, ...] = (100_000, 1_000_000), baseline_max: int = 100_000) -> dict:
    """Sweep seconds per size (2 threads; up to ``baseline_max`` also 1 thread and the
    replaced plant-object path), and the share of the time spent outside the kernel."""
    vset = dataclasses.replace(hdd_benchmark_variation_set(), gain=(0.0, 0.0))
    ff = DESIGNS[3].design(hdd_benchmark().replace(delay=0.0))
    out: dict = {}
    for n in sizes:
        key = f"n{n:.0e}".replace("+0", "")
        res, wall, kernel, cpu = _run(vset, ff, n, 2)
        out[f"{key}_2_threads_s"] = wall
        out[f"{key}_2_threads_cpu_s"] = cpu
        out[f"{key}_2_threads_share_outside_simulation"] = 1.0 - kernel / (2 * wall)
        out[f"{key}_chunk_size"] = res.chunk_size
        if n <= baseline_max:
            res1, wall1, kernel1, cpu1 = _run(vset, ff, n, 1)
            assert np.array_equal(res.seek_times, res1.seek_times)
            out[f"{key}_s"] = wall1
            out[f"{key}_cpu_s"] = cpu1
            out[f"{key}_share_outside_simulation"] = 1.0 - kernel1 / wall1
            t0 = time.perf_counter()
            ref = _plant_path(vset, ff, n, 2026, res1.chunk_size)
            out[f"{key}_plant_object_path_s"] = time.perf_counter() - t0
            out[f"{key}_same_numbers"] = bool(np.array_equal(ref, res.seek_times))
    return out


_EXTERNAL = """
import sys, time
from distributed import LocalCluster
cluster = LocalCluster(n_workers=int(sys.argv[1]), threads_per_worker=1, dashboard_address=None)
print(cluster.scheduler_address, flush=True)
sys.stdin.read()  # until the benchmark closes our stdin
"""


def _external_scheduler(workers: int):
    """A LocalCluster in a separate process (as a user's running scheduler); returns the
    process and the scheduler address."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-c", _EXTERNAL, str(workers)],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    return proc, proc.stdout.readline().strip()


def _cpu(client) -> float:
    """CPU seconds of this process plus (with a client) of every Dask worker process."""
    own = time.process_time()
    return own if client is None else own + sum(client.run(time.process_time).values())


def _timed_sweep(vset, ff, n: int, client=None, **kw) -> tuple[object, float, float]:
    """(result, wall seconds, CPU seconds of all processes involved)."""
    c0, t0 = _cpu(client), time.perf_counter()
    res = sweep_mod.sweep_seek_times(vset, ff, 10.0, n=n, seed=2026, client=client, **kw)
    wall = time.perf_counter() - t0
    return res, wall, _cpu(client) - c0


def dask_scaling(n: int = 100_000, rounds: int = 2, n_large: int = 0) -> dict:
    """Wall seconds of one sweep of ``n`` variants in-process (1 and 2 threads) and on
    Dask: a local cluster of 1 and of 2 single-threaded workers, and an external
    scheduler (a LocalCluster of 2 workers in another process, passed by address).
    One cluster is alive at a time; its start-up is timed apart (paid once per session);
    best of ``rounds``, its runs alternating with the in-process ones; CPU seconds summed
    over this process and the workers; the seek times must be identical on every
    backend.  A cluster is compared with the in-process runs made while it was alive
    (the same number of runs on each side, interleaved: the best of 3 against the
    best of 9 would favour in-process by the noise alone); the median of the per-round
    ratios is reported beside the ratio of the bests.  With ``n_large``, the 1-worker
    cluster and one in-process thread also run a sweep of ``n_large`` variants
    (``rounds`` times, in turn): the scheduler's round trips (about 30 ms a sweep on a
    quiet machine) weigh on 10^5 variants (1.4 s), not on 10^6."""
    import logging

    logging.getLogger("distributed").setLevel(logging.ERROR)
    vset = dataclasses.replace(hdd_benchmark_variation_set(), gain=(0.0, 0.0))
    ff = DESIGNS[3].design(hdd_benchmark().replace(delay=0.0))
    ref = _timed_sweep(vset, ff, n)[0]
    out: dict = {"variants": n}
    # one cluster alive at a time, as a user runs one: with all three alive at once (the
    # previous design) one backend per run stalled 1.5-3 s, a different one each run
    best: dict = {}
    paired: dict = {}  # (cluster, label) -> best wall while that cluster was alive
    rounds_ratio: dict = {}  # cluster -> its wall over the in-process one, per round
    local = {"in_process_1_thread": {"threads": 1}, "in_process_2_threads": {"threads": 2}}
    same_cores = {"dask_1_worker": "in_process_1_thread",
                  "dask_2_workers": "in_process_2_threads"}  # fmt: skip
    for name, how in (("dask_1_worker", {"workers": 1}), ("dask_2_workers", {"workers": 2}),
                      ("dask_external_2_workers", None)):  # fmt: skip
        proc = None
        if how is None:
            proc, address = _external_scheduler(2)
            how = {"scheduler": address}
        t0 = time.perf_counter()
        client = sweep_mod.connect_dask(**how)
        out[f"{name}_startup_s"] = time.perf_counter() - t0
        try:
            # in-process runs alternate with this cluster's: a burst of load hits both
            for _ in range(rounds):
                walls = {}
                for label, kw in (*local.items(), (name, {"client": client})):
                    res, walls[label], cpu = _timed_sweep(vset, ff, n, **kw)
                    assert np.array_equal(res.seek_times, ref.seek_times)
                    w0, c0 = best.get(label, (float("inf"), float("inf")))
                    best[label] = (min(w0, walls[label]), min(c0, cpu))
                    paired[name, label] = min(paired.get((name, label), np.inf), walls[label])
                    out[f"{label}_chunk_size"] = res.chunk_size
                if name in same_cores:
                    ratio = walls[name] / walls[same_cores[name]]
                    rounds_ratio.setdefault(name, []).append(ratio)
            if name == "dask_1_worker":
                out["dask_1_worker_outside_tasks_s"] = _outside_tasks(vset, ff, n, client)
                if n_large:
                    _large_pair(vset, ff, n_large, rounds, client, best)
        finally:
            client.close()
            if proc is not None:
                proc.stdin.close()
                proc.wait(timeout=60)
    for name, (wall, cpu) in best.items():
        out[f"{name}_s"], out[f"{name}_cpu_s"] = wall, cpu
    for name, label in same_cores.items():
        key = f"{name}_over_{label}"
        out[f"{label}_while_{name}_s"] = paired[name, label]
        out[key] = paired[name, name] / paired[name, label]
        out[f"{key}_median_of_rounds"] = float(np.median(rounds_ratio[name]))
    out["dask_2_workers_speedup_vs_1_worker"] = out["dask_1_worker_s"] / out["dask_2_workers_s"]
    if n_large:
        out["large_variants"] = n_large
        out["large_dask_1_worker_over_in_process_1_thread"] = (
            out["large_dask_1_worker_s"] / out["large_in_process_1_thread_s"]
        )
    out["same_numbers"] = True
    return out


def _outside_tasks(vset, ff, n: int, client) -> float:
    """Wall seconds of one Dask sweep of ``n`` variants spent outside its tasks'
    execution on the workers (submission, dispatch, result transfer, the client's draw
    of the worst plant), from Dask's task stream; with one worker the tasks run one
    after another, so this is the fixed cost a sweep pays over in-process."""
    from distributed import get_task_stream

    with get_task_stream(client) as stream:
        t0 = time.perf_counter()
        sweep_mod.sweep_seek_times(vset, ff, 10.0, n=n, seed=2026, client=client)
        wall = time.perf_counter() - t0
    busy = sum(
        ss["stop"] - ss["start"]
        for task in stream.data
        for ss in task["startstops"]
        if ss["action"] == "compute"
    )
    return wall - busy


def _large_pair(vset, ff, n: int, rounds: int, client, best: dict) -> None:
    """``n`` variants in-process on one thread and on the 1-worker ``client``, in turn;
    the best wall/CPU of each into ``best`` (labels ``large_*``)."""
    ref = None
    for _ in range(rounds):
        for label, kw in (("large_in_process_1_thread", {"threads": 1}),
                          ("large_dask_1_worker", {"client": client})):  # fmt: skip
            res, wall, cpu = _timed_sweep(vset, ff, n, **kw)
            ref = res.seek_times if ref is None else ref
            assert np.array_equal(res.seek_times, ref)
            w0, c0 = best.get(label, (float("inf"), float("inf")))
            best[label] = (min(w0, wall), min(c0, cpu))


if __name__ == "__main__":
    import sys

    sizes = tuple(int(float(a)) for a in sys.argv[1:]) or (100_000,)
    for k, v in sweeps(sizes).items():
        print(f"  {k:45s} {v:.4g}" if isinstance(v, float) else f"  {k:45s} {v}", flush=True)
