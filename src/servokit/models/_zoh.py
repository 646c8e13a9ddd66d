"""Exact zero-order-hold integrals of linear systems, batched.

For x' = A x + B u with u constant over an interval, the state after a time t is
``Phi(t) x + Gamma(t) u`` with ``Phi(t) = e^{A t}`` and ``Gamma(t) = int_0^t e^{A s} ds B``.
Both come from one matrix exponential of the augmented matrix ``[[A, B], [0, 0]]``
(Van Loan), which is exact and needs no inverse of A (the rigid-body mode makes A
singular).  Everything here is batched over leading axes so that many plant variants
and many modes are handled in one call.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["zoh_pair", "delayed_zoh"]


def zoh_pair(A: np.ndarray, B: np.ndarray, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return ``Phi(t)`` and ``Gamma(t)`` for (batched) ``A`` (..., n, n) and ``B`` (..., n, p).

    ``t`` may be a scalar or an array broadcast against the batch axes of ``A``.
    """
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    n, p = A.shape[-1], B.shape[-1]
    t = np.asarray(t, dtype=float)
    batch = np.broadcast_shapes(A.shape[:-2], B.shape[:-2], t.shape)
    M = np.zeros((*batch, n + p, n + p))
    M[..., :n, :n] = A
    M[..., :n, n:] = B
    M = M * t[..., None, None]
    E = scipy.linalg.expm(M)
    return E[..., :n, :n], E[..., :n, n:]


def delayed_zoh(
    A: np.ndarray, B: np.ndarray, dt: float, delay: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Exact ZOH of x' = A x + B u(t - delay) over one step ``dt``.

    With ``delay = d*dt + frac`` (0 <= frac < dt) the input seen by the plant over
    [k dt, (k+1) dt) is u[k-d-1] for the first ``frac`` seconds and u[k-d] afterwards, so

        x[k+1] = Phi x[k] + Gamma_new u[k-d] + Gamma_old u[k-d-1],
        Gamma_new = Gamma(dt - frac),  Gamma_old = Phi(dt - frac) Gamma(frac).

    Returns ``(Phi, Gamma_new, Gamma_old, d)``; ``Gamma_old`` is zero when frac == 0.
    """
    d = int(np.floor(delay / dt + 1e-12))
    frac = delay - d * dt
    if frac < 1e-12 * dt:
        frac = 0.0
    Phi, _ = zoh_pair(A, B, dt)
    Phi_rest, Gnew = zoh_pair(A, B, dt - frac)
    _, Gfrac = zoh_pair(A, B, frac)
    Gold = Phi_rest @ Gfrac
    return Phi, Gnew, Gold, d
