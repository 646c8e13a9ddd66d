"""Independent references for the margins core in mpmath (tests and bench/margins.py).

Crossings as roots of polynomials in ω² at 50 digits (an all-pole loop ``K / den(s)``:
``Im den(jω) = 0`` and ``|den(jω)|² = K²``, the generalised Routh-Hurwitz condition), or
mpmath's secant root of the loop evaluated at 40 digits from the system's own (double)
coefficients or matrices.
"""

from __future__ import annotations

import control
import mpmath
import numpy as np


def mp_poly(c: np.ndarray, x: mpmath.mpc) -> mpmath.mpc:
    return mpmath.polyval([mpmath.mpf(float(v)) for v in c], x)


def mp_loop(systems: list, f: mpmath.mpf) -> mpmath.mpc:
    """The loop at ``f`` [Hz] in mpmath from each system's own (double) data."""
    out = mpmath.mpc(1)
    for sys in systems:
        dt = sys.dt if sys.dt not in (None, 0, False, True) else None
        x = mpmath.exp(2j * mpmath.pi * f * dt) if dt else 2j * mpmath.pi * f
        if isinstance(sys, control.TransferFunction):
            out *= mp_poly(sys.num[0][0], x) / mp_poly(sys.den[0][0], x)
        else:
            a, b, c = (mpmath.matrix(np.asarray(m, float).tolist()) for m in (sys.A, sys.B, sys.C))
            y = mpmath.lu_solve(x * mpmath.eye(a.rows) - a, b)
            out *= (c * y)[0] + float(np.asarray(sys.D).ravel()[0])
    return out


def mp_root(systems: list, f0: float, kind: str) -> float:
    """The true crossing nearest ``f0`` (secant at 40 digits on ``log|L|`` or ``Im L/|L|``)."""
    with mpmath.workdps(40):

        def h(f: mpmath.mpf) -> mpmath.mpf:
            v = mp_loop(systems, f)
            return mpmath.log(abs(v)) if kind == "gain" else v.imag / abs(v)

        return float(mpmath.findroot(h, (mpmath.mpf(f0), mpmath.mpf(f0) * (1 + 1e-7))))


def all_pole_reference(den: np.ndarray, k: float) -> tuple[list[float], list[float], list[float]]:
    """Phase crossovers [Hz], their gain margins (linear) and gain crossovers [Hz] of
    ``k / den(s)`` from polynomial roots in ω² at 50 digits."""
    with mpmath.workdps(50):
        n = den.size - 1
        c = [mpmath.mpf(float(v)) for v in den]  # den(s) = Σ c[i] s^(n-i)
        re = [mpmath.mpf(0)] * (n + 1)  # Re den(jω) and Im den(jω)/ω as polynomials in ω
        im = [mpmath.mpf(0)] * (n + 1)
        for i, ci in enumerate(c):
            p = n - i  # (jω)^p = j^p ω^p
            (re if p % 2 == 0 else im)[p] += ci * (1 if p % 4 in (0, 1) else -1)
        # Im den(jω) = ω q(ω²), q from the odd coefficients
        q = [im[p] for p in range(n if n % 2 else n - 1, 0, -2)]
        # a phase crossover needs L = k/den real and negative: Re den(jω) < 0
        w180 = [w for w in positive_roots_in_w2(q) if mpmath.re(mpmath.polyval(c, 1j * w)) < 0]
        gms = [abs(mpmath.polyval(c, 1j * w)) / k for w in w180]
        # |den(jω)|² - k² as a polynomial in ω² (even by construction)
        mag = [mpmath.mpf(0)] * (2 * n + 1)
        for a in range(n + 1):
            for b in range(n + 1):
                mag[a + b] += re[a] * re[b] + im[a] * im[b]
        mag[0] -= k * k
        wc = positive_roots_in_w2([mag[p] for p in range(2 * n, -1, -2)])
        hz = [float(w / (2 * mpmath.pi)) for w in w180]
        return hz, [float(g) for g in gms], [float(w / (2 * mpmath.pi)) for w in wc]


def positive_roots_in_w2(coeffs: list) -> list:
    """Positive ω with ``Σ coeffs[i] (ω²)^(m-i) = 0`` (real positive roots in ω²)."""
    while coeffs and coeffs[0] == 0:
        coeffs = coeffs[1:]
    if len(coeffs) < 2:
        return []
    # in u = ω² / s with s the geometric size of the roots, so that they are O(1): on
    # unscaled coefficients (poles near 100 rad/s, ω² ~ 1e4 to the 6th power) a cluster
    # left Durand-Kerner unconverged after 400 steps
    m = len(coeffs) - 1
    s = abs(coeffs[-1] / coeffs[0]) ** (mpmath.mpf(1) / m) if coeffs[-1] != 0 else 1
    scaled = [c * s ** (m - i) for i, c in enumerate(coeffs)]
    roots = [r * s for r in mpmath.polyroots(scaled, maxsteps=2000, extraprec=400)]
    scale = max(abs(r) for r in roots)
    real = [mpmath.re(r) for r in roots if abs(mpmath.im(r)) <= 1e-30 * scale]
    return sorted(mpmath.sqrt(r) for r in real if r > 0)


def numerator_roots_mp(A: np.ndarray, b: np.ndarray, c: np.ndarray, dps: int = 150) -> np.ndarray:
    """Roots of ``c adj(sI - A) b = det(sI - A + b c) - det(sI - A)`` in ``dps`` digits
    (Faddeev-LeVerrier characteristic polynomials, mpmath ``polyroots``)."""
    n = A.shape[0]

    def charpoly(M: mpmath.matrix) -> list:
        coeffs, Mk = [mpmath.mpf(1)], mpmath.zeros(n, n)
        for k in range(1, n + 1):
            Mk = M * Mk + coeffs[-1] * mpmath.eye(n)
            coeffs.append(-sum((M * Mk)[i, i] for i in range(n)) / k)
        return coeffs

    with mpmath.workdps(dps):
        # A - b c in mpmath: formed in double it rounds (a rigid body's 1e-3 beside a
        # mode's 2.4e6 moved the reference zero by 4e-8)
        Am = mpmath.matrix(A.tolist())
        bc = mpmath.matrix(b.reshape(-1, 1).tolist()) * mpmath.matrix(c.reshape(1, -1).tolist())
        pa, pb = charpoly(Am), charpoly(Am - bc)
        num = [x - y for x, y in zip(pb, pa, strict=True)]
        k = 0  # exact structural zeros of the leading Markov parameters
        while abs(num[k]) < mpmath.mpf(10) ** (20 - dps) * max(abs(pa[k]), 1):
            k += 1
        if len(num) - k == 1:  # a constant numerator: no zeros
            return np.zeros(0, dtype=complex)
        roots = mpmath.polyroots(num[k:], maxsteps=2000, extraprec=4 * dps)
        return np.array([complex(r) for r in roots])
