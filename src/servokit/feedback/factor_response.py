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
  backward stable for any ``A``; ``A`` balanced first, exactly, since unitary reductions
  of a badly scaled state lose digits);
* each Schur form is kept only where it agrees with the LU solve at the poles'
  frequencies (:func:`~servokit.feedback.exact_forms.agrees`): the split form of four
  real poles within 1e-3 relative, one 2e-6 from the other three, has an ill-conditioned
  Sylvester decoupling and was 3e-5 relative off; the whole Schur form of a six-pole
  cluster within 6e-5 relative was 6e-8 off. The next form is tried, and last the LU
  solve of ``(xI - A) y = B`` on every point (O(n^3) each).

Partial fractions are kept only where they agree with the factor's exact form
(:func:`~servokit.feedback.exact_forms.faithful`): nearly repeated poles make them cancel
(7.6e-7 relative off for poles 12, 12.5, 12.547; wrong in the first digit for
``(s+1)^3 (s+1.001)``), and such a factor keeps Horner or the Schur form instead.

A transfer function is evaluated as the user gave it (Horner on numerator and denominator,
which is what its coefficients define); a :class:`~servokit.models.ModalPlant` by its own
exact modal sum with the delay. Every factor also reports its poles, which the Nyquist
stability verdict needs. ``x`` is ``j 2π f`` for continuous factors and ``e^{j 2π f dt}``
for discrete ones.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.feedback.exact_forms import (
    Exact,
    agrees,
    dense_exact,
    faithful,
    horner_exact,
    root_errors,
)

__all__ = ["Factor", "clear_factor_cache", "loop_evaluator", "make_factor"]

#: Eigenvector condition number above which the Schur form replaces the diagonal form.
_MAX_COND = 1e8

#: Largest norm of the Sylvester solution ``X`` of a split Schur form that is kept
#: without checking it against the LU solve: ``S = [[I, X], [0, I]]`` has condition about
#: ``||X||^2``, which multiplies the rounding of the decoupled form. Measured: ``||X||``
#: 0 for a rigid body with 100 modes, 1.0 for a rigid body and one mode, 16 for its ZOH
#: image; 2.5e10 for the cluster whose split form was 3e-5 off.
_SPLIT_X_MAX = 1e2


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
    #: ``freq_hz -> (value, amplification)`` of a factor with ``pf`` by a form that does
    #: not cancel (Horner on a TF's coefficients, an LU solve for a state space), with its
    #: relative error in units of double rounding; used where the partial fractions
    #: cancel (:mod:`~servokit.feedback.accurate_response`).
    exact: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = field(
        default=None, repr=False
    )
    #: First-order error of each pole in ``pf`` (a TF's roots: their condition times the
    #: rounding): near a pole the fractions are off by ``|r_i| δλ_i / |x − λ_i|²`` even
    #: without cancelling (a discrete integrator at 0.7 Hz with dt = 1 ms: 1e-10).
    pole_error: np.ndarray | None = field(default=None, repr=False)


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
    exact = horner_exact(num, den, x_of)
    fa = Factor(resp, dt, poles, dt is None, sys, zeros=zeros, exact=exact)
    pf = _tf_partial_fractions(num, den, poles)
    if pf is not None and faithful(pf, x_of, exact, dt):
        fa.pf = pf
        fa.pole_error = root_errors(den, pf[0])
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


def _balanced(
    A: np.ndarray, B: np.ndarray, C: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(T^-1 A T, T^-1 B, C T)`` with ``T`` LAPACK's balancing (a permutation and powers
    of two: exact). The Schur forms below are unitary reductions, which mix the scales of
    a badly scaled state (a ZOH image with entries from 1e-29 to 2e5, a companion form
    with coefficients up to 1e13) and lost up to 4e-8 relative without it."""
    import scipy.linalg

    Ab, T = scipy.linalg.matrix_balance(A)
    return Ab, np.linalg.solve(T, B), C @ T


def _ss_factor(sys: Any, dt: float | None) -> Factor:
    A, B, C = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C))
    d = complex(np.asarray(sys.D, dtype=float).reshape(-1)[0]) if np.size(sys.D) else 0j
    x_of = _point(dt)
    if A.shape[0] == 0:
        return Factor(lambda f: np.full(np.shape(f), d), dt, np.zeros(0, complex), dt is None)
    zeros = _zeros(sys)
    exact = dense_exact(A, B, C, d, x_of)
    A, B, C = _balanced(A, B, C)
    eig = np.linalg.eig(A)
    diag = _diagonal(A, B, C, eig) if _repeated(eig[0]).size == 0 else None
    if diag is not None and not faithful((*diag, d), x_of, exact, dt):
        diag = None  # nearly repeated eigenvalues: their fractions cancel
    if diag is not None:
        lam, r = diag
        resp = _partial_fractions(lam, r, d, x_of)
        return Factor(resp, dt, lam, dt is None, sys, pf=(lam, r, d), zeros=zeros, exact=exact)
    return _schur_factor(sys, A, B, C, d, dt, eig[0], zeros, exact)


def _schur_factor(
    sys: Any,
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    d: complex,
    dt: float | None,
    lam: np.ndarray,
    zeros: np.ndarray,
    exact: Exact,
) -> Factor:
    """A state space without faithful partial fractions: the split Schur form (a Jordan
    cluster by back substitution, the rest by fractions), else the whole Schur form, each
    kept only where it :func:`~servokit.feedback.exact_forms.agrees` with the LU solve;
    else the LU solve itself on every point (see the module text)."""
    import scipy.linalg

    x_of = _point(dt)
    split = _split(A, lam)
    if split is not None:
        T, S, Z, k = split
        Sinv = np.linalg.inv(S)
        b = Sinv @ (Z.conj().T @ B[:, 0])
        c = C[0] @ Z @ S
        rest = _diagonal(T[k:, k:], b[k:, None], c[None, k:])
        if rest is not None:
            lam2, r2 = rest
            near = _triangular(T[:k, :k], b[:k], c[:k], 0j, lambda x: x)  # a function of x
            far = _partial_fractions(lam2, r2, d, x_of)
            poles = np.r_[np.diag(T[:k, :k]), lam2]

            def both(f: np.ndarray) -> np.ndarray:
                return near(x_of(f)) + far(f)

            # a well-conditioned decoupling (||X|| small) is accurate: no check needed
            # (its 3n LU probes cost O(n^4): 0.67 s for a rigid body and 100 modes)
            tame = np.linalg.norm(S[:k, k:]) <= _SPLIT_X_MAX
            if tame or agrees(both, poles, x_of, exact, dt):
                return Factor(
                    both,
                    dt,
                    poles,
                    dt is None,
                    sys,
                    pf=(lam2, r2, d),
                    near=near,
                    zeros=zeros,
                    exact=exact,
                )
    T, Z = scipy.linalg.schur(A.astype(complex), output="complex")
    poles = np.diag(T).copy()
    resp = _triangular(T, Z.conj().T @ B[:, 0], C[0] @ Z, d, x_of)
    if not agrees(resp, poles, x_of, exact, dt):
        resp = _values_of(exact)
    return Factor(resp, dt, poles, dt is None, sys, zeros=zeros, exact=exact)


def _values_of(exact: Exact) -> Callable[[np.ndarray], np.ndarray]:
    def resp(f: np.ndarray) -> np.ndarray:
        return exact(f)[0]

    return resp


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
    # an object of python-control exists only once python-control is loaded: a callable or
    # ModalPlant factor leaves it unloaded (start-up, issue 23)
    control = sys.modules.get("control")
    if control is not None and isinstance(item, control.LTI):
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


Sums = Callable[[np.ndarray, bool], tuple[np.ndarray, np.ndarray | None]]


def merged_sums(merged: list[Factor]) -> Sums:
    """Partial-fraction values of several factors at once, and optionally their sizes.

    Parameters
    ----------
    merged : list of Factor
        Factors with ``pf``.

    Returns
    -------
    callable
        ``(x, with_size) -> (values, sizes)``, both ``(len(merged), x.size)``: each
        factor's ``d + Σ r_i/(x − λ_i)`` (plus its ``near`` part) and, if asked, a bound
        of its error in units of the rounding, ``Σ |r_i/(x − λ_i)| (1 + δλ_i / (ε |x −
        λ_i|)) + |d|`` (``δλ_i`` the factor's ``pole_error``; None otherwise).
    """
    if not merged:
        return lambda x, with_size: (np.ones((0, x.size), dtype=complex), None)
    lam = np.concatenate([fa.pf[0] for fa in merged])
    res = np.concatenate([fa.pf[1] for fa in merged])
    d = np.array([fa.pf[2] for fa in merged])
    sizes = np.array([fa.pf[0].size for fa in merged])
    # reduceat takes the row at a repeated start: zero-pole factors are zeroed after it
    starts = np.minimum(np.r_[0, np.cumsum(sizes)[:-1]], max(lam.size - 1, 0))
    empty = sizes == 0
    nears = [(k, fa.near) for k, fa in enumerate(merged) if fa.near is not None]
    eps = np.finfo(float).eps
    # pole errors in units of the rounding (0 where unknown)
    weight = np.concatenate(
        [np.zeros(fa.pf[0].size) if fa.pole_error is None else fa.pole_error / eps for fa in merged]
    )
    weighted = bool(np.any(weight > 0))

    def per_factor(terms: np.ndarray, n: int) -> np.ndarray:
        if not lam.size:
            return np.zeros((d.size, n), dtype=terms.dtype)
        out = np.add.reduceat(terms, starts, axis=0)
        out[empty] = 0.0
        return out

    def sums(x: np.ndarray, with_size: bool) -> tuple[np.ndarray, np.ndarray | None]:
        with np.errstate(all="ignore"):  # a pole on the grid gives inf
            # poles along the first axis: the per-factor sums reduce contiguous rows
            diff = x[None, :] - lam[:, None]
            terms = res[:, None] / diff
            vals = per_factor(terms, x.size) + d[:, None]
            size = None
            if with_size:  # the error bound in units of the rounding: cancelling terms and
                # the poles' own errors, |r| δλ / |x - λ|^2
                mag = np.abs(terms)
                if weighted:
                    mag = mag * (1.0 + weight[:, None] / np.abs(diff))
                size = per_factor(mag, x.size) + np.abs(d)[:, None]
            for k, near in nears:
                part = near(x)
                vals[k] += part
                if size is not None:
                    size[k] += np.abs(part)
        return vals, size

    return sums


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
    sums = merged_sums(merged)

    def resp(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        flat = f.ravel()
        out = np.exp(-2j * np.pi * flat * tau) if tau else np.ones(flat.shape, dtype=complex)
        if merged:
            out = out * np.prod(sums(x_of(flat), False)[0], axis=0)
        for fa in others:
            out = out * fa.response(flat)
        return out.reshape(f.shape)

    return resp
