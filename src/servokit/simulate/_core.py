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

from dataclasses import dataclass

import numpy as np

from servokit.simulate._bank import PlantBank

__all__ = ["Loop", "run_chunk"]

StateSpace = tuple[np.ndarray, np.ndarray, np.ndarray, float]


@dataclass(frozen=True)
class Loop:
    """Digital feedback ``u_fb = C(z) (r - yd)``, optionally up-sampled by ``m`` through ``F``."""

    controller: StateSpace
    reference: np.ndarray  # (K,)
    m: int = 1
    filt: StateSpace | None = None


def _block_maps(rows: np.ndarray, bank: PlantBank, S: int) -> np.ndarray:
    """``B2`` (2S, V, 2M): effect of each delayed input of a period on the end state.

    ``B2[s] = Phi^(S-1-s) Gnew`` for the new inputs (``s < S``), ``Phi^(2S-1-s) Gold``
    for the old ones, written with the entries of ``Phi^i`` (:meth:`transition_rows`).
    Input-major, so that a shared input drives all variants with one GEMM.
    """
    V, M = bank.shape
    p00, p01, p10, p11 = rows[:, S - 1 :: -1] if S > 1 else rows[:, :1]
    out = np.empty((2, S, V, M, 2))
    for n, G in enumerate((bank.Gnew, bank.Gold)):
        g0, g1 = G[..., 0], G[..., 1]
        out[n, ..., 0] = p00 * g0 + p01 * g1
        out[n, ..., 1] = p10 * g0 + p11 * g1
    return out.reshape(2 * S, V, 2 * M)


def _windows(ubuf: np.ndarray, S: int, lo: int, hi: int) -> np.ndarray:
    """Delayed inputs of periods lo..hi-1 as (Vu, hi-lo, 2S): new then old."""
    Vu = ubuf.shape[0]
    w_new = ubuf[:, lo * S + 1 : hi * S + 1].reshape(Vu, hi - lo, S)
    w_old = ubuf[:, lo * S : hi * S].reshape(Vu, hi - lo, S)
    return np.concatenate([w_new, w_old], axis=2)


class _Feedback:
    """Controller (and multirate filter) states of all variants, advanced once per period."""

    def __init__(self, loop: Loop, V: int, S: int) -> None:
        self.loop, self.S = loop, S
        self.xc = np.zeros((V, loop.controller[0].shape[0]))
        self.xf = None if loop.filt is None else np.zeros((V, loop.filt[0].shape[0]))

    def step(self, k: int, yk: np.ndarray) -> np.ndarray:
        """Fine-grid feedback input (V, S) over period ``k`` given the sampled output."""
        Ac, Bc, Cc, Dc = self.loop.controller
        e = self.loop.reference[k] - yk
        ufb = self.xc @ Cc + Dc * e
        self.xc = self.xc @ Ac.T + e[:, None] * Bc
        if self.loop.filt is None:
            return np.repeat(ufb[:, None], self.S, axis=1)
        Af, Bf, Cf, Df = self.loop.filt
        m = self.loop.m
        sub = np.empty((yk.size, m))
        inp = ufb  # zero insertion: only the first sub-sample carries the value
        for i in range(m):
            sub[:, i] = self.xf @ Cf + Df * inp
            self.xf = self.xf @ Af.T + inp[:, None] * Bf
            inp = np.zeros_like(ufb)
        return np.repeat(sub, self.S // m, axis=1)


def _forced_output(H2: np.ndarray, W: np.ndarray, S: int) -> np.ndarray:
    """Output inside each period due to its own inputs: (V, n, S) from W (Vu, n, 2S)."""
    V = H2.shape[0]
    idx = np.arange(S)
    n = W.shape[1]
    Wp = np.concatenate([np.zeros((W.shape[0], n, 1)), W], axis=2)  # leading zero pad
    if W.shape[0] == 1:
        # shared input: its per-period Toeplitz Wt[l, k, i] = w[k, i-1-l] is built once
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
    x0: np.ndarray | None,
    loop: Loop | None,
    dc_samples: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulate one chunk; returns ``y`` (V, K*S) without output disturbance, ``yd`` and ``u``.

    ``u_open`` is (1, K*S) when shared by every variant, else (V, K*S); ``x0`` is
    (V, M, 2) or None; ``dc_samples`` (1 or V, K) is the output disturbance at the
    sampling instants, seen by the controller and included in ``yd``.
    """
    V, M = bank.shape
    Nt = K * S
    rows = bank.transition_rows(S)  # entries of Phi^i, (4, S+1, V, M)
    B2 = _block_maps(rows, bank, S)  # (2S, V, 2M)
    p00, p01, p10, p11 = rows[:, S]  # Phi^S, each (V, M)
    Vu = V if loop is not None else u_open.shape[0]
    # u_j sits at ubuf[:, j + dd + 1]; the plant sees u[j-dd] (new) and u[j-dd-1] (old)
    dd = bank.dd
    ubuf = np.zeros((Vu, Nt + dd + 1))
    ubuf[:, dd + 1 :] = u_open
    x0_, x1_ = (np.zeros((V, M)), np.zeros((V, M))) if x0 is None else (x0[..., 0], x0[..., 1])
    xs = np.empty((V, K, M, 2))
    yd = np.empty((V, K))
    fb = None if loop is None else _Feedback(loop, V, S)
    if fb is None:
        W_all = _windows(ubuf, S, 0, K)
        active = np.flatnonzero(np.any(W_all != 0.0, axis=(0, 2)))
        drive = np.zeros((K, V, M, 2))
        if Vu == 1:  # one GEMM for all variants
            drive[active] = (W_all[0, active] @ B2.reshape(2 * S, -1)).reshape(-1, V, M, 2)
        else:
            drive[active] = np.einsum("vks,svq->kvq", W_all[:, active], B2).reshape(-1, V, M, 2)
    else:
        B2v = B2.transpose(1, 0, 2)  # (V, 2S, 2M) for per-variant windows
    for k in range(K):
        xs[:, k, :, 0], xs[:, k, :, 1] = x0_, x1_
        yk = x0_.sum(axis=-1)
        if dc_samples is not None:
            yk = yk + dc_samples[:, k]
        yd[:, k] = yk
        if fb is not None:
            ubuf[:, dd + 1 + k * S : dd + 1 + (k + 1) * S] += fb.step(k, yk)
            inc = (_windows(ubuf, S, k, k + 1) @ B2v).reshape(V, M, 2)
        else:
            inc = drive[k]
        x0_, x1_ = (
            p00 * x0_ + p01 * x1_ + inc[..., 0],
            p10 * x0_ + p11 * x1_ + inc[..., 1],
        )
    # outputs between the samples: free response of the stored states + forced response
    CP = np.stack([rows[0, :S], rows[1, :S]], axis=-1).transpose(1, 0, 2, 3)  # C Phi^i
    y = xs.reshape(V, K, 2 * M) @ CP.reshape(V, S, 2 * M).transpose(0, 2, 1)
    # impulse responses C Phi^l G (l = 0..S-1) summed over modes: the reversed first
    # state component of the block maps
    H2 = B2.reshape(2, S, V, M, 2)[:, ::-1, :, :, 0].sum(axis=-1)  # (2, S, V)
    H2 = H2.transpose(2, 0, 1).reshape(V, 2 * S)
    W = _windows(ubuf, S, 0, K)
    active = np.flatnonzero(np.any(W != 0.0, axis=(0, 2)))
    y[:, active] += _forced_output(H2, W[:, active], S)
    u = np.broadcast_to(ubuf[:, dd + 1 :], (V, Nt))
    return y.reshape(V, Nt), yd, u
