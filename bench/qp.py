"""Constrained FSC QP, N = 1000 steps, input + velocity limits: the banded (sparse)
formulation vs the dense lifted one it replaces for large N (rigid body, 1 unit in 3 s,
|u| <= 0.6, |v| <= 0.5)."""

from __future__ import annotations

import numpy as np
from _timing import best_time

from servokit.feedforward import InputLimit, VelocityLimit, fsc_input, sparse_qp
from servokit.models import ModalPlant, Mode


def constrained_fsc(N: int) -> dict:
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
    dt = 3.0 / N
    cons = [InputLimit(0.6), VelocityLimit(0.5)]

    def run():
        return fsc_input(plant, dt, N, 1.0, constraints=cons)

    fast = run()
    t_sparse = best_time(run, 3)
    threshold = sparse_qp.SPARSE_MIN_STEPS
    sparse_qp.SPARSE_MIN_STEPS = 10**9  # the dense path, as before issue 8
    try:
        dense = run()
        t_dense = best_time(run, 1)
    finally:
        sparse_qp.SPARSE_MIN_STEPS = threshold
    rel = float(np.max(np.abs(fast.jerk - dense.jerk)) / np.max(np.abs(dense.jerk)))
    return {
        "N": N,
        "sparse_s": t_sparse,
        "dense_s": t_dense,
        "speedup": t_dense / t_sparse,
        "max_relative_difference": rel,
        "peak_input": float(np.abs(fast.u).max()),
    }
