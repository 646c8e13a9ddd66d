"""Where ``servokit settle evaluate`` spends its time, and the seek simulation before/after.

Two measurements, each in a fresh interpreter (``python bench/settle_phases.py JUDGE``):

1. ``phases``: the incremental wall time of each phase of ``settle evaluate`` (100 seeks):
   the CLI's own imports, ``scipy.stats`` (imported by scikit-learn), the rest of
   scikit-learn, ``skops.io``, loading the judge, simulating, judging.
2. ``seeks``: 100 validation seeks simulated one ``simulate_seeks`` call per seek (the
   CLI's path before it shared the discretisation) and in one pass, with the BLAS thread
   count of the process (run it with ``OPENBLAS_NUM_THREADS=1`` for one thread); the
   states must be identical.

``JUDGE`` is a judge file from ``servokit settle train``. Prints one line per phase.
"""

from __future__ import annotations

import sys
import time


def phases(judge_path: str) -> list[tuple[str, float]]:
    """Incremental seconds of each phase of ``settle evaluate`` (100 seeks)."""
    marks, t0 = [], time.perf_counter()

    def mark(name: str) -> None:
        nonlocal t0
        now = time.perf_counter()
        marks.append((name, now - t0))
        t0 = now

    import servokit.cli  # noqa: F401

    mark("servokit.cli (what --help needs)")
    import scipy.stats  # noqa: F401

    mark("scipy.stats (imported by sklearn.utils.fixes)")
    import sklearn.pipeline  # noqa: F401
    import sklearn.preprocessing  # noqa: F401
    import sklearn.svm  # noqa: F401

    mark("rest of sklearn Pipeline/StandardScaler/SVC")
    import skops.io  # noqa: F401

    mark("skops.io (its import scans all sklearn estimators)")
    from servokit.learn import SettlingJudge, evaluate_judgements, iter_seeks, validation_seeks

    judge = SettlingJudge.load(judge_path)
    mark("SettlingJudge.load (audit + load)")
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # as the CLI simulates
        responses = list(iter_seeks(validation_seeks(100, 1)))
    mark("simulate 100 seeks (one BLAS thread, as the CLI)")
    evaluate_judgements(responses, judge, levels=(0.0, -0.8))
    mark("judge 100 seeks 3 ways")
    return marks


def seeks() -> tuple[float, float, bool]:
    """Seconds for 100 seeks one call per seek and in one pass; identical states?"""
    from servokit.learn import simulate_seeks, validation_seeks

    grid = validation_seeks(100, 1)
    simulate_seeks(grid[:1])  # imports out of the timing
    t = time.perf_counter()
    one_by_one = [r for s in grid for r in simulate_seeks([s])]
    t_old = time.perf_counter() - t
    t = time.perf_counter()
    one_pass = simulate_seeks(grid)
    t_new = time.perf_counter() - t
    same = all((a.states == b.states).all() for a, b in zip(one_by_one, one_pass, strict=True))
    return t_old, t_new, same


if __name__ == "__main__":
    if sys.argv[1:2] == ["seeks"]:
        old, new, same = seeks()
        print(f"one call per seek {old:.3f} s, one pass {new:.3f} s, identical {same}")
    else:
        for name, seconds in phases(sys.argv[1]):
            print(f"{seconds:6.3f} s  {name}")
