"""The inequality QP of constrained final-state control, after the final state is
eliminated (book §2.3.4, (2.64)-(2.66) with (2.72) in the null space of (2.29)).

:func:`solve_reduced` finds the optimum of ``min w^T P w + 2 q^T w`` s.t. ``G w <= h``:
the unconstrained optimum when it meets every row; active-set steps from it for few
rows; otherwise PIQP or Clarabel (via ``qpsolvers``) on the rows the unconstrained
optimum violates first (:mod:`~servokit.feedforward._qp_rows`), polished to the exact
optimum of the active set. :func:`~servokit.feedforward.constraints.solve_fsc_qp` builds
the reduced problem and checks the answer against the final state.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable

import numpy as np

# scipy.linalg and scipy.sparse load on first attribute access (SciPy's lazy submodules)
import scipy

from servokit.feedforward import _qp_rows
from servokit.feedforward._qp_rows import solve_by_rows

__all__ = ["INEQ_RTOL", "feasible", "max_violation", "solve_reduced"]

#: accepted relative violation of an inequality row after the solve
INEQ_RTOL = 1e-6


def feasible(G: np.ndarray, h: np.ndarray) -> bool:
    """Whether ``G w <= h`` has a solution (HiGHS LP with zero cost)."""
    if G.shape[0] == 0:
        return True
    from servokit._highs_lp import linprog_highs  # linprog's answer, less call overhead

    res = linprog_highs(np.zeros(G.shape[1]), G, h, [(None, None)] * G.shape[1])
    return bool(res.status == 0)


def _run_solver(
    solver: str, P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray
) -> np.ndarray | None:
    from qpsolvers import Problem, solve_problem

    if solver == "clarabel":
        Pm, Gm = scipy.sparse.csc_matrix(P), scipy.sparse.csc_matrix(G) if G.size else None
        opts: dict[str, float] = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12}
    else:
        Pm, Gm = P, G if G.size else None
        opts = {"eps_abs": 1e-11, "eps_rel": 1e-11}
    problem = Problem(Pm, q, Gm, h if G.size else None)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            sol = solve_problem(problem, solver=solver, **opts)
        except Exception:  # noqa: BLE001 - a failing backend falls through to the next one
            return None
    if not sol.found or sol.x is None or not np.all(np.isfinite(sol.x)):
        return None
    return np.asarray(sol.x, dtype=float)


def _stationary_point(P: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``w`` with ``P w = -q`` (Cholesky; least squares if ``P`` is only semi-definite)."""
    try:
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(P), -q)
    except (np.linalg.LinAlgError, ValueError):
        return np.linalg.lstsq(P, -q, rcond=None)[0]


def _active_set(
    P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray, w: np.ndarray,
    iterations: int = 6,
) -> np.ndarray | None:  # fmt: skip
    """Exact optimum of ``min w^T P w + 2 q^T w`` s.t. ``G w <= h`` by active-set steps
    from ``w``, or None when they do not settle within ``iterations``.

    Starting from the rows active (normalised slack below 1e-7) or violated at ``w``, the
    equality-constrained QP on the active set is solved exactly (its KKT system), violated
    rows are added and rows with negative multipliers dropped, until neither happens: then
    every inequality holds with non-negative multipliers, the KKT conditions of the full
    problem.
    """

    def rel(v: np.ndarray) -> np.ndarray:  # normalised constraint values, <= 0 feasible
        return (G @ v - h) / (np.abs(G) @ np.abs(v) + np.abs(h) + 1e-300)

    act, n = rel(w) > -1e-7, w.size
    for _ in range(iterations):
        m = int(act.sum())
        K = np.zeros((n + m, n + m))
        K[:n, :n], K[:n, n:], K[n:, :n] = P, G[act].T, G[act]
        try:  # an ill-conditioned KKT matrix means a degenerate active set: give up
            with warnings.catch_warnings():
                warnings.simplefilter("error", scipy.linalg.LinAlgWarning)
                sol = scipy.linalg.solve(K, np.r_[-q, h[act]], assume_a="sym")
        except (np.linalg.LinAlgError, ValueError, scipy.linalg.LinAlgWarning):
            return None
        if not np.all(np.isfinite(sol)):
            return None
        we, lam = sol[:n], np.zeros(act.size)
        lam[act] = sol[n:]
        add = rel(we) > 1e-12
        drop = act & (lam < -1e-9 * max(1.0, float(np.max(np.abs(lam)))))
        if not add.any() and not drop.any():
            return we
        act = (act | add) & ~drop
    return None


def _polish(
    P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray, w: np.ndarray
) -> np.ndarray:
    """The exact optimum on the active set of an interior-point answer ``w``, if found.

    An interior-point solver stops at its tolerance, which along weakly curved directions
    of the FSC cost leaves the minimiser off by up to ~1e-4 relative (HDD FFSC, N = 300).
    :func:`_active_set` from ``w`` gives the exact optimum; it is kept if it costs no more
    than ``w``, otherwise ``w`` is returned.
    """
    we = _active_set(P, q, G, h, w)
    if we is None:
        return w
    cost_w, cost_e = (float(v @ (P @ v) + 2 * q @ v) for v in (w, we))
    return we if cost_e <= cost_w + 1e-12 * abs(cost_w) else w


def max_violation(G: np.ndarray, h: np.ndarray, w: np.ndarray) -> float:
    if G.shape[0] == 0:
        return 0.0
    scale = np.abs(G) @ np.abs(w) + np.abs(h) + 1e-300
    return float(np.max((G @ w - h) / scale))


def solve_reduced(
    P: np.ndarray,
    q: np.ndarray,
    G: np.ndarray,
    h: np.ndarray,
    solver: str,
    violation_at: Callable[[np.ndarray], float],
) -> np.ndarray | None:
    """The optimum of the reduced QP, or None when no backend finds a feasible one.

    Parameters
    ----------
    P, q : ndarray
        Scaled cost ``w^T P w + 2 q^T w`` (``P`` positive semi-definite).
    G, h : ndarray
        Scaled inequality rows ``G w <= h`` (unit rows).
    solver : {"piqp", "clarabel"}
        First interior-point backend; the other is the fallback.
    violation_at : callable
        Largest relative violation of the original rows at ``w`` (judged there: in
        ``w``-space the relative scale vanishes where ``w = 0``).

    Returns
    -------
    ndarray or None
    """
    # the unconstrained optimum, when it meets every limit, is the answer: exact, and it
    # spares the interior-point solvers the degenerate case of limits touching it
    w0 = _stationary_point(P, q)
    stationary = np.linalg.norm(P @ w0 + q) <= 1e-10 * max(np.linalg.norm(q), 1.0)
    start = w0 if stationary else None  # where the row generation starts
    w = None
    if stationary and violation_at(w0) <= INEQ_RTOL:
        return w0
    if stationary and 0 < G.shape[0] < _qp_rows.MIN_ROWS:
        # active-set iterations from the unconstrained optimum: exact, and on the FSC
        # problems a few dense solves instead of a whole interior-point run (with more
        # rows the generated-rows solve below is cheaper: the galvano N = 351 designs
        # never settled in 12 iterations, 40 ms each)
        w = _active_set(P, q, G, h, w0, iterations=12)
    backends = (solver, "clarabel" if solver == "piqp" else "piqp")
    for name in backends if w is None else ():
        # on the rows the unconstrained optimum violates first (_qp_rows): same optimum
        cand = solve_by_rows(functools.partial(_run_solver, name), P, q, G, h, start)
        if cand is not None and max_violation(G, h, cand) <= INEQ_RTOL:
            return _polish(P, q, G, h, cand)
    return w
