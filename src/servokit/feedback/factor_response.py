"""Fast exact frequency responses of loop factors from a reduced form computed once.

python-control evaluates a state space by a dense solve ``C (xI - A)^{-1} B`` per frequency
(O(n^3) each). Here each factor is reduced once:

* diagonalisable ``A = V Λ V^{-1}`` with a well-conditioned ``V`` (cond < 1e8): the partial
  fractions ``D + Σ_i r_i / (x - λ_i)``, ``r_i = (C V)_i (V^{-1} B)_i`` (O(n) per frequency);
* a Jordan block (the rigid body ``1/s^2``, its ZOH image ``[[1, h], [0, 1]]``, repeated
  integrators): the complex Schur form reordered to put the repeated eigenvalues first,
  ``T = [[T11, T12], [0, T22]]``, decoupled by the Sylvester equation
  ``T11 X - X T22 = -T12``; the small cluster ``T11`` is solved by back substitution,
  ``T22`` by partial fractions;
* otherwise the complex Schur form ``A = Z T Z^H`` and a back substitution
  ``(xI - T) y = Z^H B`` vectorised over all frequencies at once (O(n^2) per frequency,
  backward stable for any ``A``).

A transfer function is evaluated as the user gave it (Horner on numerator and denominator,
which is what its coefficients define); a :class:`~servokit.models.ModalPlant` by its own
exact modal sum with the delay. Every factor also reports its poles, which the Nyquist
stability verdict needs. ``x`` is ``j 2π f`` for continuous factors and ``e^{j 2π f dt}``
for discrete ones.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError

__all__ = ["Factor", "make_factor"]

#: Eigenvector condition number above which the Schur form replaces the diagonal form.
_MAX_COND = 1e8


@dataclass
class Factor:
    """One loop factor: ``response(freq_hz)``, its sampling period and its poles.

    Attributes
    ----------
    response : callable
        ``freq_hz -> complex ndarray`` (exact).
    dt : float or None
        Sampling period [s]; None for continuous (or unknown, for callables).
    poles : ndarray or None
        Poles in s (continuous) or z (discrete); None when unknown (black-box callable).
    continuous_lti : bool
        True for continuous LTI/ModalPlant factors (which cannot mix with discrete ones).
    """

    response: Callable[[np.ndarray], np.ndarray]
    dt: float | None
    poles: np.ndarray | None
    continuous_lti: bool = False
    source: Any = field(default=None, repr=False)


def _timebase(sys: Any) -> float | None:
    dt = getattr(sys, "dt", None)
    if dt is None or dt is False or dt == 0:
        return None
    if dt is True:
        raise ServokitValueError("loop: a discrete loop needs a numeric sampling period dt")
    return float(dt)


def _point(dt: float | None) -> Callable[[np.ndarray], np.ndarray]:
    if dt is None:
        return lambda f: 2j * np.pi * f
    return lambda f: np.exp(2j * np.pi * f * dt)


def _tf_factor(sys: Any, dt: float | None) -> Factor:
    num = np.trim_zeros(np.asarray(sys.num[0][0], dtype=float), "f")
    den = np.trim_zeros(np.asarray(sys.den[0][0], dtype=float), "f")
    if num.size == 0:
        num = np.zeros(1)
    x_of = _point(dt)

    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(np.asarray(f, dtype=float))
        with np.errstate(all="ignore"):  # a pole on the grid gives inf, handled by callers
            return np.polyval(num, x) / np.polyval(den, x)

    return Factor(resp, dt, np.roots(den).astype(complex), dt is None, sys)


def _diagonal(A: np.ndarray, B: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    if A.shape[0] == 0:
        return np.zeros(0, dtype=complex), np.zeros(0, dtype=complex)
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) > _MAX_COND:
        return None
    r = (C @ V)[0] * np.linalg.solve(V, B)[:, 0]
    return lam, r


def _split(A: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    """Schur form with the repeated-eigenvalue cluster first, decoupled from the rest.

    Returns ``(T11, S, Z, k)`` with ``A = Z S blockdiag(T11, T22) S^{-1} Z^H`` (T22 is then
    diagonalised separately), or None when the rest is not safely diagonalisable.
    """
    import scipy.linalg

    lam = np.linalg.eigvals(A)
    scale = max(1.0, float(np.max(np.abs(lam))))
    near = np.abs(lam[:, None] - lam[None, :]) <= 1e-6 * scale
    rep = lam[near.sum(axis=1) > 1]
    if rep.size == 0:
        return None

    def in_cluster(x: complex) -> bool:
        return bool(np.any(np.abs(rep - x) <= 1e-6 * scale))

    T, Z, k = scipy.linalg.schur(A.astype(complex), output="complex", sort=in_cluster)
    T11, T12, T22 = T[:k, :k], T[:k, k:], T[k:, k:]
    X = scipy.linalg.solve_sylvester(T11, -T22, -T12)
    S = np.eye(A.shape[0], dtype=complex)
    S[:k, k:] = X
    return T, S, Z, k


def _ss_factor(sys: Any, dt: float | None) -> Factor:
    A, B, C = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C))
    d = complex(np.asarray(sys.D, dtype=float).reshape(-1)[0]) if np.size(sys.D) else 0j
    x_of = _point(dt)
    if A.shape[0] == 0:
        return Factor(lambda f: np.full(np.shape(f), d), dt, np.zeros(0, complex), dt is None)
    diag = _diagonal(A, B, C)
    if diag is not None:
        lam, r = diag
        return Factor(_partial_fractions(lam, r, d, x_of), dt, lam, dt is None, sys)
    split = _split(A)
    if split is not None:
        T, S, Z, k = split
        Sinv = np.linalg.inv(S)
        b = Sinv @ (Z.conj().T @ B[:, 0])
        c = C[0] @ Z @ S
        rest = _diagonal(T[k:, k:], b[k:, None], c[None, k:])
        if rest is not None:
            lam2, r2 = rest
            near = _triangular(T[:k, :k], b[:k], c[:k], 0j, x_of)
            far = _partial_fractions(lam2, r2, d, x_of)
            return Factor(
                lambda f: near(f) + far(f), dt, np.r_[np.diag(T[:k, :k]), lam2], dt is None, sys
            )
    import scipy.linalg

    T, Z = scipy.linalg.schur(A.astype(complex), output="complex")
    resp = _triangular(T, Z.conj().T @ B[:, 0], C[0] @ Z, d, x_of)
    return Factor(resp, dt, np.diag(T).copy(), dt is None, sys)


def _partial_fractions(
    lam: np.ndarray, r: np.ndarray, d: complex, x_of: Callable[[np.ndarray], np.ndarray]
) -> Callable[[np.ndarray], np.ndarray]:
    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(np.asarray(f, dtype=float))
        with np.errstate(all="ignore"):  # a pole on the grid gives inf, handled by callers
            return (r / (x[..., None] - lam)).sum(axis=-1) + d

    return resp


def _triangular(
    T: np.ndarray, b: np.ndarray, c: np.ndarray, d: complex,
    x_of: Callable[[np.ndarray], np.ndarray],
) -> Callable[[np.ndarray], np.ndarray]:
    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(np.asarray(f, dtype=float)).ravel()
        n = T.shape[0]
        y = np.empty((n, x.size), dtype=complex)
        with np.errstate(all="ignore"):
            # back substitution, all frequencies at once; elementwise sums rather than BLAS
            # calls, whose thread start-up costs more than these small products
            for i in range(n - 1, -1, -1):
                y[i] = (b[i] + (T[i, i + 1 :, None] * y[i + 1 :]).sum(axis=0)) / (x - T[i, i])
        return ((c[:, None] * y).sum(axis=0) + d).reshape(np.shape(f))

    return resp


def _modal_factor(plant: Any) -> Factor:
    w, z, _ = plant.arrays()
    p = -z * w + 1j * w * np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    # a rigid-body mode (w = 0) is a double pole at s = 0
    poles = np.r_[p, np.conj(p)]

    def resp(f: np.ndarray) -> np.ndarray:
        return np.asarray(plant.freqresp(f), dtype=complex)

    return Factor(resp, None, poles, True, plant)


def make_factor(item: Any) -> Factor:
    """Wrap one loop factor (LTI, ModalPlant or callable) as a :class:`Factor`.

    Parameters
    ----------
    item : LTI, ModalPlant or callable
        A SISO python-control system, a :class:`~servokit.models.ModalPlant` (continuous,
        delay included) or a callable ``freq_hz -> complex`` (its ``dt`` attribute, if any,
        marks it discrete; its ``poles`` attribute, if any, enables the stability verdict).

    Returns
    -------
    Factor
    """
    import control

    if isinstance(item, control.LTI):
        if not (item.ninputs == 1 and item.noutputs == 1):
            raise ServokitValueError("loop must be single-input single-output")
        dt = _timebase(item)
        if isinstance(item, control.TransferFunction):
            return _tf_factor(item, dt)
        return _ss_factor(control.ss(item), dt)
    if hasattr(item, "freqresp") and hasattr(item, "modes"):
        return _modal_factor(item)
    if callable(item):
        poles = getattr(item, "poles", None)
        poles = None if poles is None else np.asarray(poles, dtype=complex)
        return Factor(
            lambda f: np.asarray(item(f), dtype=complex), getattr(item, "dt", None), poles
        )
    raise ServokitTypeError(
        f"loop factor of type {type(item).__name__} is not supported; pass a python-control "
        "LTI system, a ModalPlant or a callable freq_hz -> complex response"
    )
