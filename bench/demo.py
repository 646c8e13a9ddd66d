"""``make demo``'s five original cases: CPU seconds with the demo speed-ups and with the
paths they replaced restored (same process, interleaved), and the numbers of both.

The replaced paths, restored by patching module attributes: the damped unobservable grid
evaluated directly on every (row, phase, sample) (``_damped_yu_direct``), the undamped
sample phases sorted again for every phase grid, ``yui`` computed through the full
``unobservable_magnitude`` (with the refinement of ``yuw`` and the minimum), and the
galvano FFSC designs through ``fsc_input``'s default path (the banded QP first).  CPU time
(``time.process_time``) because the machine is shared.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from servokit.cases import galvano_designs, oscillations, registry
from servokit.sampled import _unobservable_grid, unobservable

CASES = ("hdd-seek", "galvano", "hdd-sensitivity", "sampled-oscillations", "hdd-residual")


@contextmanager
def replaced_paths() -> Iterator[None]:
    """The unobservable grids and the galvano designs as before the demo speed-up."""
    full_rms = unobservable.unobservable_magnitude
    unpatched_fsc = galvano_designs.fsc_input

    def rms_via_magnitude(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        return full_rms(*args, **kwargs).rms

    def fsc_default_path(*args, qp="auto", **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        return unpatched_fsc(*args, **kwargs)

    saved = [
        (_unobservable_grid, "_DIRECT_PHASES", 2**62),  # _damped_yu -> _damped_yu_direct
        (_unobservable_grid, "_CACHE_ELEMENTS", -1),  # _UndampedGrid -> _undamped_yu every call
        (unobservable, "unobservable_rms", rms_via_magnitude),
        (oscillations, "unobservable_rms", rms_via_magnitude),
        (galvano_designs, "fsc_input", fsc_default_path),
    ]
    old = [(mod, name, getattr(mod, name)) for mod, name, _ in saved]
    for mod, name, value in saved:
        setattr(mod, name, value)
    try:
        yield
    finally:
        for mod, name, value in old:
            setattr(mod, name, value)


def _numbers(result) -> list[float]:  # noqa: ANN001
    """Every number of a CaseResult (rows, then the extras flattened)."""
    out = [float(c.servokit) for c in result.comparisons]

    def walk(x) -> None:  # noqa: ANN001
        if isinstance(x, dict):
            for v in x.values():
                walk(v)
        elif isinstance(x, list | tuple):
            for v in x:
                walk(v)
        elif isinstance(x, np.ndarray) and x.dtype.kind in "fiu":
            out.extend(x.astype(float).ravel().tolist())
        elif isinstance(x, int | float | np.number) and not isinstance(x, bool):
            out.append(float(x))

    walk(result.extra)
    return out


def _cpu(fn: Callable[[], object]) -> tuple[float, object]:
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def demo(rounds: int = 2, cases: tuple[str, ...] = CASES) -> dict:
    """Per case: CPU seconds (best of ``rounds``, fast and replaced paths interleaved),
    speed-up, and the largest relative difference of its numbers between the two."""
    reg = registry()
    res: dict = {}
    total_fast = total_old = 0.0
    with tempfile.TemporaryDirectory() as tmp:
        reg["hdd-residual"](Path(tmp) / "warm-up")  # fonts, sympy, lazy imports
        for name in cases:
            best_fast = best_old = float("inf")
            for _ in range(rounds):
                t, fast = _cpu(lambda: reg[name](Path(tmp) / "fast"))  # noqa: B023
                best_fast = min(best_fast, t)
                with replaced_paths():
                    t, old = _cpu(lambda: reg[name](Path(tmp) / "old"))  # noqa: B023
                best_old = min(best_old, t)
            a, b = np.array(_numbers(fast)), np.array(_numbers(old))
            both = np.isfinite(a) & np.isfinite(b)
            scale = np.maximum(np.abs(a), np.abs(b))[both]
            diff = np.abs(a - b)[both]
            rel = float(np.max(np.where(scale > 0, diff / np.where(scale > 0, scale, 1), 0)))
            same_nonfinite = bool(np.array_equal(a[~both], b[~both], equal_nan=True))
            key = name.replace("-", "_")
            res[f"{key}_cpu_s"] = best_fast
            res[f"{key}_replaced_cpu_s"] = best_old
            res[f"{key}_speedup"] = best_old / best_fast
            res[f"{key}_max_relative_difference"] = rel if same_nonfinite else float("inf")
            total_fast += best_fast
            total_old += best_old
    res["total_cpu_s"] = total_fast
    res["total_replaced_cpu_s"] = total_old
    res["speedup"] = total_old / total_fast
    res["max_relative_difference"] = max(
        v for k, v in res.items() if k.endswith("_max_relative_difference")
    )
    return res
