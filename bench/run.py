"""Benchmark suite (``make bench``): issue 8's targets measured side by side.

Single thread (BLAS threads pinned before numpy loads), best of several runs, every
ratio from two timings in this process (absolute times vary on a shared machine).
Writes ``out/bench/results.json`` (untracked; ``--out`` to change) and prints a summary
with the targets.

Sections: open-loop simulation of 1000 HDD Monte-Carlo variants (vs python-control's
``forced_response`` and scipy's ``dlsim`` loops, and vs the arithmetic bound: flops of
the modal recursion / measured DGEMM peak), 10^5 variants through ``simulate_metrics``
(peak memory), closed loops (vs python-control ``feedback`` + ``forced_response``), the
constrained FSC QP (default path vs dense, N = 100 ... 3000, banded and unbanded;
issue 24), HDD seek sweeps of 10^5 and 10^6 variants (share outside the simulation) and
their Dask scaling (1 and 2 local workers, an external scheduler; issue 24),
``sampled_data_sensitivity`` over 10^4 frequencies, and ``demo``:
the five original ``make demo`` cases in CPU seconds, against the paths the demo speed-up
replaced (same numbers required), and ``margins``: the IEEJ benchmark loop's full margins
against python-control's ``stability_margins`` (issue 20), and ``admissible``: the
switching-admissible case's O_inf and slices, certificates vs one LP per question.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(1, str(Path(__file__).parent.parent / "tests"))  # the mpmath references

import admissible  # noqa: E402
import demo  # noqa: E402
import margins  # noqa: E402
import numpy as np  # noqa: E402
import qp  # noqa: E402
import sensitivity  # noqa: E402
import simulator  # noqa: E402
import sweep  # noqa: E402

TARGETS = {
    "open_loop.speedup_vs_python_control": (">=", 300.0),
    "open_loop.ratio_to_bound": ("<=", 10.0),
    "many_variants.peak_memory_mb": ("<", 1000.0),
    "many_variants.ratio_to_1000_variant_figure": ("<=", 1.5),
    "closed_loop.speedup": (">=", 30.0),
    "closed_loop.single_plant_speedup": (">=", 5.0),
    "qp.worst_default_over_dense": ("<=", 2.0),
    "qp.max_relative_difference": ("<=", 1e-6),
    "sensitivity.speedup_vs_per_cell": (">=", 5.0),
    "sensitivity.max_relative_difference": ("<=", 1e-10),
    "sweep.n1e6_2_threads_s": ("<", 60.0),
    "sweep.n1e6_2_threads_cpu_s": ("<", 60.0),
    "sweep.n1e5_share_outside_simulation": ("<", 0.5),
    "dask.dask_2_workers_over_in_process_2_threads": ("<=", 1.0),
    "dask.dask_1_worker_over_in_process_1_thread": ("<=", 1.0),
    "dask.large_dask_1_worker_over_in_process_1_thread": ("<=", 1.0),
    "dask.dask_2_workers_speedup_vs_1_worker": (">=", 1.2),
    "demo.total_cpu_s": ("<", 8.0),
    "demo.max_relative_difference": ("<=", 1e-12),
    "margins.speedup_vs_python_control": (">=", 1.0),
    "margins_accuracy.worst_relative_error": ("<=", 1e-9),
    "admissible.speedup": (">=", 3.0),
}


def _check(results: dict) -> list[tuple[str, float, str, float, bool]]:
    rows = []
    for key, (op, target) in TARGETS.items():
        section, name = key.split(".")
        if section not in results or name not in results[section]:
            continue
        v = float(results[section][name])
        ok = {"<=": v <= target, ">=": v >= target, "<": v < target}[op]
        rows.append((key, v, op, target, ok))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="smaller sets (a smoke run)")
    ap.add_argument("--only", nargs="*", help="sections to run (default: all)")
    default_out = Path(__file__).resolve().parent.parent / "out" / "bench" / "results.json"
    ap.add_argument("--out", default=str(default_out))
    args = ap.parse_args()
    q = args.quick
    sections = {
        "open_loop": lambda: simulator.open_loop(200 if q else 1000, 5 if q else 20),
        "many_variants": lambda: simulator.many_variants(10_000 if q else 100_000),
        "closed_loop": lambda: simulator.closed_loop(200 if q else 1000, 10 if q else 40),
        "qp": lambda: qp.constrained_fsc((100, 300) if q else qp.STEPS),
        "sensitivity": lambda: sensitivity.sensitivity(2000 if q else 10_000),
        "sweep": lambda: sweep.sweeps((10_000,) if q else (100_000, 1_000_000)),
        "dask": lambda: sweep.dask_scaling(
            20_000 if q else 100_000, 1 if q else 3, 40_000 if q else 1_000_000
        ),
        "demo": lambda: demo.demo(1 if q else 2),
        "margins": lambda: margins.margins(7 if q else 25),
        "margins_accuracy": margins.accuracy,
        "admissible": admissible.admissible,
    }
    wanted = args.only or list(sections)
    results: dict = {
        "machine": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "processor": platform.processor() or platform.machine(),
            "threads": os.environ["OPENBLAS_NUM_THREADS"],
        }
    }
    for name in wanted:
        print(f"running {name} ...", file=sys.stderr, flush=True)
        results[name] = sections[name]()
    rows = _check(results)
    results["targets"] = {
        k: {"value": v, "op": op, "target": t, "met": ok} for k, v, op, t, ok in rows
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(results, indent=2) + "\n")
    for name in wanted:
        print(f"[{name}]")
        for k, v in results[name].items():
            print(f"  {k:40s} {v:.4g}" if isinstance(v, float) else f"  {k:40s} {v}")
    print("[targets (issues 8, 20 and 24)]")
    for key, v, op, t, ok in rows:
        print(f"  {'met ' if ok else 'MISS'}  {key:48s} {v:10.4g} {op} {t:g}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
