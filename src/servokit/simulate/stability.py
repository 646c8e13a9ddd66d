"""Batched closed-loop stability of a digital controller around many plant variants.

The discrete loop of :func:`servokit.simulate.simulate` (unity negative feedback, plant
exact ZOH with its delay, controller ``C(z)``) has, for each variant, the closed-loop
matrix::

    A_cl = [[A_p - B_p D_c C_p, B_p C_c],
            [-B_c C_p,          A_c    ]]

(the plant is strictly proper).  With a multirate path the fast series ``P(dt/m) F``
driven by the zero-inserted controller output is first lifted over one period:
``A^m, A^(m-1) B``.  All variants are stacked and their spectral radii come from one
batched ``numpy.linalg.eigvals`` call, instead of python-control's
``sample_system``/``feedback``/``poles`` per variant (which cost more than the whole
simulation of a single plant).
"""

from __future__ import annotations

import numpy as np

from servokit.simulate._bank import PlantBank

__all__ = ["closed_loop_matrices", "spectral_radii"]

StateSpace = tuple[np.ndarray, np.ndarray, np.ndarray, float]


def _series_fast(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, filt: StateSpace
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Plant (A, B, C; D = 0) fed by the filter ``F``: stacked series model."""
    Af, Bf, Cf, Df = filt
    V, n, _ = A.shape
    nf = Af.shape[0]
    As = np.zeros((V, n + nf, n + nf))
    As[:, :n, :n] = A
    As[:, :n, n:] = B[:, :, None] * Cf[None, None, :]
    As[:, n:, n:] = Af
    Bs = np.concatenate([B * Df, np.broadcast_to(Bf, (V, nf))], axis=1)
    Cs = np.concatenate([C, np.zeros(nf)])
    return As, Bs, Cs


def closed_loop_matrices(
    bank: PlantBank,
    controller: StateSpace,
    dt: float,
    multirate: tuple[int, StateSpace] | None = None,
) -> np.ndarray:
    """Stacked closed-loop matrices (V, N, N) of the sampled loop (see module docstring)."""
    if multirate is None:
        A, B, C = bank.discrete(dt)
    else:
        m, filt = multirate
        A, B, C = _series_fast(*bank.discrete(dt / m), filt)
        Am1 = np.linalg.matrix_power(A, m - 1)  # m is a small multirate number
        A, B = Am1 @ A, np.einsum("vij,vj->vi", Am1, B)
    Ac, Bc, Cc, Dc = controller
    V, n, _ = A.shape
    nc = Ac.shape[0]
    Acl = np.zeros((V, n + nc, n + nc))
    Acl[:, :n, :n] = A - Dc * B[:, :, None] * C[None, None, :]
    Acl[:, :n, n:] = B[:, :, None] * Cc[None, None, :]
    Acl[:, n:, :n] = -Bc[None, :, None] * C[None, None, :]
    Acl[:, n:, n:] = Ac
    return Acl


def spectral_radii(
    bank: PlantBank,
    controller: StateSpace,
    dt: float,
    multirate: tuple[int, StateSpace] | None = None,
) -> np.ndarray:
    """Largest closed-loop pole magnitude ``|z|`` of every variant, shape (V,)."""
    Acl = closed_loop_matrices(bank, controller, dt, multirate)
    if Acl.shape[-1] == 0:
        return np.zeros(Acl.shape[0])
    return np.abs(np.linalg.eigvals(Acl)).max(axis=-1)
