"""Switching-condition design by H2 norms of the post-switch responses (book §3.3.3).

After a switch with IVC the free responses of the control input and the output are
``u[k] = Cu A^k [I; K] xp[0]`` and ``y[k] = C A^k [I; K] xp[0]`` ((3.72)-(3.74); the
factor z of ``z (zI - A)^{-1}`` makes the sequence start at ``A^0``). Their squared H2
norms (3.75)-(3.77) are quadratic forms

    Ju = xp[0]^T E^T Lo_u E xp[0],   Jy = xp[0]^T E^T Lo_y E xp[0],   E = [I; K],

with the observability Gramians ``A^T Lo A - Lo + Cz^T Cz = 0`` (3.78). The book's
``D^T D + B^T Lo B`` (3.77) is the same number for the realisation ``D = Cz E``,
``B = A E``. Correction: (3.69) prints ``[-Dc Cc, Cc]`` for the input map; it is
``[-Dc Cp, Cc]``.

Minimising ``Ju`` over some plant states with the others fixed (3.81) is a linear
least-squares problem in the free states.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError, check_finite
from servokit.switching.loop import SwitchedLoop, weighted_gramian

__all__ = ["switching_cost_matrix", "SwitchingCostMap", "switching_cost_map", "optimal_condition"]


def switching_cost_matrix(loop: SwitchedLoop, K: np.ndarray | None, Cz: np.ndarray) -> np.ndarray:
    """``M`` with ``sum_k |Cz A^k [I; K] xp|^2 = xp^T M xp`` ((3.77)-(3.80)).

    ``K = None`` is the zero reset (``xc[0] = 0``).
    """
    A = loop.A
    if np.max(np.abs(np.linalg.eigvals(A))) >= 1:
        raise ServokitValueError("the closed loop is not stable; the H2 norms are infinite")
    Cz = np.atleast_2d(np.asarray(Cz, dtype=float))
    Lo = weighted_gramian(A, Cz.T @ Cz)
    E = loop.stack(np.zeros((loop.m, loop.n)) if K is None else K)
    M = E.T @ Lo @ E
    return 0.5 * (M + M.T)


@dataclass(frozen=True)
class SwitchingCostMap:
    """``Ju`` and ``Jy`` (squared H2 norms) over a grid of two plant states (Fig. 3.13).

    ``ju[i, j]`` belongs to ``(x_values[j], y_values[i])``.
    """

    x_values: np.ndarray
    y_values: np.ndarray
    ju: np.ndarray
    jy: np.ndarray


def switching_cost_map(
    loop: SwitchedLoop,
    K: np.ndarray | None,
    base: Sequence[float],
    axes: tuple[int, int],
    x_values: Sequence[float],
    y_values: Sequence[float],
) -> SwitchingCostMap:
    """Ju, Jy over plant states ``axes`` = (i, j) on a grid, the others as in ``base``.

    Parameters
    ----------
    loop : SwitchedLoop
    K : ndarray or None
        IVC gain (None: zero reset).
    base : sequence of float
        Plant state at the switch; entries ``axes`` are replaced by the grid values.
    axes : (int, int)
        Plant-state indices on the x and y axes (e.g. velocity, acceleration).
    x_values, y_values : sequence of float
        Grid values of those states.
    """
    base = check_finite("base", base).ravel()
    if base.size != loop.n:
        raise ServokitValueError(f"base must hold the {loop.n} plant states (got {base.size})")
    xv, yv = check_finite("x_values", x_values).ravel(), check_finite("y_values", y_values).ravel()
    i, j = axes
    X, Y = np.meshgrid(xv, yv)
    pts = np.repeat(base[:, None], X.size, axis=1)
    pts[i], pts[j] = X.ravel(), Y.ravel()
    maps = []
    for Cz in (loop.Cu, loop.C):
        M = switching_cost_matrix(loop, K, Cz)
        maps.append(np.einsum("ik,ij,jk->k", pts, M, pts).reshape(X.shape))
    return SwitchingCostMap(xv, yv, maps[0], maps[1])


def optimal_condition(M: np.ndarray, base: Sequence[float], free: Sequence[int]) -> np.ndarray:
    """Plant state minimising ``xp^T M xp`` over the states ``free``, the others fixed (3.81)."""
    x = check_finite("base", base).ravel().copy()
    free = list(free)
    fixed = [k for k in range(len(x)) if k not in free]
    # d/dx_f: M_ff x_f + M_fc x_c = 0
    sol, *_ = np.linalg.lstsq(M[np.ix_(free, free)], -M[np.ix_(free, fixed)] @ x[fixed], rcond=None)
    x[free] = sol
    return x
