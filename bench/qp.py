"""Constrained FSC QP benchmark (the sparse formulation is not in yet)."""

from __future__ import annotations


def constrained_fsc(N: int) -> dict:
    return {"N": N, "status": "sparse formulation not implemented yet"}
