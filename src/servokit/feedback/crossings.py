"""Crossing search that cannot miss: adaptive refinement, bracketing, exact verification.

1. Start from a pole-aware grid (:func:`~servokit.models.frequency_grid.frequency_grid`).
2. Refine adaptively: wherever the phase of ``L`` or of ``1 + L`` turns by more than
   0.35 rad, or ``log|L|`` changes by more than 0.35, between neighbours, insert the
   midpoint; repeat until no interval jumps (a black-box callable gets resolved the same
   way). After this every interval is short against the variation of ``L``.
3. A gain crossover is a sign change of ``log|L|``; a phase crossover a sign change of
   ``Im L / |L|`` with ``Re L < 0`` at both ends (the phase moves < 0.35 rad per interval,
   so this is a pass through 180°). A crossing pair hidden inside one interval needs an
   extremum of the function there: every grid extremum close to zero is located exactly
   and splits its interval if it changes sign.
4. All brackets of all tests are shrunk together (128 sub-points per bracket per pass,
   one vectorised call of the fast response per pass) to a relative width of 1e-5, then
   finished on the accurate response (:mod:`~servokit.feedback.accurate_response`; its
   sign change re-checked at the bracket ends and, if the fast response's rounding moved
   it, looked for beside the bracket) by Illinois steps to ``|h| <= 1e-12`` (``h`` the
   log-magnitude or the sine of the phase: 1e-12 relative in ``|L|``, 1e-12 rad), with
   bisection to rounding where they stall (a very sharp crossing). Hidden pairs are
   located the same way (257-point zooming, vectorised over all candidates).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["adapt_grid", "cut_intervals", "find_crossings"]

Response = Callable[[np.ndarray], np.ndarray]

#: Largest phase turn [rad] and log-magnitude change between grid neighbours.
MAX_STEP = 0.35
#: |L| below which nothing is resolved or reported (a gain margin above 160 dB).
TINY = 1e-8
#: ``|h|`` at which a root whose refinement stalled (at the response's own rounding) is
#: accepted without bisection: 1e-9 relative in ``|L|``, 1e-9 rad of phase.
ACCEPT = 1e-9
#: Cap on grid points (a pathological black box must not hang the search).
MAX_POINTS = 2_000_000


def cut_intervals(f: np.ndarray, barriers: np.ndarray) -> np.ndarray:
    """Intervals ``[f_k, f_k+1]`` that straddle a pole on the stability boundary.

    Parameters
    ----------
    f : ndarray
        Sorted grid [Hz].
    barriers : ndarray
        Frequencies of boundary poles [Hz].

    Returns
    -------
    ndarray of bool
        One flag per interval (``f.size - 1``).
    """
    if barriers.size == 0:
        return np.zeros(f.size - 1, dtype=bool)
    k = np.searchsorted(f, barriers)
    cut = np.zeros(f.size - 1, dtype=bool)
    inside = (k > 0) & (k < f.size)
    cut[k[inside] - 1] = True
    return cut


def _bad_intervals(
    f: np.ndarray, L: np.ndarray, barriers: np.ndarray, quiet_above: float
) -> np.ndarray:
    with np.errstate(all="ignore"):
        turn = np.abs(np.angle(L[1:] / L[:-1]))
        turn1 = np.abs(np.angle((1 + L[1:]) / (1 + L[:-1])))
        dlog = np.abs(np.diff(np.log(np.abs(L))))
        top = np.maximum(np.abs(L[1:]), np.abs(L[:-1]))
        big = top > 0.5
    # above the search band only winding matters: |L| < 1/2 cannot wind around -1
    phase_matters = (f[1:] <= quiet_above) | big
    # the magnitude matters near 0 dB; falling into an exact zero of L (a Tustin zero at
    # Nyquist) from below -40 dB hides no crossing the packing has not resolved
    mag_matters = top > 1e-2
    jump = ((turn > MAX_STEP) | (turn1 > MAX_STEP)) & phase_matters
    jump |= (dlog > MAX_STEP) & mag_matters
    jump |= ~np.isfinite(turn + turn1) | ~np.isfinite(dlog) & mag_matters
    # next to a zero of L (|L| < 1e-8, a gain margin > 160 dB) there is nothing to find
    jump &= top > TINY
    return jump & (np.diff(f) > 1e-13 * f[1:]) & ~cut_intervals(f, barriers)


def adapt_grid(
    resp: Response,
    f: np.ndarray,
    L: np.ndarray | None = None,
    *,
    barriers: np.ndarray | None = None,
    quiet_above: float = np.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """Refine ``f`` until ``L = resp(f)`` turns and changes little between neighbours.

    Parameters
    ----------
    resp : callable
        Exact response ``freq_hz -> complex``.
    f : ndarray
        Sorted starting grid [Hz].
    L : ndarray, optional
        ``resp(f)`` if already computed.
    barriers : ndarray, optional
        Frequencies of poles on the stability boundary [Hz]; the intervals around them
        are left alone (the phase jumps there by ``m π``).
    quiet_above : float
        Above this frequency [Hz] the phase is resolved only where ``|L| > 1/2``.

    Returns
    -------
    f, L : ndarray
        The refined grid and the response on it.
    """
    L = resp(f) if L is None else L
    barriers = np.zeros(0) if barriers is None else np.asarray(barriers, dtype=float)
    for _ in range(60):
        bad = np.nonzero(_bad_intervals(f, L, barriers, quiet_above))[0]
        if bad.size == 0 or f.size + bad.size > MAX_POINTS:
            break
        # fifteen interior points per bad interval: converges in few passes
        t = np.arange(1, 16) / 16.0
        new = (f[bad, None] + (f[bad + 1] - f[bad])[:, None] * t).ravel()
        Ln = resp(new)
        f = np.concatenate([f, new])
        L = np.concatenate([L, Ln])
        order = np.argsort(f, kind="stable")
        f, L = f[order], L[order]
    return f, L


Test = tuple[Callable[[np.ndarray], np.ndarray], np.ndarray]


def _rowwise(resp: Response, x: np.ndarray, which: np.ndarray, tests: list[Test]) -> np.ndarray:
    """``h_i(resp(x))`` row by row, ``i = which[row]``, with one call of ``resp``."""
    Lx = resp(x.ravel()).reshape(x.shape)
    out = np.empty(x.shape)
    for i, (h, _) in enumerate(tests):
        rows = which == i
        if rows.any():
            out[rows] = h(Lx[rows])
    return out


def _shrink(
    resp: Response,
    tests: list[Test],
    which: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    ga: np.ndarray,
    gb: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Shrink all brackets [a, b] of sign changes together (128 sub-intervals per pass);
    returns the final brackets and the function values at their ends."""
    t = np.linspace(0.0, 1.0, 129)[1:-1]
    rows = np.arange(a.size)
    for _ in range(8):
        width = b - a
        # to 1e-5 relative: two regula-falsi steps then finish the root to rounding
        if np.all(width <= 1e-5 * b):
            break
        x = a[:, None] + width[:, None] * t
        gx = _rowwise(resp, x, which, tests)
        # first sub-point whose sign differs from the left end (or a zero)
        flip = (np.sign(gx) != np.sign(ga)[:, None]) | (gx == 0)
        has = flip.any(axis=1)
        k = np.where(has, np.argmax(flip, axis=1), t.size)
        prev = np.maximum(k - 1, 0)
        left = np.where(k > 0, x[rows, prev], a)
        lg = np.where(k > 0, gx[rows, prev], ga)
        right = np.where(has, x[rows, np.minimum(k, t.size - 1)], b)
        rg = np.where(has, gx[rows, np.minimum(k, t.size - 1)], gb)
        a, b, ga, gb = left, right, lg, rg
    return a, b, ga, gb


def _extrema(
    resp: Response, tests: list[Test], cands: list[tuple[int, float, float, float]]
) -> list[tuple[int, float, float, float, float]]:
    """Locate grid extrema (test, lo, hi, sign) by vectorised zooming; keep sign changes
    as (test, lo, extremum, hi, value at the extremum)."""
    if not cands:
        return []
    which = np.array([c[0] for c in cands])
    lo = np.array([c[1] for c in cands])
    hi = np.array([c[2] for c in cands])
    sign = np.array([c[3] for c in cands])
    a, b = lo.copy(), hi.copy()
    t = np.linspace(0.0, 1.0, 257)
    rows = np.arange(a.size)
    for _ in range(2):
        x = a[:, None] + (b - a)[:, None] * t
        gx = sign[:, None] * _rowwise(resp, x, which, tests)
        k = np.argmin(gx, axis=1)
        best, val = x[rows, k], gx[rows, k]
        step = (b - a) / 256
        a, b = np.maximum(lo, best - step), np.minimum(hi, best + step)
    return [
        (int(which[r]), float(lo[r]), float(best[r]), float(hi[r]), float(sign[r] * val[r]))
        for r in rows
        if val[r] < 0
    ]


def find_crossings(
    resp: Response,
    f: np.ndarray,
    L: np.ndarray,
    tests: list[Test],
    cut: np.ndarray | None = None,
    tol: float = 1e-12,
    exact: Response | None = None,
) -> list[list[float]]:
    """Roots of ``h(L(f))`` for each test ``(h, ok)``, bracketed on the grid and verified.

    Parameters
    ----------
    resp : callable
        Exact response ``freq_hz -> complex``.
    f : ndarray
        Adapted grid [Hz].
    L : ndarray
        ``resp(f)``.
    tests : list of (callable, ndarray of bool)
        ``h(L) -> real`` whose zeros are wanted and where on the grid a sign change may
        count (e.g. ``Re L < 0`` for phase crossings).
    cut : ndarray of bool, optional
        Intervals (``f.size - 1``) never to bracket (they straddle a boundary pole).
    tol : float
        ``|h|`` to which a root is refined (Illinois steps, then bisection); a root whose
        bracket reaches rounding first is kept (a sign change across adjacent doubles).
    exact : callable, optional
        Accurate response for the final refinement (a few points per root); ``resp``
        (used for the grid and the shrinking) when omitted.

    Returns
    -------
    list of list of float
        Sorted roots [Hz] per test.
    """
    cut = np.zeros(f.size - 1, dtype=bool) if cut is None else cut
    which: list[int] = []
    a: list[float] = []
    b: list[float] = []
    ga: list[float] = []
    gb: list[float] = []
    roots: list[list[float]] = []
    cands: list[tuple[int, float, float, float]] = []
    values = []
    for i, (h, ok) in enumerate(tests):
        v = h(L)
        values.append(v)
        fin = np.isfinite(v) & ok
        s = np.sign(v)
        idx = np.nonzero((s[:-1] * s[1:] < 0) & fin[:-1] & fin[1:] & ~cut)[0]
        which += [i] * idx.size
        a += list(f[idx])
        b += list(f[idx + 1])
        ga += list(v[idx])
        gb += list(v[idx + 1])
        roots.append([float(x) for x in f[(v == 0) & ok]])
        cands += _extremum_candidates(i, f, v, fin, cut)
    for i, lo, mid, hi, gmid in _extrema(resp, tests, cands):
        v = values[i]
        k = int(np.searchsorted(f, lo))
        which += [i, i]
        a += [lo, mid]
        b += [mid, hi]
        ga += [float(v[k]), gmid]
        gb += [gmid, float(v[k + 2])]
    if a:
        w_arr = np.array(which)
        lo_arr, hi_arr, g0, g1 = _shrink(
            resp, tests, w_arr, np.array(a), np.array(b), np.array(ga), np.array(gb)
        )
        x, gx = _finish(exact or resp, tests, w_arr, lo_arr, hi_arr, g0, g1, tol, exact is not None)
        for r, e, i in zip(x, gx, w_arr, strict=True):
            if abs(e) <= max(tol, ACCEPT) or np.isnan(e):
                roots[i].append(float(r))
    return [sorted(set(r)) for r in roots]


def _finish(
    final: Response,
    tests: list[Test],
    which: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    ga: np.ndarray,
    gb: np.ndarray,
    tol: float,
    recheck: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Roots in the shrunk brackets on the ``final`` response: Illinois steps to ``tol``,
    bisection where they stall. Returns the roots and ``h`` there (NaN: a sign change
    across adjacent doubles; inf: no sign change of ``final`` near the bracket).

    With ``recheck`` (``final`` is not the response the brackets were shrunk on) the
    bracket ends are evaluated again with the first secant point, in one call; a bracket
    on which ``final`` does not change sign is moved beside it (:func:`_widen`)."""
    br = _Brackets(a.copy(), b.copy(), ga.copy(), gb.copy(), np.zeros(a.size, dtype=int))
    x, gx = _secant(a, b, ga, gb), np.full(a.size, np.inf)
    found = np.ones(a.size, dtype=bool)
    active = np.isfinite(ga + gb)
    if recheck:
        g = _rowwise(final, np.stack([a, b, x], axis=1), which, tests)
        br.ga, br.gb = g[:, 0], g[:, 1]
        ok = _changes_sign(br.ga, br.gb)
        i = np.nonzero(ok)[0]
        gx[i] = g[i, 2]
        active[i] = br.step(i, x[i], gx[i], tol)
        j = np.nonzero(~ok)[0]
        if j.size:  # the fast response's rounding moved its root out of the bracket
            br.a[j], br.b[j], br.ga[j], br.gb[j], found[j] = _widen(
                final, tests, which[j], a[j], b[j], br.ga[j], br.gb[j]
            )
            x[j], active[j] = _secant(br.a[j], br.b[j], br.ga[j], br.gb[j]), found[j]
    x, gx = _illinois(final, tests, which, br, x, gx, active, tol)
    # Illinois stalls at the response's own noise (accepted below 1e-9); above it is a
    # very sharp crossing (zeta ~ 1e-6): bisect to tol or rounding
    hard = ~(np.abs(gx) <= max(tol, ACCEPT)) & found
    if hard.any():
        i = np.nonzero(hard)[0]
        x[i], gx[i] = _bisect(final, tests, which[i], br.a[i], br.b[i], br.ga[i], tol)
    gx[~found] = np.inf
    return x, gx


def _changes_sign(ga: np.ndarray, gb: np.ndarray) -> np.ndarray:
    return ((np.sign(ga) != np.sign(gb)) | (ga == 0) | (gb == 0)) & np.isfinite(ga + gb)


@dataclass
class _Brackets:
    """Brackets ``[a, b]`` with the values at their ends and the end the last Illinois
    step replaced (+1 left, -1 right, 0 none yet)."""

    a: np.ndarray
    b: np.ndarray
    ga: np.ndarray
    gb: np.ndarray
    side: np.ndarray

    def step(self, i: np.ndarray, x: np.ndarray, g: np.ndarray, tol: float) -> np.ndarray:
        """Replace an end of brackets ``i`` by ``x`` (value ``g``); Illinois: an end kept
        twice in a row has its value halved (superlinear convergence). Returns whether
        each bracket still needs a step."""
        fin = np.isfinite(g)
        left = (np.sign(g) == np.sign(self.ga[i])) & fin  # the root is right of x
        right = ~left & fin
        self.gb[i] = np.where(left & (self.side[i] == 1), 0.5 * self.gb[i], self.gb[i])
        self.ga[i] = np.where(right & (self.side[i] == -1), 0.5 * self.ga[i], self.ga[i])
        self.a[i], self.ga[i] = np.where(left, x, self.a[i]), np.where(left, g, self.ga[i])
        self.b[i], self.gb[i] = np.where(right, x, self.b[i]), np.where(right, g, self.gb[i])
        self.side[i] = np.where(left, 1, -1)
        wide = self.b[i] - self.a[i] > 4e-16 * np.abs(self.b[i])
        return fin & (np.abs(g) > tol) & wide


def _illinois(
    final: Response,
    tests: list[Test],
    which: np.ndarray,
    br: _Brackets,
    x: np.ndarray,
    gx: np.ndarray,
    active: np.ndarray,
    tol: float,
    steps: int = 8,
) -> tuple[np.ndarray, np.ndarray]:
    """Illinois steps on the active brackets until ``|h| <= tol`` or rounding. Returns
    the last point of each bracket and its value."""
    for _ in range(steps):
        i = np.nonzero(active)[0]
        if i.size == 0:
            break
        xi = _secant(br.a[i], br.b[i], br.ga[i], br.gb[i])
        gi = _rowwise(final, xi[:, None], which[i], tests)[:, 0]
        x[i], gx[i] = xi, gi
        active[i] = br.step(i, xi, gi, tol)
    return x, gx


def _widen(
    final: Response,
    tests: list[Test],
    which: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    ga: np.ndarray,
    gb: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Brackets beside ``[a, b]`` (where ``final`` keeps its sign; values ``ga, gb``):
    ``[a - kw, a]`` or ``[b, b + kw]`` for the smallest k of 1, 4, 16, 64 (w = b - a)
    with a sign change, left first. Returns the brackets, their end values and whether
    one was found (none: the fast response's crossing was a rounding artefact)."""
    w = (b - a)[:, None]
    k = np.array([1.0, 4.0, 16.0, 64.0])
    pts = np.concatenate([a[:, None] - k * w, b[:, None] + k * w], axis=1)
    g = _rowwise(final, pts, which, tests)
    gl, gr = g[:, :4], g[:, 4:]
    ok_l = (np.sign(gl) != np.sign(ga)[:, None]) & np.isfinite(gl)
    ok_r = (np.sign(gr) != np.sign(gb)[:, None]) & np.isfinite(gr)
    pick = np.argmax(np.stack([ok_l, ok_r], axis=2).reshape(a.size, -1), axis=1)
    j, right = pick // 2, pick % 2 == 1
    rows = np.arange(a.size)
    found = ok_l.any(axis=1) | ok_r.any(axis=1)
    new_a = np.where(right, b, pts[rows, j])
    new_b = np.where(right, pts[rows, 4 + j], a)
    new_ga = np.where(right, gb, gl[rows, j])
    new_gb = np.where(right, gr[rows, j], ga)
    return new_a, new_b, new_ga, new_gb, found


def _bisect(
    resp: Response,
    tests: list[Test],
    which: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    ga: np.ndarray,
    tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Bisect brackets with a verified sign change down to a few ulps. Returns the midpoint
    and its value, or NaN as value when the bracket reached rounding with ``|g| > tol``
    (a sign change verified on the exact response across adjacent doubles: a crossing)."""
    a, b, ga = a.copy(), b.copy(), ga.copy()
    for _ in range(60):
        m = 0.5 * (a + b)
        gm = _rowwise(resp, m[:, None], which, tests)[:, 0]
        if np.all((np.abs(gm) <= tol) | (b - a <= 4e-16 * b)):
            break
        same = np.sign(gm) == np.sign(ga)
        a, ga = np.where(same, m, a), np.where(same, gm, ga)
        b = np.where(same, b, m)
    return m, np.where(np.abs(gm) <= tol, gm, np.nan)


def _secant(a: np.ndarray, b: np.ndarray, ga: np.ndarray, gb: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        w = np.where(gb != ga, ga / (ga - gb), 0.5)
    return a + np.clip(w, 0, 1) * (b - a)


def _extremum_candidates(
    i: int, f: np.ndarray, v: np.ndarray, ok: np.ndarray, cut: np.ndarray
) -> list[tuple[int, float, float, float]]:
    """Grid extrema of ``v`` on the wrong side of zero that might hide a crossing pair.

    The parabola through the three grid points predicts the dip below the middle one; a
    candidate is kept when zero lies within three times that dip (a generous margin: the
    zooming that follows decides)."""
    # a grid point exactly on zero at an extremum may still hide a pair beside it
    mins = (v[1:-1] < v[:-2]) & (v[1:-1] <= v[2:]) & (v[1:-1] >= 0)
    maxs = (v[1:-1] > v[:-2]) & (v[1:-1] >= v[2:]) & (v[1:-1] <= 0)
    whole = ok[:-2] & ok[1:-1] & ok[2:] & ~cut[:-1] & ~cut[1:]
    ks = np.nonzero((mins | maxs) & whole & (np.abs(v[1:-1]) < 0.1))[0] + 1
    is_min = mins[ks - 1]
    out = []
    for k, lowest in zip(ks, is_min, strict=True):
        x0, x1, x2 = f[k - 1] - f[k], 0.0, f[k + 1] - f[k]
        y0, y1, y2 = v[k - 1], v[k], v[k + 1]
        # vertex of the interpolating parabola (divided differences)
        d01 = (y1 - y0) / (x1 - x0)
        d12 = (y2 - y1) / (x2 - x1)
        c2 = (d12 - d01) / (x2 - x0)
        c1 = d01 - c2 * (x0 + x1)
        dip = c1 * c1 / (4 * c2) if c2 != 0 else np.inf  # y1 - vertex value
        if abs(y1) <= 3 * abs(dip) + 1e-12:
            out.append((i, float(f[k - 1]), float(f[k + 1]), 1.0 if lowest else -1.0))
    return out
