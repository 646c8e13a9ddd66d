"""Exact (non-cancelling) forms of loop factors, and the check that a factor's partial
fractions agree with them.

A factor's partial fractions (:mod:`~servokit.feedback.factor_response`) are fast but
cancel near clustered poles; these forms do not: Horner on a transfer function's own
coefficients in long double, with Horner's running error bound, and an LU solve of
``(xI − A) y = B`` on a state space's own matrices (python-control's evaluation). Both
return ``(value, amplification)``, the relative error in units of double rounding.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = [
    "Exact",
    "agrees",
    "dense_exact",
    "faithful",
    "horner_exact",
    "probe_freqs",
    "root_errors",
]

Exact = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]

#: Unit roundoff of the extended precision of the Horner evaluation relative to double
#: (2^-11 on x86-64's 80-bit long double, 1 where long double is double).
_LD_GAIN = float(np.finfo(np.longdouble).eps / np.finfo(float).eps)


def horner_exact(
    num: np.ndarray, den: np.ndarray, x_of: Callable[[np.ndarray], np.ndarray]
) -> Exact:
    """Horner on the TF's coefficients in long double, with the error amplification
    ``(deg + 1)(Σ|a_i||x|^i / |a(x)| + Σ|b_i||x|^i / |b(x)|)`` (in units of double
    rounding): the classic running bound of Horner's rule.

    Parameters
    ----------
    num, den : ndarray
        Coefficients, highest power first.
    x_of : callable
        ``freq_hz -> x`` (``j 2π f`` or ``e^{j 2π f dt}``).

    Returns
    -------
    callable
        ``freq_hz -> (value, amplification)``.
    """
    cn, cd = (c.astype(np.longdouble) for c in (num, den))

    def resp(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = x_of(f).astype(np.clongdouble)
        ax = np.abs(x)
        amp = np.zeros(x.shape, dtype=np.longdouble)
        vals = []
        for c in (cn, cd):
            p = np.full(x.shape, c[0], dtype=np.clongdouble)
            bound = np.full(x.shape, abs(c[0]), dtype=np.longdouble)
            for ci in c[1:]:
                p = p * x + ci
                bound = bound * ax + abs(ci)
            with np.errstate(all="ignore"):
                amp += bound / np.abs(p)
            vals.append(p)
        with np.errstate(all="ignore"):  # a pole on the point gives inf, handled by callers
            val = (vals[0] / vals[1]).astype(complex)
        return val, (amp * max(cn.size, cd.size) * _LD_GAIN).astype(float)

    return resp


def dense_exact(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    d: complex,
    x_of: Callable[[np.ndarray], np.ndarray],
) -> Exact:
    """``C (xI - A)^{-1} B + d`` by one LU solve per point on the system's own matrices
    (python-control's evaluation). Unitary reductions (Schur, Hessenberg) mix the scales
    of a badly scaled state (entries of a ZOH image from 1e-29 to 2e5) and lose up to
    1e-8 relative; the LU solve keeps 1e-13. O(n^3) per point: for the few points of a
    final refinement only. Its amplification is reported as 1 (no cheap estimate).

    Parameters
    ----------
    A, B, C : ndarray
        State-space matrices (single input, single output).
    d : complex
        Feedthrough.
    x_of : callable
        ``freq_hz -> x`` (``j 2π f`` or ``e^{j 2π f dt}``).

    Returns
    -------
    callable
        ``freq_hz -> (value, amplification)``.
    """
    A, B, C = A.copy(), B.astype(complex), C[0].copy()  # the closure outlives the system
    eye = np.eye(A.shape[0])
    # points per batched solve: its matrices stay near _SOLVE_BYTES (a 200-state factor on
    # 600 points took 0.8 GB in one batch)
    step = max(1, _SOLVE_BYTES // (16 * max(1, A.size)))

    def solve(x: np.ndarray) -> np.ndarray:
        try:
            y = np.linalg.solve(x[:, None, None] * eye - A, np.broadcast_to(B, (x.size, *B.shape)))
        except np.linalg.LinAlgError:  # a pole exactly on a point: inf there, not everywhere
            if x.size == 1:
                return np.full(1, np.inf + 0j)
            return np.concatenate([solve(x[k : k + 1]) for k in range(x.size)])
        return y[..., 0] @ C + d

    def resp(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = x_of(f).ravel()
        out = np.empty(x.size, dtype=complex)
        for k in range(0, x.size, step):
            out[k : k + step] = solve(x[k : k + step])
        return out.reshape(np.shape(f)), np.ones(np.shape(f))

    return resp


#: Size of the matrices of one batched LU solve in :func:`dense_exact` [bytes].
_SOLVE_BYTES = 32_000_000


def root_errors(p: np.ndarray, roots: np.ndarray) -> np.ndarray:
    """``ε Σ|p_j||λ|^j / |p'(λ)|``: the error of computed roots of a polynomial (their
    condition number for a componentwise backward error ε).

    Parameters
    ----------
    p : ndarray
        Polynomial coefficients, highest power first.
    roots : ndarray
        Its computed roots.

    Returns
    -------
    ndarray
        First-order error of each root (0 where it cannot be estimated).
    """
    with np.errstate(all="ignore"):
        size = np.polyval(np.abs(p), np.abs(roots))
        err = np.finfo(float).eps * size / np.abs(np.polyval(np.polyder(p), roots))
    return np.where(np.isfinite(err), err, 0.0)


#: Largest relative difference between a reduced form and the exact one at the probes.
FAITHFUL = 1e-10


def faithful(
    pf: tuple[np.ndarray, np.ndarray, complex],
    x_of: Callable[[np.ndarray], np.ndarray],
    exact: Exact,
    dt: float | None,
) -> bool:
    """Whether partial fractions ``pf`` agree with the factor's exact form to
    :data:`FAITHFUL` at half, once and twice every pole's frequency (where a loop turns).

    Nearly repeated poles make the residues large and the fractions cancel: for
    ``(s+1)^3 (s+1.001)`` the computed poles are split by 1e-4 and the fractions are
    wrong in the first digit at ``s = j``, so no crossing there would be found; a
    cluster of three poles 4e-3 apart is 7.6e-7 relative off. Such a factor keeps its
    exact form on the whole grid. The exact form is evaluated only where the fractions
    cancel by more than a factor 100 (cheap for the usual well separated poles).

    Parameters
    ----------
    pf : tuple
        ``(poles, residues, feedthrough)``.
    x_of : callable
        ``freq_hz -> x`` (``j 2π f`` or ``e^{j 2π f dt}``).
    exact : callable
        The factor's exact form, ``freq_hz -> (value, amplification)``.
    dt : float or None
        Sampling period [s] (None: continuous).

    Returns
    -------
    bool
    """
    lam, r, d = pf
    f = probe_freqs(lam, dt)
    with np.errstate(all="ignore"):
        terms = r / (x_of(f)[:, None] - lam)
        fast = terms.sum(axis=1) + d
        kappa = (np.abs(terms).sum(axis=1) + abs(d)) / np.abs(fast)
    check = ~(kappa <= 100.0)
    if not check.any():
        return True
    ref, amp = exact(f[check])
    with np.errstate(all="ignore"):
        err = np.abs(fast[check] - ref) / np.abs(ref)
    # judged wherever the exact form is finite, non-zero and accurate enough: fractions
    # that are NaN or infinite there are not faithful (their error is NaN, not small)
    known = np.isfinite(ref) & (ref != 0)
    trusted = known & (amp * np.finfo(float).eps < 0.1 * FAITHFUL)
    return bool(np.all(err[trusted] <= FAITHFUL))


def probe_freqs(poles: np.ndarray, dt: float | None) -> np.ndarray:
    """Half, once and twice every pole's frequency [Hz] (where a loop turns), inside the
    band (below Nyquist for a discrete factor); poles at 0 (s or z) give none.

    Parameters
    ----------
    poles : ndarray
        Poles in s (continuous) or z (discrete).
    dt : float or None
        Sampling period [s] (None: continuous).

    Returns
    -------
    ndarray
        Probe frequencies [Hz].
    """
    with np.errstate(all="ignore"):
        s = np.log(poles[poles != 0]) / dt if dt is not None else poles
        f0 = np.abs(s[np.isfinite(s)]) / (2 * np.pi)
    f = np.concatenate([0.5 * f0, f0, 2 * f0])
    return f[f > 0] if dt is None else f[(f > 0) & (f < 0.5 / dt * (1 - 1e-9))]


def agrees(
    resp: Callable[[np.ndarray], np.ndarray],
    poles: np.ndarray,
    x_of: Callable[[np.ndarray], np.ndarray],
    exact: Exact,
    dt: float | None,
) -> bool:
    """Whether a reduced form ``resp`` of a state space agrees with its LU solve ``exact``
    to :data:`FAITHFUL` at the :func:`probe_freqs` of its ``poles``.

    Near a cluster of nearly repeated poles the Schur forms lose digits: the split form
    decouples the cluster by a Sylvester equation that is ill-conditioned when a pole
    outside it is close (four real poles within 1e-3 relative: 3e-5 relative off at the
    cluster's frequency, enough to move a phase crossover out of its bracket), and the
    whole Schur form of a six-pole cluster within 6e-5 relative was 6e-8 off
    (``tests/test_margins_accuracy.py``). A probe on a pole (an undamped mode's own
    frequency: ``|x - λ| <= 10 ε |x| / FAITHFUL``) is skipped, as is a point where the LU
    solve is infinite or zero; a reduced form that is not finite elsewhere does not agree.

    Parameters
    ----------
    resp : callable
        ``freq_hz -> complex`` by the reduced form.
    poles : ndarray
        Its poles (s or z).
    x_of : callable
        ``freq_hz -> x`` (``j 2π f`` or ``e^{j 2π f dt}``).
    exact : callable
        The LU solve, ``freq_hz -> (value, amplification)``.
    dt : float or None
        Sampling period [s] (None: continuous).

    Returns
    -------
    bool
    """
    f = probe_freqs(poles, dt)
    x = x_of(f)
    # a probe on a pole (an undamped mode's own frequency) is skipped: there both forms are
    # rounding over a vanishing |x - λ| and differ by O(1) relative; elsewhere each is
    # within ~ε|x|/|x - λ| relative, trusted where that is below a tenth of FAITHFUL
    gap = np.min(np.abs(x[:, None] - poles[None, :]), axis=1, initial=np.inf)
    f = f[gap * 0.1 * FAITHFUL > np.finfo(float).eps * np.maximum(np.abs(x), 1e-300)]
    if not f.size:
        return True
    ref = exact(f)[0]
    # and a point on a pole (or a zero) of the LU solve: a reduced form that is not finite
    # where the LU solve is does not agree (its error is NaN, not <= FAITHFUL)
    known = np.isfinite(ref) & (ref != 0)
    with np.errstate(all="ignore"):
        err = np.abs(resp(f[known]) - ref[known]) / np.abs(ref[known])
    return bool(np.all(err <= FAITHFUL))
