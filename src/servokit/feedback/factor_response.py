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

__all__ = ["Factor", "clear_factor_cache", "loop_evaluator", "make_factor"]

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
    #: ``(poles, residues, feedthrough)`` of the diagonal part, merged across factors by
    #: :func:`loop_evaluator`; ``near`` adds the rest (a function of ``x``), if any.
    pf: tuple[np.ndarray, np.ndarray, complex] | None = field(default=None, repr=False)
    near: Callable[[np.ndarray], np.ndarray] | None = field(default=None, repr=False)
    zeros: np.ndarray = field(default_factory=lambda: np.zeros(0, complex), repr=False)


def _timebase(sys: Any) -> float | None:
    dt = getattr(sys, "dt", None)
    if dt is None or dt is False or dt == 0:
        return None
    if dt is True:
        raise ServokitValueError("loop: a discrete loop needs a numeric sampling period dt")
    return float(dt)


def _point(dt: float | None) -> Callable[[np.ndarray], np.ndarray]:
    if dt is None:
        return lambda f: 2j * np.pi * np.asarray(f, dtype=float)
    return lambda f: np.exp(2j * np.pi * np.asarray(f, dtype=float) * dt)


def _tf_factor(sys: Any, dt: float | None) -> Factor:
    # copies: the reduced form is cached and must not alias the system's own arrays
    num, den = (np.array(c, dtype=float) for c in (sys.num[0][0], sys.den[0][0]))
    num = num[np.argmax(num != 0) :] if np.any(num != 0) else np.zeros(1)
    den = den[np.argmax(den != 0) :]
    x_of = _point(dt)

    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(f)
        with np.errstate(all="ignore"):  # a pole on the grid gives inf, handled by callers
            return np.polyval(num, x) / np.polyval(den, x)

    zeros = _poly_roots(num) if num.size > 1 else np.zeros(0, complex)
    poles = _poly_roots(den)
    fa = Factor(resp, dt, poles, dt is None, sys, zeros=zeros)
    fa.pf = _tf_partial_fractions(num, den, poles)
    return fa


def _poly_roots(p: np.ndarray) -> np.ndarray:
    """Roots of a polynomial with a nonzero leading coefficient.

    The filters of a servo loop are first- and second-order sections: their roots come
    from the closed forms (the quadratic one in the cancellation-free form ``q = -(b +
    sign(b) sqrt(b^2 - 4ac))/2``, roots ``q/a`` and ``c/q``), which are as accurate as the
    companion-matrix eigenvalues of ``np.roots`` and ten times cheaper; higher degrees use
    ``np.roots``.
    """
    k = p.size - 1
    while k > 0 and p[k] == 0:  # trailing zero coefficients: roots at the origin
        k -= 1
    origin = np.zeros(p.size - 1 - k, dtype=complex)
    if k == 1:
        rest = np.array([-p[1] / p[0]], dtype=complex)
    elif k == 2:
        a, b, c = (complex(x) for x in p[:3])
        root = np.sqrt(b * b - 4 * a * c)
        q = -0.5 * (b + (root if (b.conjugate() * root).real >= 0 else -root))
        rest = np.array([q / a, c / q], dtype=complex)
    else:
        rest = np.roots(p[: k + 1]).astype(complex)
    return np.concatenate([rest, origin])


def _tf_partial_fractions(
    num: np.ndarray, den: np.ndarray, poles: np.ndarray
) -> tuple[np.ndarray, np.ndarray, complex] | None:
    """Residues ``num(p)/den'(p)`` of a proper TF with well separated poles, else None."""
    if num.size > den.size or poles.size == 0:
        return None
    scale = max(1.0, float(np.max(np.abs(poles))))
    gaps = np.abs(poles[:, None] - poles[None, :]) + np.eye(poles.size) * scale
    if np.min(gaps) < 1e-4 * scale:
        return None  # repeated or clustered poles: Horner is the better evaluation
    d = num[0] / den[0] if num.size == den.size else 0.0
    strict = np.polysub(num, d * den)
    r = np.polyval(strict, poles) / np.polyval(np.polyder(den), poles)
    return poles, r, complex(d)


def _diagonal(
    A: np.ndarray, B: np.ndarray, C: np.ndarray, eig: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    if A.shape[0] == 0:
        return np.zeros(0, dtype=complex), np.zeros(0, dtype=complex)
    lam, V = np.linalg.eig(A) if eig is None else eig
    if np.linalg.cond(V) > _MAX_COND:
        return None
    r = (C @ V)[0] * np.linalg.solve(V, B)[:, 0]
    return lam, r


def _split(A: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int] | None:
    """Schur form with the repeated-eigenvalue cluster first, decoupled from the rest.

    Returns ``(T11, S, Z, k)`` with ``A = Z S blockdiag(T11, T22) S^{-1} Z^H`` (T22 is then
    diagonalised separately), or None when the rest is not safely diagonalisable.
    """
    import scipy.linalg

    rep = _repeated(lam)
    if rep.size == 0:
        return None
    scale = max(1.0, float(np.max(np.abs(lam))))

    def in_cluster(x: complex) -> bool:
        return bool(np.any(np.abs(rep - x) <= 1e-6 * scale))

    T, Z, k = scipy.linalg.schur(A.astype(complex), output="complex", sort=in_cluster)
    T11, T12, T22 = T[:k, :k], T[:k, k:], T[k:, k:]
    X = scipy.linalg.solve_sylvester(T11, -T22, -T12)
    S = np.eye(A.shape[0], dtype=complex)
    S[:k, k:] = X
    return T, S, Z, k


def _repeated(lam: np.ndarray) -> np.ndarray:
    """Eigenvalues with a near-duplicate (1e-6 relative): a possible Jordan block."""
    scale = max(1.0, float(np.max(np.abs(lam))))
    near = np.abs(lam[:, None] - lam[None, :]) <= 1e-6 * scale
    return lam[near.sum(axis=1) > 1]


def _ss_factor(sys: Any, dt: float | None) -> Factor:
    A, B, C = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C))
    d = complex(np.asarray(sys.D, dtype=float).reshape(-1)[0]) if np.size(sys.D) else 0j
    x_of = _point(dt)
    if A.shape[0] == 0:
        return Factor(lambda f: np.full(np.shape(f), d), dt, np.zeros(0, complex), dt is None)
    eig = np.linalg.eig(A)
    zeros = _zeros(sys)
    diag = _diagonal(A, B, C, eig) if _repeated(eig[0]).size == 0 else None
    if diag is not None:
        lam, r = diag
        resp = _partial_fractions(lam, r, d, x_of)
        return Factor(resp, dt, lam, dt is None, sys, pf=(lam, r, d), zeros=zeros)
    split = _split(A, eig[0])
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
            poles = np.r_[np.diag(T[:k, :k]), lam2]
            return Factor(
                lambda f: near(f) + far(f),
                dt,
                poles,
                dt is None,
                sys,
                pf=(lam2, r2, d),
                near=_triangular(T[:k, :k], b[:k], c[:k], 0j, lambda x: x),
                zeros=zeros,
            )
    import scipy.linalg

    T, Z = scipy.linalg.schur(A.astype(complex), output="complex")
    resp = _triangular(T, Z.conj().T @ B[:, 0], C[0] @ Z, d, x_of)
    return Factor(resp, dt, np.diag(T).copy(), dt is None, sys, zeros=zeros)


def _zeros(sys: Any) -> np.ndarray:
    """Transmission zeros (finite eigenvalues of the Rosenbrock pencil), or none if the
    generalised eigenproblem fails (repeated undamped modes can make QZ give up; the
    adaptive refinement still resolves what the packing then misses)."""
    import scipy.linalg

    A, B, C, D = (np.atleast_2d(np.asarray(m, dtype=float)) for m in (sys.A, sys.B, sys.C, sys.D))
    n = A.shape[0]
    M = np.block([[A, B], [C, D]])
    N = np.zeros_like(M)
    N[:n, :n] = np.eye(n)
    try:
        with np.errstate(all="ignore"):
            z = scipy.linalg.eigvals(M, N)
    except (np.linalg.LinAlgError, ValueError):
        return np.zeros(0, dtype=complex)
    return z[np.isfinite(z)].astype(complex)


def _partial_fractions(
    lam: np.ndarray, r: np.ndarray, d: complex, x_of: Callable[[np.ndarray], np.ndarray]
) -> Callable[[np.ndarray], np.ndarray]:
    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(f)
        with np.errstate(all="ignore"):  # a pole on the grid gives inf, handled by callers
            return (r / (x[..., None] - lam)).sum(axis=-1) + d

    return resp


def _triangular(
    T: np.ndarray,
    b: np.ndarray,
    c: np.ndarray,
    d: complex,
    x_of: Callable[[np.ndarray], np.ndarray],
) -> Callable[[np.ndarray], np.ndarray]:
    def resp(f: np.ndarray) -> np.ndarray:
        x = x_of(f).ravel()
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

    zeros = _zeros(plant.to_statespace())
    return Factor(resp, None, poles, True, plant, zeros=zeros)


#: Reduced forms of recently seen LTI factors: ``id -> (system, fingerprint, Factor)``.
#: A loop is usually evaluated many times with the same controller (margins over a plant
#: set, loop shaping, a gain sweep, the CLI's report), so each system is reduced once.
#: The entry keeps the system alive, so its id cannot be reused while cached; the
#: fingerprint (coefficients and ``dt``) catches a system changed in place.
_CACHE: dict[int, tuple[Any, bytes, Factor]] = {}
_CACHE_SIZE = 64


def _fingerprint(item: Any) -> bytes:
    import control

    if isinstance(item, control.TransferFunction):
        parts = [item.num[0][0], item.den[0][0]]
    else:
        parts = [item.A, item.B, item.C, item.D]
    # each part's shape goes in too: bytes alone could match after num shrinks and den grows
    raw = b"".join(
        repr(np.shape(p)).encode() + np.ascontiguousarray(p, dtype=float).tobytes() for p in parts
    )
    return raw + repr(item.dt).encode()


def clear_factor_cache() -> None:
    """Forget every cached reduced form (a benchmark of the cold path calls this).

    Returns
    -------
    None
    """
    _CACHE.clear()


def _lti_factor(item: Any) -> Factor:
    import control

    if not isinstance(item, control.TransferFunction | control.StateSpace):
        return _ss_factor(control.ss(item), _timebase(item))  # conversion fails with a clear error
    key, fp = id(item), _fingerprint(item)
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is item and hit[1] == fp:
        return hit[2]
    dt = _timebase(item)
    if isinstance(item, control.TransferFunction):
        fa = _tf_factor(item, dt)
    else:
        fa = _ss_factor(control.ss(item), dt)
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.pop(next(iter(_CACHE)))  # oldest first
    _CACHE[key] = (item, fp, fa)
    return fa


def make_factor(item: Any) -> Factor:
    """Wrap one loop factor (LTI, ModalPlant or callable) as a :class:`Factor`.

    Parameters
    ----------
    item : LTI, RationalTF, StateSpaceData, ModalPlant or callable
        A SISO python-control system or its numpy-only form
        (:mod:`servokit.models.rational`), a :class:`~servokit.models.ModalPlant` (continuous,
        delay included) or a callable ``freq_hz -> complex`` (its ``dt`` attribute, if any,
        marks it discrete; its ``poles`` attribute, if any, enables the stability verdict).

    Returns
    -------
    Factor
    """
    from servokit.models.rational import RationalTF, StateSpaceData

    if isinstance(item, RationalTF | StateSpaceData):  # numpy-only data: python-control unloaded
        if not (item.ninputs == 1 and item.noutputs == 1):
            raise ServokitValueError("loop must be single-input single-output")
        build = _tf_factor if isinstance(item, RationalTF) else _ss_factor
        return build(item, _timebase(item))
    import control

    if isinstance(item, control.LTI):
        if not (item.ninputs == 1 and item.noutputs == 1):
            raise ServokitValueError("loop must be single-input single-output")
        return _lti_factor(item)
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


def loop_evaluator(
    factors: list[Factor], tau: float, dt: float | None
) -> Callable[[np.ndarray], np.ndarray]:
    """``L(freq_hz)``: the product of the factors and ``e^{-j 2π f τ}``, merged for speed.

    Every diagonal part is evaluated in one array operation (all poles of all factors at
    once, summed per factor with ``np.add.reduceat``), ``x`` is computed once; the other
    factors are called as they are.

    Parameters
    ----------
    factors : list of Factor
        The loop factors (one sampling period ``dt``).
    tau : float
        Extra delay [s].
    dt : float or None
        Sampling period [s] (None: continuous).

    Returns
    -------
    callable
        ``freq_hz -> complex ndarray``.
    """
    merged = [fa for fa in factors if fa.pf is not None]
    others = [fa for fa in factors if fa.pf is None]
    x_of = _point(dt)
    if merged:
        lam = np.concatenate([fa.pf[0] for fa in merged])
        res = np.concatenate([fa.pf[1] for fa in merged])
        d = np.array([fa.pf[2] for fa in merged])
        sizes = np.array([fa.pf[0].size for fa in merged])
        starts = np.r_[0, np.cumsum(sizes)[:-1]]
        empty = sizes == 0
        nears = [fa.near for fa in merged]

    def resp(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        flat = f.ravel()
        out = np.exp(-2j * np.pi * flat * tau) if tau else np.ones(flat.shape, dtype=complex)
        if merged:
            x = x_of(flat)
            with np.errstate(all="ignore"):  # a pole on the grid gives inf
                # poles along the first axis: the per-factor sums reduce contiguous rows
                if lam.size:
                    terms = res[:, None] / (x[None, :] - lam[:, None])
                    sums = np.add.reduceat(terms, np.minimum(starts, lam.size - 1), axis=0)
                    sums[empty] = 0.0
                else:
                    sums = np.zeros((d.size, x.size), dtype=complex)
                vals = sums + d[:, None]
                for k, near in enumerate(nears):
                    if near is not None:
                        vals[k] += near(x)
                out = out * np.prod(vals, axis=0)
        for fa in others:
            out = out * fa.response(flat)
        return out.reshape(f.shape)

    return resp
