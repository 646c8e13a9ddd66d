"""CPU of the parts changed by reproduce_cases_d.md, old path vs new path (issue 24, item 3).

In one process, one BLAS thread, best of three (``time.process_time``); every pair also
checks that both paths give the same arrays.  Writes ``bench/out/cases_d_parts.json``.

Run: ``MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 PYTHONPATH=$PWD/src python bench/cases_d_parts.py``.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from _timing import write_result


def _best(fn: Callable[[], Any], n: int = 3) -> float:
    out = []
    for _ in range(n):
        t = time.process_time()
        fn()
        out.append(time.process_time() - t)
    return min(out)


def _pair(name: str, old: Callable[[], Any], new: Callable[[], Any], result: dict) -> None:
    a, b = old(), new()
    same = all(
        np.asarray(x).tobytes() == np.asarray(y).tobytes() for x, y in zip(a, b, strict=True)
    )
    result[name] = {"old_s": _best(old), "new_s": _best(new), "same": bool(same)}
    print(f"{name}: {result[name]['old_s']:.4f} s -> {result[name]['new_s']:.4f} s (same: {same})")


def _robust_seek(result: dict) -> None:
    from servokit.cases.robust_seek import held_out_arrays, held_out_plants
    from servokit.models import hdd_benchmark_variants, without_delay
    from servokit.seek.hdd import BAND, DESIGNS
    from servokit.simulate import metrics, seek_time
    from servokit.simulate.metrics import seek_time_of_arrays

    nominal = without_delay(hdd_benchmark_variants())[0]
    ffs = [(d.design(nominal), d.tracks) for d in DESIGNS]
    ffs += ffs[:2]  # six calls, as in the case

    def old():
        plants = held_out_plants()
        return [seek_time(plants, ff, tr, band=BAND) for ff, tr in ffs]

    def new():
        metrics._bank_memo.clear()  # the case's first call builds the bank
        arrays = held_out_arrays()
        return [seek_time_of_arrays(arrays, 0.0, ff, tr, band=BAND) for ff, tr in ffs]

    _pair("hdd-robust-seek held-out seek times", old, new, result)


def _loopshape(result: dict) -> None:
    from servokit.feedback.loopshape_iterate import certify_banks, certify_models
    from servokit.feedback.loopshape_problem import (
        bank_frfs,
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
    from servokit.models.variation_arrays import modal_arrays_from_draws
    from servokit.simulate._bank import PlantBank

    dt = HDD_BENCHMARK_TS
    f = packed_grid(dt, model_resonances(hdd_benchmark_variants(), dt), n_freq=3000)
    c = benchmark_controller()
    vs = dataclasses.replace(hdd_benchmark_variation_set(), gain=(-0.05, 0.05))

    def old():
        plants = vs.monte_carlo(1000, seed=2026)
        frfs = model_frfs(plants, dt, f, method="blocks")
        return frfs, certify_models(c, plants), certify_models(c, plants)

    def new():
        modal = modal_arrays_from_draws(vs, *vs.draw(1000, seed=2026))
        banks = [(np.arange(1000), PlantBank.from_arrays(*modal, vs.nominal.delay, dt))]
        z = np.exp(2j * np.pi * f * dt)
        return (
            bank_frfs(banks, 1000, z),
            certify_banks(c, banks, 1000),
            certify_banks(c, banks, 1000),
        )

    _pair("hdd-loopshape held-out FRFs + 2 certifications", old, new, result)


def _matching(result: dict) -> None:
    import control

    from servokit.feedback.rootlocus import _gains_polys, _match_loop, _match_run, _roots_rows

    g = control.tf([1.0, 3.0], np.polymul(np.poly([-1.0, -2.0, -2.0, -5.0]), [1.0, 0.06, 9.0]))
    _, polys, nd, _ = _gains_polys(g, np.geomspace(1e-3, 1e4, 800))
    rows, prev = _roots_rows(polys[1:]), np.roots(nd)
    _pair(
        "root-locus matching, 800 gains",
        lambda: _match_loop(prev, rows),
        lambda: _match_run(prev, rows),
        result,
    )


def _pes(result: dict) -> None:
    from servokit.cases.hdd_pes import (
        CASE_FILTER,
        loop_report,
        peak_filtered_controller,
        variants_discretized,
    )
    from servokit.feedback.factor_response import clear_factor_cache
    from servokit.models import (
        HDD_BENCHMARK_TS,
        BenchmarkDisturbances,
        benchmark_controller,
        hdd_benchmark,
    )

    rec = BenchmarkDisturbances().generate(200, seed=0)
    c0 = benchmark_controller()
    c1 = peak_filtered_controller(c0, hdd_benchmark().discretize(HDD_BENCHMARK_TS), CASE_FILTER)

    def numbers(reports):
        return [
            [r.nrpe_3sigma_percent, r.worst_gain_margin_db, r.worst_phase_margin_deg]
            for r in reports
        ]

    def old():
        clear_factor_cache()
        return numbers([loop_report(c0, rec), loop_report(c1, rec)])

    def new():
        clear_factor_cache()
        plants = variants_discretized()
        return numbers([loop_report(c0, rec, plants), loop_report(c1, rec, plants)])

    _pair("hdd-pes two loop reports", old, new, result)


def main() -> None:
    """Time the four parts and write ``bench/out/cases_d_parts.json``."""
    from threadpoolctl import threadpool_limits

    result: dict[str, dict] = {}
    with threadpool_limits(1):
        for part in (_robust_seek, _loopshape, _matching, _pes):
            part(result)
    write_result("cases_d_parts", result)


if __name__ == "__main__":
    main()
