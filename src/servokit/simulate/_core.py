"""The simulation kernel of :func:`servokit.simulate.simulate` for one chunk of variants.

The plant state is advanced once per sampling period ``Ts = S h`` (``S`` fine steps):

    x[k+1] = Phi^S x[k] + sum_s B2[s] w_k[s],

``w_k`` being the ``2S`` delayed inputs that act during period ``k`` (the new and the
old input of each fine step, see :class:`PlantBank`) and ``B2[s] = Phi^(S-1-s) G``.
The outputs between samples are then produced for all periods at once: the free
response ``C Phi^i x[k]`` of the stored sample states (one batched matrix product)
plus the forced response of the inputs inside the period (a ``2S``-tap convolution,
one GEMM for all variants when the input is shared).  Periods whose input window is
all zero (after a feedforward seek has ended) are skipped in both products.
Everything per mode is written elementwise on ``(V, M)`` arrays: numpy's stacked
``matmul`` over thousands of 2x2 blocks costs far more than the arithmetic.
"""

from __future__ import annotations

import numpy as np

from servokit.simulate._bank import PlantBank
from servokit.simulate._scan import modal_scan

__all__ = ["run_chunk"]

StateSpace = tuple[np.ndarray, np.ndarray, np.ndarray, float]


def _windows(ubuf: np.ndarray, S: int, lo: int, hi: int) -> np.ndarray:
    """Delayed inputs of periods lo..hi-1 as (Vu, hi-lo, 2S): new then old."""
    Vu = ubuf.shape[0]
    w_new = ubuf[:, lo * S + 1 : hi * S + 1].reshape(Vu, hi - lo, S)
    w_old = ubuf[:, lo * S : hi * S].reshape(Vu, hi - lo, S)
    return np.concatenate([w_new, w_old], axis=2)


def _active(ubuf: np.ndarray, S: int, K: int) -> slice:
    """Periods from the first to the last whose input window is not all zero.

    Period ``k`` reads ``ubuf[:, kS : kS + S + 1]`` (see :func:`_windows`).
    """
    nz = np.flatnonzero(np.any(ubuf[:, : K * S + 1] != 0.0, axis=0))
    if nz.size == 0:
        return slice(0, 0)
    first = max(0, -(-int(nz[0]) // S) - 1)
    last = min(K - 1, int(nz[-1]) // S)
    return slice(first, last + 1)


def _forced_output(H2: np.ndarray, W: np.ndarray, S: int) -> np.ndarray:
    """Output inside each period due to its own inputs: (V, n, S) from W (Vu, n, 2S)."""
    V = H2.shape[0]
    idx = np.arange(S)
    n = W.shape[1]
    Wp = np.concatenate([np.zeros((W.shape[0], n, 1)), W], axis=2)  # leading zero pad
    if W.shape[0] == 1 and V > 1:
        # shared input: its per-period Toeplitz Wt[l, k, i] = w[k, i-1-l] is built once
        # (for one variant the (2S, S) Toeplitz of its impulse response below is smaller)
        lag = np.clip(idx[None, :] - idx[:, None], 0, None)  # [l, i] -> i - l (0 = pad)
        Wt_new = Wp[0][:, lag].transpose(1, 0, 2)  # (S, n, S)
        Wt_old = Wp[0][:, S + lag].transpose(1, 0, 2)
        Wt_old[(lag == 0)[:, None, :].repeat(n, axis=1)] = 0.0
        Wt = np.concatenate([Wt_new, Wt_old], axis=0).reshape(2 * S, n * S)
        return (H2 @ Wt).reshape(V, n, S)
    lag = np.clip(idx[:, None] - idx[None, :], 0, None)  # [i, j] -> i - j (0 if i <= j)
    Hp = np.concatenate([np.zeros((V, 1)), H2[:, :S], np.zeros((V, 1)), H2[:, S:]], axis=1)
    T2 = np.concatenate([Hp[:, lag.T], Hp[:, S + 1 + lag.T]], axis=1)  # (V, 2S, S)
    return Wp[:, :, 1:] @ T2


def run_chunk(
    bank: PlantBank,
    S: int,
    K: int,
    u_open: np.ndarray,
    x0: np.ndarray | None = None,
    dc_samples: np.ndarray | None = None,
    states: np.ndarray | None = None,
    fine: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Open-loop response of one chunk: ``y`` (V, K*S) without output disturbance, ``yd``.

    ``u_open`` is (1, K*S) when shared by every variant, else (V, K*S); ``x0`` is
    (V, M, 2) or None; ``dc_samples`` (1 or V, K) is the output disturbance at the
    sampling instants, included in ``yd``.  ``states`` (V, K, M, 2), when the caller
    already has the modal states at the samples, replaces the time recursion.  With
    ``fine=False`` the outputs between the samples are not formed: ``y`` is then the
    output at the samples (V, K), the same numbers as ``yd`` without ``dc_samples``
    (and ``u_open`` is not read when ``states`` is given).
    """
    V, M = bank.shape
    Nt = K * S
    rows = bank.transition_rows(S)  # entries of Phi^i, (4, S+1, V, M)
    if states is None or (fine and S > 1):
        B2 = bank.block_maps(S)  # (2S, V, 2M)
        Vu = u_open.shape[0]
        # u_j sits at ubuf[:, j + dd + 1]; the plant sees u[j-dd] (new) and u[j-dd-1] (old)
        # (the feedback of a closed loop arrives here as a per-variant input, see _closed)
        dd = bank.dd
        ubuf = np.zeros((Vu, Nt + dd + 1))
        ubuf[:, dd + 1 :] = u_open
        W = _windows(ubuf, S, 0, K)
        act = _active(ubuf, S, K)
    if states is None:
        x0_ = (np.zeros((V, M)), np.zeros((V, M))) if x0 is None else (x0[..., 0], x0[..., 1])
        drive = np.zeros((K, V, M, 2))
        if Vu == 1:  # one GEMM for all variants
            drive[act] = (W[0, act] @ B2.reshape(2 * S, -1)).reshape(-1, V, M, 2)
        else:  # one small GEMM per variant
            per = W[:, act] @ B2.transpose(1, 0, 2)  # (V, n, 2M)
            drive[act] = per.transpose(1, 0, 2).reshape(-1, V, M, 2)
        states = modal_scan(tuple(rows[:, S]), drive, x0_)  # (V, K, M, 2)
    y0 = states[..., 0].sum(axis=-1)
    yd = y0 if dc_samples is None else y0 + dc_samples
    if S == 1 or not fine:  # the inputs of a period act after its sample: the samples
        return y0, yd  # are the output
    # outputs between the samples: free response of the stored states + forced response
    CPt = np.empty((V, M, 2, S))  # C Phi^i, contiguous so that matmul runs in BLAS
    CPt[:, :, 0] = rows[0, :S].transpose(1, 2, 0)
    CPt[:, :, 1] = rows[1, :S].transpose(1, 2, 0)
    y = np.ascontiguousarray(states).reshape(V, K, 2 * M) @ CPt.reshape(V, 2 * M, S)
    # impulse responses C Phi^l G (l = 0..S-1) summed over modes: the reversed first
    # state component of the block maps
    H2 = B2.reshape(2, S, V, M, 2)[:, ::-1, :, :, 0].sum(axis=-1)  # (2, S, V)
    H2 = H2.transpose(2, 0, 1).reshape(V, 2 * S)
    y[:, act] += _forced_output(H2, W[:, act], S)
    return y.reshape(V, Nt), yd
