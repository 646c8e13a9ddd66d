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
from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitValueError, check_finite
from servokit.switching.loop import SwitchedLoop, weighted_gramian

if TYPE_CHECKING:
    from servokit.switching.admissible import AdmissibleSet

__all__ = [
    "switching_cost_matrix",
    "SwitchingCostMap",
    "switching_cost_map",
    "optimal_condition",
    "SwitchingCostGrid",
    "switching_cost_grid",
    "ConditionCheck",
    "admissible_conditions",
]


def switching_cost_matrix(loop: SwitchedLoop, K: np.ndarray | None, Cz: np.ndarray) -> np.ndarray:
    """``M`` with ``sum_k |Cz A^k [I; K] xp|^2 = xp^T M xp`` ((3.77)-(3.80)).

    ``K = None`` is the zero reset (``xc[0] = 0``).

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    K : ndarray or None
        IVC gain (m x n); None for the zero reset.
    Cz : ndarray, shape (q, n + m)
        Signal whose squared H2 norm is taken (``loop.Cu`` or ``loop.C``).

    Returns
    -------
    ndarray, shape (n, n)
        Symmetric ``M`` of the quadratic form in xp[0].
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

    Returns
    -------
    SwitchingCostMap
        The grid values and the maps of Ju and Jy.
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
    """Plant state minimising ``xp^T M xp`` over the states ``free``, the others fixed (3.81).

    Parameters
    ----------
    M : ndarray, shape (n, n)
        Quadratic form of the cost, e.g. from :func:`switching_cost_matrix`.
    base : sequence of float
        Plant state; the entries not in ``free`` stay fixed.
    free : sequence of int
        Indices of the states to optimise (e.g. velocity and acceleration).

    Returns
    -------
    ndarray, shape (n,)
        ``base`` with the free states replaced by the minimiser.
    """
    x = check_finite("base", base).ravel().copy()
    free = list(free)
    fixed = [k for k in range(len(x)) if k not in free]
    # d/dx_f: M_ff x_f + M_fc x_c = 0
    sol, *_ = np.linalg.lstsq(M[np.ix_(free, free)], -M[np.ix_(free, fixed)] @ x[fixed], rcond=None)
    x[free] = sol
    return x


@dataclass(frozen=True)
class SwitchingCostGrid:
    """Ju, Jy over initial velocity (and acceleration) with the position held, and the
    free states minimising Ju (Fig. 3.13, (3.81)); see :func:`switching_cost_grid`."""

    velocity: np.ndarray  #: grid of plant state 2 [output unit/s]
    acceleration: np.ndarray  #: grid of plant state 3 [output unit/s^2] (one 0 without)
    cost: SwitchingCostMap  #: the maps (rows over acceleration)
    optimal_state: np.ndarray  #: plant state minimising Ju with state 1 fixed
    free: list[int]  #: indices of the optimised states


def switching_cost_grid(
    loop: SwitchedLoop,
    K: np.ndarray | None,
    position: float,
    vel_range: tuple[float, float],
    acc_range: tuple[float, float] = (0.0, 0.0),
    n_points: int = 41,
) -> SwitchingCostGrid:
    """Ju and Jy over a velocity (x acceleration) grid at a fixed position, (3.65)-(3.81).

    Parameters
    ----------
    loop : SwitchedLoop
    K : ndarray or None
        IVC gain (None: zero reset).
    position : float
        Plant state 1 at the switch [output unit].
    vel_range : (float, float)
        Lowest and highest plant state 2 [output unit/s].
    acc_range : (float, float)
        Lowest and highest plant state 3; equal ends: no acceleration axis (the map then
        has one row, state 1 held at ``position``).
    n_points : int
        Grid points per axis.

    Returns
    -------
    SwitchingCostGrid
        The grid, the maps and the best free states for ``position``.
    """
    base = np.zeros(loop.n)
    base[0] = float(check_finite("position", position))
    with_acc = acc_range[0] != acc_range[1]
    if with_acc and loop.n < 3:
        raise ServokitValueError("acc_range needs a plant with a third state; use 0:0")
    v = np.linspace(*vel_range, n_points)
    a = np.linspace(*acc_range, n_points) if with_acc else np.zeros(1)
    axes, second = ((1, 2), a) if with_acc else ((1, 0), np.array([position]))
    cmap = switching_cost_map(loop, K, base, axes, v, second)
    if not (np.any(np.isfinite(cmap.ju)) or np.any(np.isfinite(cmap.jy))):
        # every cell overflowed: the map would be all null, which answers nothing
        raise ServokitValueError(
            f"position {position:g}: the switching cost overflows at every grid point; "
            "give a position (and vel_range/acc_range) of the plant's scale"
        )
    free = [1, 2] if with_acc else [1]
    best = optimal_condition(switching_cost_matrix(loop, K, loop.Cu), base, free)
    return SwitchingCostGrid(v, a, cmap, best, free)


@dataclass(frozen=True)
class ConditionCheck:
    """The admissible slices with J-min IVC and with zero reset, and switching conditions
    judged against them; see :func:`admissible_conditions`."""

    t_star: int  #: horizon at which O_inf was determined [samples]
    n_inequalities: int  #: inequalities of the full set
    ivc: AdmissibleSet  #: slice over plant states 1-2 with J-min IVC (J = sum u^2)
    zero_reset: AdmissibleSet  #: the same slice with zero reset
    conditions: list[dict]  #: one row per condition (position, velocity, needed |u|)


def admissible_conditions(
    loop: SwitchedLoop,
    u_max: float,
    conditions: Sequence[Sequence[float]] = (),
    *,
    t_max: int = 500,
) -> ConditionCheck:
    """Maximal output admissible set for |u| <= u_max over (position, velocity), with J-min
    IVC and zero reset, and the input each switching condition needs, (3.82)-(3.92).

    Parameters
    ----------
    loop : SwitchedLoop
    u_max : float
        Input bound [plant input unit].
    conditions : sequence of (position, velocity)
        Plant states 1 and 2 at the switch, the others at rest.
    t_max : int
        Largest horizon tried [samples].

    Returns
    -------
    ConditionCheck
        The two 2-D slices and one row per condition: ``position_out``,
        ``velocity_out_per_s``, ``admissible_ivc``, ``admissible_zero_reset``,
        ``needed_u_ivc``, ``needed_u_zero_reset`` (the smallest bound admitting it).
    """
    from servokit.switching.admissible import max_output_admissible_set
    from servokit.switching.ivc import ivc_jmin

    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    full = max_output_admissible_set(loop.A, loop.Cu, -u_max, u_max, t_max=t_max)
    E = np.eye(loop.n)[:, :2]
    sets = {
        "ivc": full.restrict(loop.stack(K) @ E),
        "zero_reset": full.restrict(loop.stack(np.zeros_like(K)) @ E),
    }
    rows = []
    for x in conditions:
        x = np.asarray(x, dtype=float)
        need = {k: float(s.gauge(x)[0]) * u_max for k, s in sets.items()}
        rows.append(
            {
                "position_out": float(x[0]),
                "velocity_out_per_s": float(x[1]),
                "admissible_ivc": need["ivc"] <= u_max * (1 + 1e-9),
                "admissible_zero_reset": need["zero_reset"] <= u_max * (1 + 1e-9),
                "needed_u_ivc": need["ivc"],
                "needed_u_zero_reset": need["zero_reset"],
            }
        )
    return ConditionCheck(full.t_star, len(full.h), sets["ivc"], sets["zero_reset"], rows)
