"""Benchmark of issue 13 (``make bench``): robust minimum-time design and a large sweep.

1. The 10-track robust design on the 18 HDD plants (N scan and settle bisection included),
   at Design 2's peak input, against the book's way of choosing N for Design 2 (an FFSC
   design and an 18-plant simulation per N, ``choose_N`` over N = 12..33) run in the same
   process: absolute seconds and their ratio.  The same design with every feasibility LP
   a fresh ``scipy.optimize.linprog`` (the kept HiGHS model switched off, issue 24): CPU
   seconds of both, best of 3, and whether the designs are the same arrays.
2. A seek-time sweep of ``--variants`` Monte-Carlo plants (Table 2.3 ranges) in chunks:
   seconds, plants per second and peak traced memory (tracemalloc), which stays at about
   one chunk whatever the number of plants.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
import tracemalloc

import numpy as np

from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark_variants, hdd_benchmark_variation_set
from servokit.seek import DESIGNS, choose_N, robust_minimum_time, search_range, sweep_seek_times


def best_of(n: int, fn):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def cpu_best_of(n: int, fn):
    times = []
    for _ in range(n):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return min(times), out


def kept_vs_fresh(design) -> dict:
    """CPU [s] of ``design()`` with the kept HiGHS feasibility model and without it."""
    from servokit.seek import _highs_feasibility as hf

    t_kept, d_kept = cpu_best_of(3, design)
    core = hf._core
    hf._core = lambda: None  # no binding: every feasibility LP a fresh linprog
    try:
        t_fresh, d_fresh = cpu_best_of(3, design)
    finally:
        hf._core = core
    same = np.array_equal(d_kept.u, d_fresh.u) and np.array_equal(
        d_kept.seek_times, d_fresh.seek_times
    )
    return {"kept_cpu_s": t_kept, "fresh_cpu_s": t_fresh, "same_design": bool(same)}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    plants = [p.replace(delay=0.0) for p in hdd_benchmark_variants()]
    d2 = DESIGNS[3]  # Design 2, 10 tracks
    ff2 = d2.design(plants[0])
    u_max = float(np.abs(ff2.u).max())
    t_rob, rob = best_of(
        3, lambda: robust_minimum_time(plants, HDD_BENCHMARK_TS, 10.0, band=0.1, u_max=u_max)
    )
    t_base, _ = best_of(
        3,
        lambda: choose_N(
            plants,
            HDD_BENCHMARK_TS,
            10.0,
            search_range(10.0),
            band_weights=d2.band_weights(),
            model="rigid-body",
        ),
    )
    kept = kept_vs_fresh(
        lambda: robust_minimum_time(plants, HDD_BENCHMARK_TS, 10.0, band=0.1, u_max=u_max)
    )
    vset = dataclasses.replace(hdd_benchmark_variation_set(), gain=(0.0, 0.0))
    tracemalloc.start()
    t0 = time.perf_counter()
    sweep = sweep_seek_times(vset, ff2, 10.0, n=args.variants, seed=2026)
    t_sweep = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    out = {
        "robust_10_track_design_s": t_rob,
        "robust_N": rob.N,
        "robust_n_lp": rob.n_lp,
        "choose_N_design_2_s": t_base,
        "ratio_robust_over_choose_N": t_rob / t_base,
        "robust_kept_model_cpu_s": kept["kept_cpu_s"],
        "robust_fresh_linprog_cpu_s": kept["fresh_cpu_s"],
        "robust_kept_same_design": kept["same_design"],
        "sweep_variants": args.variants,
        "sweep_s": t_sweep,
        "sweep_plants_per_s": args.variants / t_sweep,
        "sweep_chunk_size": sweep.chunk_size,
        "sweep_chunk_estimate_mb": sweep.chunk_mb,
        "sweep_peak_memory_mb": peak / 1e6,
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print("Robust minimum-time seek (issue 13), HDD benchmark, 10 tracks, 18 plants")
    print(f"  robust LP design (N scan) : {t_rob:8.3f} s  (N = {rob.N}, {rob.n_lp} LPs)")
    print(f"  choose_N for Design 2     : {t_base:8.3f} s  (ratio {t_rob / t_base:.2f})")
    print(
        f"  feasibility LPs, CPU      : kept HiGHS model {kept['kept_cpu_s']:.3f} s, fresh "
        f"linprog {kept['fresh_cpu_s']:.3f} s (ratio "
        f"{kept['fresh_cpu_s'] / kept['kept_cpu_s']:.2f}, same design: {kept['same_design']})"
    )
    print(
        f"  sweep of {args.variants} plants   : {t_sweep:8.3f} s  "
        f"({args.variants / t_sweep:.0f} plants/s, chunks of {sweep.chunk_size}, "
        f"peak memory {peak / 1e6:.0f} MB)"
    )


if __name__ == "__main__":
    main()
