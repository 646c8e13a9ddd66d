"""The linear programs of the admissible sets, most of them answered without a solver.

:mod:`servokit.switching.admissible` asks two questions of a polytope
``P = {x : H x <= h}`` (rows of unit length):

1. *Is the row c x <= b implied by P?*  (finite determination, Gilbert-Tan): the LP
   ``max_P c x <= b + tol (1 + |b|)``.
2. *Which rows are redundant?*  Row ``i`` is redundant when ``max c x`` over the other
   rows stays within its bound (the same test).

Each costs a HiGHS solve through ``scipy.optimize.linprog`` (ms each, mostly call
overhead: 1749 of them made 10 % of ``servokit reproduce``, issue 24; the LPs that are
left go through :func:`servokit._highs_lp.linprog_highs`, ``linprog``'s answer with
less overhead).  Most answers have a certificate that takes one matrix product for all rows at once:

* **a witness point** (answer "not implied"/"not redundant"): a point ``x`` that meets
  every other row and breaks the tested one by more than the tolerance proves the LP
  maximum above the bound.  Points come from rays out of an interior point ``x0``: the
  ray leaves ``P`` through the row with the smallest ratio ``(h - H x0) / (H d)``; half
  way to the next row's crossing it breaks that row only.  Directions: the rows'
  normals, the same whitened by the shape matrix ``H^T diag(1/h^2) H`` (a round picture
  of ``P``) and random ones.
* **the vertices** (answer "redundant"), in 2-D and 3-D only (``scipy.spatial``'s
  Qhull): a row whose maximum over the vertices of ``P`` stays clear below its bound
  does not touch ``P``, so dropping the other redundant rows cannot enlarge ``P`` past it
  and the sequential LP test finds the same maximum.

Every witness is re-evaluated exactly (``H x - h`` in floating point), so a certificate
can only say what the LP says; the rows and candidates left undecided (near-duplicate,
touching or barely violated rows) go to the LP in the original order, with the original
set of other rows.  The result equals the LP-only path (tested against it).
"""

from __future__ import annotations

import numpy as np

from servokit.errors import ServokitValueError

__all__ = ["lp_max", "not_implied", "prune_rows"]

#: relative tolerance of "implied" (as in the LP-only path)
TOL = 1e-9
#: a certificate must clear the LP's decision threshold by this factor of ``TOL``
_SAFETY = 100.0
#: random ray directions per row of ``H`` for the witnesses of non-redundancy
_RANDOM_PER_ROW = 4
#: up to this dimension redundancy is certified from the vertices (Qhull)
_VERTEX_DIM = 3


def lp_max(c: np.ndarray, H: np.ndarray, h: np.ndarray) -> float:
    """``max c x`` subject to ``H x <= h`` by HiGHS (``inf`` if unbounded).

    Parameters
    ----------
    c : ndarray (N,)
        Objective.
    H, h : ndarray (q, N), (q,)
        Constraints.

    Returns
    -------
    float
        The maximum.
    """
    from servokit._highs_lp import linprog_highs  # linprog's answer, less call overhead

    free = [(None, None)] * len(c)
    res = linprog_highs(-c, H, h, free)
    if res.status == 2:  # HiGHS presolve may report an unbounded LP as infeasible
        res = linprog_highs(-c, H, h, free, presolve=False)
    if res.status == 3:
        return np.inf
    if res.status != 0:
        raise ServokitValueError(f"the admissible-set LP failed: {res.message}")
    return float(-res.fun)


def _limit(b: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """The LP decision threshold ``b + tol (1 + |b|)`` (times ``scale`` for a margin)."""
    return b + scale * TOL * (1.0 + np.abs(b))


def _shape_directions(H: np.ndarray, h: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Columns ``M^+ c`` for the rows ``c`` of ``C``, ``M = H^T diag(1/h^2) H``: the
    direction in which an ellipsoid shaped like ``P`` reaches furthest along ``c``."""
    Hs = H / h[:, None]
    M = Hs.T @ Hs
    return np.linalg.pinv(M, hermitian=True) @ C.T


def _ray_points(
    H: np.ndarray, slack: np.ndarray, x0: np.ndarray, D: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where the rays ``x0 + s d`` (columns of ``D``) leave ``P``: first row, its ratio
    ``s1`` and the next ratio ``s2`` (``inf`` where the ray never meets a row)."""
    HD = H @ D
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(HD > 0, slack[:, None] / HD, np.inf)
    if s.shape[0] == 1:
        return np.zeros(D.shape[1], dtype=int), s[0], np.full(D.shape[1], np.inf), HD
    two = np.partition(s, 1, axis=0)[:2]
    return np.argmin(s, axis=0), two[0], two[1], HD


def _rows_with_witness(H: np.ndarray, h: np.ndarray, x0: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Rows that a ray of ``D`` proves non-redundant (boolean mask over the rows)."""
    slack = h - H @ x0
    first, s1, s2, _ = _ray_points(H, slack, x0, D)
    ok = np.isfinite(s1)
    first, s1, s2, D = first[ok], s1[ok], s2[ok], D[:, ok]
    s = np.where(np.isfinite(s2), 0.5 * (s1 + s2), 2.0 * s1 + 1.0)
    X = x0[:, None] + s * D
    V = H @ X - h[:, None]  # exact re-evaluation of every row at every witness
    cols = np.arange(X.shape[1])
    breaks = V[first, cols] > _limit(h[first], _SAFETY) - h[first]
    V[first, cols] = -np.inf
    good = breaks & np.all(V <= 0.0, axis=0)
    found = np.zeros(len(h), dtype=bool)
    found[first[good]] = True
    return found


def _interior(H: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """A point strictly inside ``P``: the origin when it is, else the Chebyshev centre
    (None if ``P`` has no interior)."""
    N = H.shape[1]
    if np.all(h > 0):
        return np.zeros(N)
    c = np.zeros(N + 1)
    c[-1] = -1.0
    A = np.hstack([H, np.ones((len(h), 1))])
    from servokit._highs_lp import linprog_highs

    res = linprog_highs(c, A, h, [(None, None)] * N + [(0, 1.0)])
    if res.status != 0 or res.x[-1] <= 0:
        return None
    return res.x[:N]


def _witness_directions(H: np.ndarray, h: np.ndarray, seed: int = 0) -> np.ndarray:
    """Ray directions for the non-redundancy witnesses: normals, whitened normals, and
    random directions whitened the same way (fixed seed: reproducible)."""
    W = _shape_directions(H, h, H)
    rng = np.random.default_rng(seed)
    G = rng.standard_normal((H.shape[1], _RANDOM_PER_ROW * H.shape[0]))
    return np.hstack([H.T, W, _shape_directions(H, h, G.T)])


def _clear_of_vertices(H: np.ndarray, h: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """Rows whose maximum over the vertices of a bounded low-dimensional ``P`` is clear
    below the bound (boolean mask; all False when ``P`` is unbounded or not low-dim)."""
    q, N = H.shape
    clear = np.zeros(q, dtype=bool)
    if not 2 <= N <= _VERTEX_DIM:
        return clear
    from scipy.spatial import ConvexHull, HalfspaceIntersection, QhullError

    slack = h - H @ x0
    dual = H / slack[:, None]  # P is bounded iff x0 lies inside the hull of these
    try:
        if np.max(ConvexHull(dual).equations[:, -1]) >= -1e-9:
            return clear
        vertices = HalfspaceIntersection(np.hstack([H, -h[:, None]]), x0).intersections
    except (QhullError, ValueError):
        return clear
    top = np.max(H @ vertices.T, axis=1)
    return top < h - _SAFETY * TOL * (1.0 + np.abs(h))


def prune_rows(H: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Keep-mask of the rows of ``H x <= h`` that are not redundant.

    Same answer as testing the rows in order by LP (each against the rows still kept
    before it and all rows after it); certificates decide most rows without an LP.

    Parameters
    ----------
    H, h : ndarray (q, N), (q,)
        Unit-length rows, duplicates already removed.

    Returns
    -------
    ndarray (q,) of bool
        True for the rows kept.
    """
    q = len(h)
    keep = np.ones(q, dtype=bool)
    decided = np.zeros(q, dtype=bool)
    x0 = _interior(H, h) if q > 1 else None
    if x0 is not None:
        decided |= _rows_with_witness(H, h, x0, _witness_directions(H, h))
        clear = _clear_of_vertices(H, h, x0) & ~decided
        keep[clear] = False
        decided |= clear
    for i in np.flatnonzero(~decided):
        others = keep.copy()
        others[i] = False
        if others.any() and lp_max(H[i], H[others], h[others]) <= _limit(h[i]):
            keep[i] = False
    return keep


def not_implied(C: np.ndarray, b: np.ndarray, H: np.ndarray, h: np.ndarray) -> bool:
    """Whether some row ``c x <= b`` of ``C`` is not implied by ``P = {H x <= h}``.

    A ray point of ``P`` breaking a row proves it at once; otherwise the rows go to the
    LP in order (stopping at the first one not implied), as the LP-only path.

    Parameters
    ----------
    C, b : ndarray (p, N), (p,)
        Candidate rows.
    H, h : ndarray (q, N), (q,)
        The polytope (``h > 0``: the origin inside).

    Returns
    -------
    bool
        True if ``max_P c x > b + tol (1 + |b|)`` for a row.
    """
    D = np.hstack([C.T, _shape_directions(H, h, C)])
    _, s1, _, _ = _ray_points(H, h, np.zeros(H.shape[1]), D)
    ok = np.isfinite(s1)
    if np.any((C @ D[:, ~ok]) > 0):  # a ray that never leaves P, along which c x grows
        return True
    X = (s1[ok] * (1.0 - 1e-9)) * D[:, ok]  # just inside P
    if X.shape[1]:
        inside = np.all(H @ X <= h[:, None], axis=0)
        over = (C @ X[:, inside]) > _limit(b, _SAFETY)[:, None]
        if np.any(over):
            return True
    return any(lp_max(c, H, h) > _limit(bb) for c, bb in zip(C, b, strict=True))
