"""Constrained FSC QP: the default path (``qp="auto"``: banded sparse QP or dense, as
chosen) against the dense lifted QP (``qp="dense"``), N = 100 ... 3000, on two problems:

* ``banded``: the HDD benchmark plant with the Table 2.4 band weights (1-track column,
  240 band frequencies), |u| <= 0.8 x the unconstrained FFSC's peak (issue 24);
* ``rigid``: a rigid body, 1 unit in 3 s, |u| <= 0.6, |v| <= 0.5, no bands (issue 8).

Per N: both times (best of ``repeat``), their ratio, the largest difference of the jerk
inputs relative to the dense one's peak, and the relative cost difference.
"""

from __future__ import annotations

import time

import numpy as np
from _timing import best_time

from servokit.feedforward import InputLimit, VelocityLimit, fsc_input
from servokit.models import HDD_BENCHMARK_TS, ModalPlant, Mode, hdd_benchmark

STEPS = (100, 300, 1000, 3000)


def _problem(kind: str, N: int):
    """(plant, dt, keyword arguments of fsc_input) of one benchmark problem."""
    if kind == "rigid":
        plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
        return plant, 3.0 / N, {"constraints": [InputLimit(0.6), VelocityLimit(0.5)]}
    from servokit.cases.hdd_seek import table_2_4_weights

    plant, bands = hdd_benchmark(), table_2_4_weights(1)
    free = fsc_input(plant, HDD_BENCHMARK_TS, N, 1.0, band_weights=bands)
    cons = [InputLimit(0.8 * float(np.abs(free.u).max()))]
    return plant, HDD_BENCHMARK_TS, {"band_weights": bands, "constraints": cons}


def _cost(kind: str, N: int, dt: float, kw: dict, jerk: np.ndarray) -> float:
    from servokit.feedforward.ffsc import _band_rows

    Wb = _band_rows(dt, N, [tuple(b) for b in kw.get("band_weights", [])])
    return float(jerk @ jerk / N + (0.0 if Wb is None else np.sum((Wb @ jerk) ** 2)))


def compare(kind: str, N: int, repeat: int = 2) -> dict:
    """Default vs dense path on one problem at N steps (times, ratio, agreement)."""
    plant, dt, kw = _problem(kind, N)

    def run(qp: str):
        return fsc_input(plant, dt, N, 1.0, qp=qp, **kw)

    if N >= 1000:  # one timed run each (the dense path takes minutes at N = 3000)
        t0 = time.perf_counter()
        auto = run("auto")
        t_auto = time.perf_counter() - t0
        t0 = time.perf_counter()
        dense = run("dense")
        t_dense = time.perf_counter() - t0
    else:
        auto, dense = run("auto"), run("dense")
        t_auto = best_time(lambda: run("auto"), repeat)
        t_dense = best_time(lambda: run("dense"), repeat)
    c_auto, c_dense = (_cost(kind, N, dt, kw, f.jerk) for f in (auto, dense))
    return {
        "default_s": t_auto,
        "dense_s": t_dense,
        "default_over_dense": t_auto / t_dense,
        "max_relative_difference": float(
            np.max(np.abs(auto.jerk - dense.jerk)) / np.max(np.abs(dense.jerk))
        ),
        "relative_cost_difference": (c_auto - c_dense) / c_dense,
    }


def constrained_fsc(steps: tuple[int, ...] = STEPS) -> dict:
    """Every problem at every N; the worst ratio and difference as the summary."""
    out: dict = {}
    for kind in ("banded", "rigid"):
        for N in steps:
            row = compare(kind, N)
            out.update({f"{kind}_{N}_{k}": v for k, v in row.items()})
    out["worst_default_over_dense"] = max(v for k, v in out.items() if k.endswith("_over_dense"))
    out["max_relative_difference"] = max(
        v for k, v in out.items() if k.endswith("max_relative_difference")
    )
    return out


if __name__ == "__main__":
    import sys

    for kind in sys.argv[1].split(","):
        for N in (int(a) for a in sys.argv[2:]):
            print(kind, N, {k: f"{v:.3g}" for k, v in compare(kind, N).items()}, flush=True)
