"""Linear recursions ``x[k+1] = A x[k] + d[k]`` over the samples, batched over variants.

Two evaluations of the same sums ``x[k] = A^k x[0] + sum_{j<k} A^(k-1-j) d[j]``:

* serial: one step per sample; each step is a few array operations over all variants,
  the cheapest in arithmetic and the fastest when there are many variants;
* doubling (Hillis-Steele scan): ``log2(K)`` passes ``s[k] += A^(2^j) s[k - 2^j]`` over
  the whole record, ``A^(2^j)`` by squaring; ``log2(K)`` times the arithmetic but a
  fixed number of array operations, the fastest for a few variants (a single plant
  would otherwise pay the per-call overhead of numpy at every sample).

The doubling scan adds the terms in a tree, so its rounding is relative to the largest
partial sum rather than to the current state.  That is harmless for the stable closed
loops it is used for (:func:`matrix_scan`, states agree with the serial scan to ~1e-14)
but not for an open-loop rigid body driven by an accelerate/decelerate input, whose
position is a sum of large cancelling terms (1e-11 observed): the modal open-loop scan
(:func:`modal_scan`) is therefore always serial.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DOUBLING_MAX_VARIANTS", "matrix_scan", "modal_scan"]

#: Chunks with at most this many variants use the doubling scan.
DOUBLING_MAX_VARIANTS = 8


def modal_scan(
    P: tuple[np.ndarray, ...], drive: np.ndarray, x0: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """States ``x[0..K-1]`` (V, K, M, 2) of 2x2 modal recursions, elementwise over (V, M).

    ``P = (p00, p01, p10, p11)`` each (V, M); ``drive`` (K, V, M, 2); ``x0`` the two
    state components (V, M).  Serial (see the module docstring).
    """
    K, V, M, _ = drive.shape
    p00, p01, p10, p11 = P
    xs = np.empty((V, K, M, 2))
    a, b = x0
    for k in range(K):
        xs[:, k, :, 0], xs[:, k, :, 1] = a, b
        a, b = p00 * a + p01 * b + drive[k, ..., 0], p10 * a + p11 * b + drive[k, ..., 1]
    return xs


def matrix_scan(A: np.ndarray, drive: np.ndarray, method: str | None = None) -> np.ndarray:
    """States ``z[0..K-1]`` (V, K, N) of ``z[k+1] = A z[k] + drive[k]``, ``z[0] = 0``.

    ``A`` is (V, N, N) and ``drive`` (K, V, N).  ``method``: "serial" or "doubling";
    by default doubling for at most :data:`DOUBLING_MAX_VARIANTS` variants.
    """
    K, V, N = drive.shape
    if method is None:
        method = "doubling" if V <= DOUBLING_MAX_VARIANTS else "serial"
    if method == "serial":
        # rows times A^T, written in place: no fresh (page-faulting) buffer per step
        AT = np.ascontiguousarray(A.transpose(0, 2, 1))
        zs = np.empty((K, V, 1, N))
        zs[0] = 0.0
        for k in range(K - 1):
            np.matmul(zs[k], AT, out=zs[k + 1])
            zs[k + 1, :, 0] += drive[k]
        return zs[:, :, 0].transpose(1, 0, 2)
    s = np.zeros((V, N, K))
    s[:, :, 1:] = drive[: K - 1].transpose(1, 2, 0)
    off, Ap = 1, A
    while off < K:
        s[:, :, off:] += Ap @ s[:, :, :-off]  # right side evaluated before the update
        Ap = Ap @ Ap
        off *= 2
    return s.transpose(0, 2, 1)
