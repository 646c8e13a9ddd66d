"""Sample-rate closed loops of a digital controller around many plant variants, batched.

The discrete loop of :func:`servokit.simulate.simulate` (unity negative feedback, plant
exact ZOH with its delay, controller ``C(z)``) driven by ``e0 = r - y_open`` (the
reference minus the output the plant would have without feedback) has, for each
variant, the state ``z = [x_p, x_c]`` and::

    z[k+1] = A_cl z[k] + B_cl e0[k],      v[k] = C_v z[k] + D_c e0[k]

    A_cl = [[A_p - B_p D_c C_p, B_p C_c],      B_cl = [B_p D_c; B_c]
            [-B_c C_p,          A_c    ]],     C_v  = [-D_c C_p, C_c]

(the plant is strictly proper), ``v`` being the controller output.  With a multirate
path the fast series ``P(dt/m) F`` driven by the zero-inserted controller output is
first lifted over one period: ``A^m, A^(m-1) B``; the filter state is then part of
``x_p``.

Stability: ``rho(A)^n <= ||A^n||`` for any norm, so a variant whose ``||A^(2^j)||_inf``
drops below 1 after ``j`` squarings is certified stable (one batched product of the
stacked matrices per squaring, 0.6 ms for 1000 variants of order 20).  Only the
variants not certified that way (unstable or marginal ones) go to
``numpy.linalg.eigvals`` (0.1 ms per matrix), which gives their exact spectral radius.
This replaces python-control's ``sample_system``/``feedback``/``poles`` per variant,
which cost more than the simulation itself.
"""

from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from servokit.simulate._bank import PlantBank

__all__ = ["ClosedLoop", "closed_loop", "closed_loop_matrices", "spectral_radii", "unstable"]

StateSpace = tuple[np.ndarray, np.ndarray, np.ndarray, float]

#: squarings tried before falling back to eigenvalues: certifies rho < 1 - 1e-6 or so
_SQUARINGS = 24
#: squarings before the first norm test (to A^32): earlier powers of a stable loop
#: rarely have a norm below 1; an unstable one that overflows meanwhile (inf/NaN norm)
#: stays undecided and goes to the eigenvalues
_UNCHECKED = 5


@dataclass(frozen=True)
class ClosedLoop:
    """Stacked sample-rate closed loops (see module docstring) of ``V`` variants."""

    A: np.ndarray  # (V, N, N)
    B: np.ndarray  # (V, N)
    Cv: np.ndarray  # (V, N)
    Dv: float
    n_plant: int  # plant (and filter) states come first, then the controller's
    n_filter: int  # the last n_filter plant states are the multirate filter's


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


def _lifted_plant(
    bank: PlantBank, dt: float, multirate: tuple[int, StateSpace] | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Sample-rate plant ``(A, B, C)`` seen by the controller, and its filter order."""
    if multirate is None:
        return (*bank.discrete(dt), 0)
    m, filt = multirate
    A, B, C = _series_fast(*bank.discrete(dt / m), filt)
    Am1 = np.linalg.matrix_power(A, m - 1)  # m is a small multirate number
    return Am1 @ A, np.einsum("vij,vj->vi", Am1, B), C, filt[0].shape[0]


def closed_loop(
    bank: PlantBank,
    controller: StateSpace,
    dt: float,
    multirate: tuple[int, StateSpace] | None = None,
) -> ClosedLoop:
    """The stacked sample-rate closed loops driven by ``e0`` (see module docstring).

    Parameters
    ----------
    bank : PlantBank
        The stacked plant variants (their exact hold/delay discretisations).
    controller : StateSpace
        The digital controller ``(Ac, Bc, Cc, Dc)`` acting on ``r - y`` at ``dt``.
    dt : float
        Sampling period of the loop [s].
    multirate : tuple of (int, StateSpace), optional
        ``(m, F)``: a multirate filter ``F`` with hold at ``dt / m`` (Fig. 4.2), lifted to
        the sampling period.

    Returns
    -------
    ClosedLoop
        Stacked ``A_cl`` (V, N, N), input and output matrices of the loops, the
        controller feed-through and the plant / filter state counts.
    """
    A, B, C, nf = _lifted_plant(bank, dt, multirate)
    Ac, Bc, Cc, Dc = controller
    V, n, _ = A.shape
    nc = Ac.shape[0]
    Acl = np.zeros((V, n + nc, n + nc))
    Acl[:, :n, :n] = A - Dc * B[:, :, None] * C[None, None, :]
    Acl[:, :n, n:] = B[:, :, None] * Cc[None, None, :]
    Acl[:, n:, :n] = -Bc[None, :, None] * C[None, None, :]
    Acl[:, n:, n:] = Ac
    Bcl = np.concatenate([B * Dc, np.broadcast_to(Bc, (V, nc))], axis=1)
    Cv = np.broadcast_to(np.concatenate([-Dc * C, Cc]), (V, n + nc))
    return ClosedLoop(Acl, Bcl, Cv, float(Dc), n, nf)


def closed_loop_matrices(
    bank: PlantBank,
    controller: StateSpace,
    dt: float,
    multirate: tuple[int, StateSpace] | None = None,
) -> np.ndarray:
    """Stacked closed-loop matrices ``A_cl`` (V, N, N) of the sampled loop.

    Parameters
    ----------
    bank : PlantBank
        The stacked plant variants (their exact hold/delay discretisations).
    controller : StateSpace
        The digital controller ``(Ac, Bc, Cc, Dc)`` acting on ``r - y`` at ``dt``.
    dt : float
        Sampling period of the loop [s].
    multirate : tuple of (int, StateSpace), optional
        ``(m, F)``: a multirate filter ``F`` with hold at ``dt / m`` (Fig. 4.2), lifted to
        the sampling period.

    Returns
    -------
    numpy.ndarray
        ``A_cl`` of every variant, shape (V, N, N).
    """
    return closed_loop(bank, controller, dt, multirate).A


def spectral_radii(
    bank: PlantBank,
    controller: StateSpace,
    dt: float,
    multirate: tuple[int, StateSpace] | None = None,
) -> np.ndarray:
    """Largest closed-loop pole magnitude ``|z|`` of every variant.

    Parameters
    ----------
    bank : PlantBank
        The stacked plant variants (their exact hold/delay discretisations).
    controller : StateSpace
        The digital controller ``(Ac, Bc, Cc, Dc)`` acting on ``r - y`` at ``dt``.
    dt : float
        Sampling period of the loop [s].
    multirate : tuple of (int, StateSpace), optional
        ``(m, F)``: a multirate filter ``F`` with hold at ``dt / m`` (Fig. 4.2), lifted to
        the sampling period.

    Returns
    -------
    numpy.ndarray
        Spectral radius of every variant's closed loop, shape (V,); ``>= 1`` is unstable.
    """
    return _radii(closed_loop_matrices(bank, controller, dt, multirate))


def _radii(A: np.ndarray) -> np.ndarray:
    """Exact spectral radius of every matrix of the stack ``A`` (V, N, N); 0 when N = 0."""
    if A.shape[-1] == 0:
        return np.zeros(A.shape[0])
    return np.abs(np.linalg.eigvals(A)).max(axis=-1)


#: up to this many loops the spectral radii are computed directly (no squaring pass)
_DIRECT_MAX = 4


#: spectral radii of the last few loops, keyed by a digest of their matrices (the key
#: must not hold the matrices: 64 loops of 4 x 151-mode plants kept 190 MB of keys)
_RADII_CACHE: OrderedDict[tuple[bytes, tuple[int, ...]], np.ndarray] = OrderedDict()
_RADII_CACHE_SIZE = 8


def clear_radii_cache() -> None:
    """Forget the cached spectral radii (benchmarks of the first call use it).

    Returns
    -------
    None
    """
    _RADII_CACHE.clear()


def _radii_few(A: np.ndarray) -> np.ndarray:
    """:func:`_radii` of a few loops, kept for the next call on the same matrices (a
    user re-running one loop: the same bytes give the same eigenvalues)."""
    A = np.ascontiguousarray(A, dtype=float)
    key = (hashlib.blake2b(A.tobytes(), digest_size=32).digest(), A.shape)
    rho = _RADII_CACHE.get(key)
    if rho is None:
        rho = _radii(A)
        rho.flags.writeable = False
        _RADII_CACHE[key] = rho
        if len(_RADII_CACHE) > _RADII_CACHE_SIZE:
            _RADII_CACHE.popitem(last=False)
    else:
        _RADII_CACHE.move_to_end(key)
    return rho


def unstable(A: np.ndarray, margin: float = 1e-10) -> tuple[np.ndarray, np.ndarray]:
    """Variants of the stack ``A`` (V, N, N) with spectral radius ``>= 1 - margin``.

    Certified-stable variants are dropped by repeated squaring (a power with induced
    infinity norm below 1 proves the spectral radius below 1); the rest get exact
    eigenvalues (see module docstring).

    Parameters
    ----------
    A : numpy.ndarray
        Stack of square matrices, shape (V, N, N).
    margin : float
        Variants with spectral radius ``>= 1 - margin`` count as unstable.

    Returns
    -------
    indices : numpy.ndarray
        Indices (into the stack) of the unstable variants.
    radii : numpy.ndarray
        Their spectral radii.
    """
    V = A.shape[0]
    if A.shape[-1] == 0:
        return np.zeros(0, dtype=int), np.zeros(0)
    todo = np.arange(V)
    X = A
    if V <= _DIRECT_MAX:  # a few loops: their eigenvalues cost less than the squarings
        rho = _radii_few(A)
        bad = rho >= 1.0 - margin
        return todo[bad], rho[bad]
    with np.errstate(over="ignore", invalid="ignore"):
        for j in range(_SQUARINGS):
            if j >= _UNCHECKED:  # norms of the first powers rarely certify anything
                norm = np.abs(X).sum(axis=-1).max(axis=-1)
                keep = ~(norm < 1.0)  # NaN (overflow) stays undecided
                todo, X = todo[keep], X[keep]
                if todo.size == 0 or not np.any(norm[keep] < 1e100):
                    break  # all left are growing: their eigenvalues tell by how much
            X = X @ X
    if todo.size == 0:
        return todo, np.zeros(0)
    rho = _radii(A[todo])
    bad = rho >= 1.0 - margin
    return todo[bad], rho[bad]
