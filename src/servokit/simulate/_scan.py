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

__all__ = ["DOUBLING_MAX_VARIANTS", "POWER_GROWTH", "balance", "matrix_scan", "modal_scan"]

#: Chunks with at most this many variants use the doubling scan.
DOUBLING_MAX_VARIANTS = 8
#: Largest rounding growth ``||A|| ||A^(j-1)|| / ||A^j||`` that :func:`forced_outputs`
#: accepts inside its blocks (else it halves the block; after balancing, the HDD PES
#: loops measure 5-8).
POWER_GROWTH = 16.0


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


def forced_outputs(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, u: np.ndarray, block: int = 64
) -> np.ndarray:
    """Outputs ``y[k] = C x[k] + D u[k]`` of ``x[k+1] = A x[k] + B u[k]``, ``x[0] = 0``.

    python-control's discrete ``forced_response`` (``scipy.signal.dlsim``: one Python
    step per sample) for one system, in blocks of ``L <= block`` samples (``block``
    halved in a non-normal basis, :func:`_accurate_block`; ``A`` balanced first): the
    states at
    the block starts by ``x[(b+1)L] = A^L x[bL] + [A^(L-1) B ... B] u_b`` (one step per
    block), the outputs inside every block at once from them and the block's inputs,
    ``y_b = [C A^j] x[bL] + T u_b + D u_b`` with ``T`` the lower block-Toeplitz matrix of
    the Markov parameters ``C A^k B``.  The same sums grouped differently: for a stable
    system the outputs agree with the step-by-step recursion to rounding (1e-11 of the
    largest output times cond(T)/100 in a basis T, ~1e-13 for the PES loop;
    tests/test_numpy_loops.py).  The rounding
    of ``A^L`` enters every block, which a defective eigenvalue on the unit circle (a
    rigid body in open loop) amplifies: ~1e-10 after 700 samples; use it for stable loops.

    Parameters
    ----------
    A, B, C, D : ndarray
        ``N x N``, ``N x m``, ``p x N``, ``p x m``.
    u : ndarray (K, m)
        Inputs, one row per sample.
    block : int
        Samples per block.

    Returns
    -------
    ndarray (K, p)
    """
    K, m = u.shape
    N, p = A.shape[0], C.shape[0]
    # an exact similarity (powers of 2) that evens out the rows and columns of A: a badly
    # scaled loop (the PES loop's ||A|| = 1e5 with a spectral radius below 1) becomes
    # ||A|| = 6 (fewer digits lost, and full blocks below)
    A, scale = balance(A)
    B, C = B / scale[:, None], C * scale[None, :]
    L = max(1, min(int(block), K))
    powers = np.empty((L + 1, N, N))
    powers[0] = np.eye(N)
    for j in range(1, L + 1):
        powers[j] = A @ powers[j - 1]
    L = _accurate_block(A, powers, L)
    powers = powers[: L + 1]
    nb = -(-K // L)
    padded = np.zeros((nb * L, m))
    padded[:K] = u
    ub = padded.reshape(nb, L * m)  # row b: u[bL], ..., u[bL + L - 1]
    apb = powers[:L] @ B  # A^k B, (L, N, m)
    markov = C @ apb  # C A^k B, (L, p, m)
    j, i = np.tril_indices(L, -1)
    toeplitz = np.zeros((L, p, L, m))
    toeplitz[j, :, i, :] = markov[j - 1 - i]
    reach = apb[::-1].transpose(1, 0, 2).reshape(N, L * m)  # [A^(L-1) B, ..., B]
    drive = ub @ reach.T
    starts = np.empty((nb, N))
    x, a_l = np.zeros(N), powers[L]
    for b in range(nb):
        starts[b] = x
        x = a_l @ x + drive[b]
    y = starts @ (C @ powers[:L]).reshape(L * p, N).T + ub @ toeplitz.reshape(L * p, L * m).T
    return y.reshape(nb * L, p)[:K] + u @ D.T


def _accurate_block(A: np.ndarray, powers: np.ndarray, L: int) -> int:
    """The largest ``L' = L / 2^i`` whose products of powers of ``A`` keep the recursion's digits.

    The block form multiplies by ``A^j`` precomputed; the recursion by ``A`` ``j`` times.
    In a strongly non-normal basis (``||A||`` far above ``||A^j||``) the first loses
    about ``g_j = ||A|| ||A^(j-1)|| / ||A^j||`` times more than the second: with
    ``||A|| = 916`` and ``||A^2|| = 1208``, 2-sample blocks were 600 times further from
    a long-double recursion than the recursion itself (tests/test_numpy_loops.py).
    ``L`` is halved until every ``g_j, j <= L`` is at most :data:`POWER_GROWTH` (1 is
    the recursion itself).
    """
    with np.errstate(all="ignore"):
        norms = np.linalg.norm(powers[: L + 1], axis=(1, 2))
        growth = norms[1] * norms[:-1] / norms[1:]  # g_j for j = 1..L
    # nilpotent powers (exact zeros) lose nothing; NaN (overflow) fails the test
    worst = np.maximum.accumulate(np.where(norms[1:] == 0.0, 1.0, growth))
    ok = np.flatnonzero(worst <= POWER_GROWTH)
    while L > 1 and (ok.size == 0 or ok[-1] + 1 < L):
        L //= 2
    return L


def balance(A: np.ndarray, sweeps: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """``D^-1 A D`` with ``D = diag(scale)`` of powers of 2 evening out rows and columns.

    The scaling step of LAPACK's ``gebal`` (``scipy.linalg.matrix_balance`` without
    permutations), in numpy because the PES and seek commands run without SciPy
    (issue 23): state ``i`` is scaled by the power of 2 nearest
    ``sqrt(||row i|| / ||column i||)`` (off-diagonal 2-norms) while that shrinks
    ``||row|| + ||column||`` by 5 %, sweeping until nothing changes.  Powers of 2 make the
    similarity exact in floating point; the diagonal is unchanged.

    Parameters
    ----------
    A : ndarray (N, N)
        Square matrix.
    sweeps : int
        Most passes over the states.

    Returns
    -------
    A_balanced : ndarray (N, N)
        ``D^-1 A D``.
    scale : ndarray (N,)
        The diagonal of ``D`` (so ``B -> B / scale[:, None]``, ``C -> C * scale``).
    """
    A = np.array(A, dtype=float)
    n = A.shape[0]
    scale = np.ones(n)
    off = ~np.eye(n, dtype=bool)
    for _ in range(sweeps):
        changed = False
        for i in range(n):
            c = float(np.linalg.norm(A[off[:, i], i]))
            r = float(np.linalg.norm(A[i, off[i]]))
            if c == 0.0 or r == 0.0 or not np.isfinite(c + r):
                continue
            f = 2.0 ** round(0.5 * np.log2(r / c))
            if f != 1.0 and c * f + r / f < 0.95 * (c + r):
                A[:, i] *= f
                A[i, :] /= f
                scale[i] *= f
                changed = True
        if not changed:
            break
    return A, scale
