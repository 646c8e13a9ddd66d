"""Timing helpers of the benchmark suite: best-of-n wall times, DGEMM peak, peak memory.

The machine is shared, so every figure is the best of several runs and every claim is a
ratio of two timings taken in the same process, close together in time.
"""

from __future__ import annotations

import json
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np


def best_time(fn: Callable[[], Any], repeat: int = 5) -> float:
    """Smallest wall time [s] of ``repeat`` calls (the least disturbed one)."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def interleaved_best(fns: dict[str, Callable[[], Any]], rounds: int = 3) -> dict[str, float]:
    """Best wall time [s] of each function, the functions run in turn ``rounds`` times:
    a burst of load on the shared machine then hits all of them alike."""
    best = dict.fromkeys(fns, float("inf"))
    for _ in range(rounds):
        for name, fn in fns.items():
            best[name] = min(best[name], best_time(fn, 1))
    return best


def dgemm_peak_flops(n: int = 1000, repeat: int = 7) -> float:
    """Single-call DGEMM rate [flop/s] of an n x n product (the machine's arithmetic peak)."""
    rng = np.random.default_rng(0)
    a, b = rng.standard_normal((n, n)), rng.standard_normal((n, n))
    return 2.0 * n**3 / best_time(lambda: a @ b, repeat)


def peak_memory(fn: Callable[[], Any]) -> tuple[Any, float]:
    """Result of ``fn()`` and the peak of memory allocated during it [bytes] (tracemalloc;
    numpy reports its buffers to it)."""
    tracemalloc.start()
    try:
        out = fn()
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    return out, float(peak)


def write_result(name: str, result: Any) -> Path:
    """Write ``result`` as JSON to ``bench/out/NAME.json`` (created); return the path."""
    out = Path(__file__).parent / "out"
    out.mkdir(exist_ok=True)
    path = out / f"{name}.json"
    path.write_text(json.dumps(result, indent=2) + "\n")
    return path

