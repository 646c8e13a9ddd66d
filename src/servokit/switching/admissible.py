"""Maximal output admissible sets (book §3.3.3, (3.82)-(3.92); Gilbert and Tan, 1991).

For the free closed loop ``x[k+1] = A x[k]`` with the constrained signal
``z[k] = Cz x[k]`` and ``zmin <= z[k] <= zmax`` (3.83)-(3.84), the maximal output
admissible set is ``O_inf = {x : Cz A^k x in Z for all k >= 0}`` (3.89). With A Schur
stable, (Cz, A) observable and 0 in the interior of Z, ``O_inf`` is a polytope determined
by finitely many k: ``O_t = {x : Cz A^k x in Z, k = 0..t}`` and the first t with
``O_t = O_{t+1}`` gives ``O_inf = O_t`` (Gilbert-Tan, Theorem 4.1). ``O_t = O_{t+1}`` is
tested by linear programs: every row of the step-(t+1) constraint must already be implied
by ``O_t`` (its maximum over ``O_t`` within its bound). Redundant rows are then removed
by the same LP test. LPs go to SciPy's HiGHS; most of them are answered by exact
certificates instead (witness points, vertices: :mod:`servokit.switching.admissible_lp`).

With IVC the controller state is ``xc[0] = K xp[0]``, so the admissible plant states are
``{xp : H [I; K] xp <= h}`` (3.92); the finite-determination argument must run in the
full closed-loop coordinates (A maps the IVC subspace out of itself), and the result is
restricted afterwards (:meth:`AdmissibleSet.restrict`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_finite
from servokit.switching.admissible_lp import not_implied, prune_rows

__all__ = ["AdmissibleSet", "max_output_admissible_set"]


def _normalise(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    norm = np.linalg.norm(H, axis=1)
    keep = norm > 0
    if np.any(h[~keep] < 0):
        raise ServokitValueError("the constraints are infeasible (a zero row with h < 0)")
    return H[keep] / norm[keep, None], h[keep] / norm[keep]


def _prune(H: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop duplicate and LP-redundant rows of ``H x <= h``."""
    H, h = _normalise(H, h)
    _, first = np.unique(np.round(np.hstack([H, h[:, None]]), 12), axis=0, return_index=True)
    H, h = H[np.sort(first)], h[np.sort(first)]
    keep = prune_rows(H, h)
    return H[keep], h[keep]


@dataclass(frozen=True)
class AdmissibleSet:
    """The polytope ``{x : H x <= h}`` (rows normalised to unit length).

    Attributes
    ----------
    H : ndarray, shape (q, N)
    h : ndarray, shape (q,)
    t_star : int
        Steps needed for finite determination (``O_inf = O_t_star``).
    """

    H: np.ndarray
    h: np.ndarray
    t_star: int

    @property
    def dim(self) -> int:
        return self.H.shape[1]

    def contains(self, x: np.ndarray, *, tol: float = 1e-9) -> np.ndarray:
        """Membership of the points in the columns (or the 1-D vector) ``x``."""
        X = np.asarray(x, dtype=float)
        one = X.ndim == 1
        X = X.reshape(-1, 1) if one else X
        inside = np.all(self.H @ X <= self.h[:, None] + tol * (1 + np.abs(self.h[:, None])), 0)
        return bool(inside[0]) if one else inside

    def gauge(self, x: np.ndarray) -> np.ndarray:
        """``max_i H_i x / h_i`` per column of ``x``: x lies in ``s * set`` iff gauge <= s.

        For a set built with symmetric bounds ``+-b`` this is the bound a state needs
        (in units of b): the set is homogeneous in the bound.
        """
        X = np.asarray(x, dtype=float)
        X = X.reshape(-1, 1) if X.ndim == 1 else X
        return np.max(self.H @ X / self.h[:, None], axis=0)

    def ray_limit(self, d: np.ndarray) -> float:
        """Largest s with ``s d`` in the set (inf if the ray never leaves it)."""
        Hd = self.H @ np.asarray(d, dtype=float)
        pos = Hd > 0
        return float(np.min(self.h[pos] / Hd[pos])) if pos.any() else np.inf

    def restrict(self, E: np.ndarray, offset: np.ndarray | None = None) -> AdmissibleSet:
        """The set in coordinates ``xi`` with ``x = E xi + offset``.

        That is ``{xi : H E xi <= h - H offset}``.

        ``E = loop.stack(K)`` gives the IVC set in xp coordinates (3.92); selecting columns
        of it gives 2-D slices (other coordinates fixed by ``offset``).
        """
        E = np.asarray(E, dtype=float)
        b = self.h if offset is None else self.h - self.H @ np.asarray(offset, dtype=float)
        H, h = _prune(self.H @ E, b)
        return AdmissibleSet(H, h, self.t_star)

    def polygon(self) -> np.ndarray:
        """Vertices (counter-clockwise, shape (v, 2)) of a bounded 2-D set."""
        if self.dim != 2:
            raise ServokitValueError(f"polygon() needs a 2-D set (this one has {self.dim} dims)")
        from scipy.spatial import HalfspaceIntersection, QhullError

        centre = self.chebyshev_centre()
        try:
            hs = HalfspaceIntersection(np.hstack([self.H, -self.h[:, None]]), centre)
        except QhullError:  # a sliver the float geometry cannot resolve: say so, not a trace
            raise ServokitValueError(
                "the 2-D admissible set is too thin for qhull to draw (the plant's state "
                "scales differ by many decades); rescale the plant (gain) or --u-max"
            ) from None
        v = hs.intersections
        order = np.argsort(np.arctan2(v[:, 1] - centre[1], v[:, 0] - centre[0]))
        return v[order]

    def chebyshev_centre(self) -> np.ndarray:
        """Centre of the largest ball inside the set (LP); refuses an empty/flat set."""
        from servokit._highs_lp import linprog_highs  # linprog's answer, less overhead

        N = self.dim
        c = np.zeros(N + 1)
        c[-1] = -1.0
        A = np.hstack([self.H, np.ones((len(self.h), 1))])
        res = linprog_highs(c, A, self.h, [(None, None)] * N + [(0, None)])
        if res.status != 0 or res.x[-1] <= 0:
            raise ServokitValueError("the admissible set is empty or has no interior")
        return res.x[:N]


def max_output_admissible_set(
    A: np.ndarray,
    Cz: np.ndarray,
    zmin: object,
    zmax: object,
    *,
    t_max: int = 500,
) -> AdmissibleSet:
    """Maximal output admissible set of ``x[k+1] = A x[k]``, ``zmin <= Cz x[k] <= zmax``.

    Parameters
    ----------
    A : ndarray, shape (N, N)
        Closed-loop state matrix (Schur stable), e.g. ``SwitchedLoop.A``.
    Cz : ndarray, shape (p, N)
        Constrained outputs, e.g. ``SwitchedLoop.Cu`` for the input bound (3.82).
    zmin, zmax : float or array_like (p,)
        Bounds with ``zmin < 0 < zmax``.
    t_max : int
        Largest horizon tried before giving up (finite determination not reached).

    Returns
    -------
    AdmissibleSet
        ``O_inf = {x : H x <= h}`` in the coordinates of A, redundant rows removed.
    """
    A = np.atleast_2d(check_finite("A", A))
    Cz = np.atleast_2d(check_finite("Cz", Cz))
    t_max = check_count("t_max", t_max, lo=1)
    N, p = A.shape[0], Cz.shape[0]
    if A.shape != (N, N) or Cz.shape[1] != N:
        raise ServokitValueError(f"A must be square and Cz have {N} columns (got {Cz.shape})")
    lo = np.broadcast_to(check_finite("zmin", zmin), (p,)).astype(float)
    hi = np.broadcast_to(check_finite("zmax", zmax), (p,)).astype(float)
    if np.any(lo >= 0) or np.any(hi <= 0):
        raise ServokitValueError("the bounds must satisfy zmin < 0 < zmax (origin inside Z)")
    if np.max(np.abs(np.linalg.eigvals(A))) >= 1:
        raise ServokitValueError(
            "A is not Schur stable; O_inf is only finitely determined for a stable loop"
        )
    rows, bounds = [Cz, -Cz], [hi, -lo]
    H, h = _normalise(np.vstack(rows), np.concatenate(bounds))
    M = Cz @ A
    for t in range(1, t_max + 1):
        cand, cb = _normalise(np.vstack([M, -M]), np.concatenate([hi, -lo]))
        if not not_implied(cand, cb, H, h):
            Hp, hp = _prune(H, h)
            return AdmissibleSet(Hp, hp, t - 1)
        H, h = np.vstack([H, cand]), np.concatenate([h, cb])
        M = M @ A
    raise ServokitValueError(
        f"O_inf was not finitely determined within t_max = {t_max} steps; raise t_max, or "
        "check that (Cz, A) is observable (unobservable directions make the set unbounded)"
    )
