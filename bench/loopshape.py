"""FRF-set loop shaping (hdd-loopshape's design, issue 24): CPU of the design and of the
set evaluation, each against the path it replaced, in this process.

``design``: :func:`servokit.feedback.loopshape` on the case's 54 HDD FRFs x 3000 points
(6 steps from the benchmark controller) with the current constraint generation, and with
the one before issue 24's pass (warm rows within 1e-3 of binding, the valleys at
``θ_k`` of every row seeded, every program solved with Clarabel's iterative
refinement): CPU seconds, Clarabel programs, lowest crossover and worst ``‖S‖∞`` of
both. ``evaluate``: ``evaluate_set`` over the 1000 held-out Monte-Carlo loops against
``evaluate_loop`` one loop at a time (the same numbers required).

Run: ``MPLBACKEND=Agg PYTHONPATH=$PWD/src python bench/loopshape.py [--rounds N]``.
Writes ``bench/out/loopshape.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from _timing import write_result

from servokit.cases import loopshape_hdd as case
from servokit.feedback import loopshape_socp as socp
from servokit.feedback.loopshape_eval import evaluate_loop, evaluate_set
from servokit.feedback.loopshape_iterate import loopshape
from servokit.feedback.loopshape_problem import (
    fixed_order_structure,
    model_frfs,
    model_resonances,
    packed_grid,
)
from servokit.models import (
    HDD_BENCHMARK_TS,
    benchmark_controller,
    hdd_benchmark_variants,
    hdd_benchmark_variation_set,
)

DT = HDD_BENCHMARK_TS


def _cpu(fn: Callable[[], Any]) -> tuple[Any, float]:
    """Result and CPU seconds of ``fn()``."""
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def _before(mp: dict) -> None:
    """Set (``mp`` empty) or restore the constraint generation before issue 24's pass."""
    names = ("WARM_SLACK", "PROGRAM_FEAS", "_unseen")
    if not mp:
        mp.update({k: getattr(socp, k) for k in names})
        socp.WARM_SLACK, socp.PROGRAM_FEAS = 1e-3, None  # every program refined
        socp._unseen = lambda d, lin, warm: np.ones(lin.b.size, dtype=bool)
    else:
        for k, v in mp.items():
            setattr(socp, k, v)
        mp.clear()


def design(rounds: int = 2) -> dict:
    """The hdd-loopshape design, current and previous generation, alternately."""
    plants = hdd_benchmark_variants()
    f = packed_grid(DT, model_resonances(plants, DT), n_freq=case.N_FREQ)
    P = np.concatenate([g * model_frfs(plants, DT, f) for g in case.GAINS])
    c0 = benchmark_controller()
    s_max = evaluate_set(
        f, P, np.asarray(c0(np.exp(2j * np.pi * f * DT))).ravel(), DT, n_integrators=3
    ).worst_s_peak_db
    solve, calls = socp._solve, [0]

    def counted(*args, **kwargs):
        calls[0] += 1
        return solve(*args, **kwargs)

    def run():
        calls[0] = 0
        res = loopshape(
            f,
            P,
            DT,
            s_max_db=s_max,
            structure=fixed_order_structure(case.ORDER),
            initial=c0,
            max_iter=case.STEPS,
            time_limit_s=900.0,
        )
        return res, calls[0]

    out: dict[str, Any] = {}
    socp._solve = counted
    saved: dict = {}
    try:
        for _ in range(rounds):
            for name in ("now", "before"):
                if name == "before":
                    _before(saved)
                try:
                    (res, n), cpu = _cpu(run)
                finally:
                    if saved:
                        _before(saved)
                best = out.get(name, {}).get("cpu_s", np.inf)
                out[name] = {
                    "cpu_s": min(best, cpu),
                    "programs": n,
                    "min_crossover_hz": res.table.min_crossover_hz,
                    "worst_s_peak_db": res.table.worst_s_peak_db,
                }
    finally:
        socp._solve = solve
    out["speedup"] = out["before"]["cpu_s"] / out["now"]["cpu_s"]
    out["crossover_rel_change"] = abs(
        out["now"]["min_crossover_hz"] / out["before"]["min_crossover_hz"] - 1.0
    )
    out["s_bound_db"] = s_max
    return out


def evaluate(rounds: int = 3) -> dict:
    """``evaluate_set`` on the 1000 held-out loops vs ``evaluate_loop`` per loop."""
    vs = dataclasses.replace(hdd_benchmark_variation_set(), gain=(-0.05, 0.05))
    plants = vs.monte_carlo(case.HELD_OUT, seed=case.SEED)
    f = packed_grid(DT, model_resonances(hdd_benchmark_variants(), DT), n_freq=case.N_FREQ)
    P = model_frfs(plants, DT, f, method="blocks")
    K = np.asarray(benchmark_controller()(np.exp(2j * np.pi * f * DT))).ravel()
    best = {"set_s": np.inf, "per_loop_s": np.inf}
    for _ in range(rounds):
        tab, t_set = _cpu(lambda: evaluate_set(f, P, K, DT, n_integrators=3))
        rows, t_one = _cpu(lambda: [evaluate_loop(f, p * K, DT, n_integrators=3) for p in P])
        best = {"set_s": min(best["set_s"], t_set), "per_loop_s": min(best["per_loop_s"], t_one)}
    same = [r.to_dict() for r in tab.rows] == [r.to_dict() for r in rows]
    return {
        **best,
        "speedup": best["per_loop_s"] / best["set_s"],
        "same_numbers": same,
        "loops": int(P.shape[0]),
    }


def main() -> None:
    """Print and write both sections."""
    from threadpoolctl import threadpool_limits

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    with threadpool_limits(limits=1):
        result = {"design": design(args.rounds), "evaluate": evaluate(args.rounds + 1)}
    for section, values in result.items():
        print(section, {k: (round(v, 6) if isinstance(v, float) else v) for k, v in values.items()})
    write_result("loopshape", result)


if __name__ == "__main__":
    main()
