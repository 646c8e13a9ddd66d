"""Row generation for the inequality QP of :func:`~servokit.feedforward.constraints.solve_fsc_qp`.

The constrained FSC designs of §2.6.3 (galvano, N = 351: 344 free variables after the
final-state elimination, 1398-2100 voltage/current/velocity rows) cost PIQP 0.12-0.2 s
each on the full problem: every interior-point iteration forms ``G^T D G`` over all
rows.  At the optimum only a handful of rows bind (8 of 2100 there), and the rows that
bind are among those the unconstrained optimum ``w0`` violates (131 there).  So the QP
is first solved on the rows violated or nearly active (normalised value above
:data:`NEAR`) at ``w0``; rows that the candidate violates or nearly touches are added
and the QP solved again, until none is left outside (:data:`MAX_ROUNDS` rounds at most).
The candidate then meets every row, and :func:`~servokit.feedforward.constraints.solve_fsc_qp`
checks and polishes it exactly as a full solve's answer: the polish (the exact KKT
solution on the active set read off the candidate) gives the full problem's optimum, the
same numbers as from the full solve whenever both candidates lead to the same active set
(all three designs of the galvano case: bit for bit, 0.2 s -> 0.02 s each).

Whenever the subproblem fails (an infeasible subset: the full problem is infeasible too)
or the rounds run out, the full problem is solved as before, so the answers (and the
infeasibility diagnosis) never depend on this path being taken.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["MAX_ROUNDS", "MIN_ROWS", "NEAR", "solve_by_rows"]

#: fewest inequality rows for which the rows are generated (below: one full solve; the
#: small N-search problems of the galvano case, 216-432 rows, cost ~1 ms either way)
MIN_ROWS = 500
#: rounds of adding rows before the full problem is solved instead
MAX_ROUNDS = 8
#: normalised row value (``<= 0`` feasible) above which a row enters the subproblem
NEAR = -1e-7

QPRun = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], "np.ndarray | None"]


def _normalised(G: np.ndarray, h: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``(G w - h) / (|G| |w| + |h|)`` per row: ``<= 0`` where the row holds."""
    return (G @ w - h) / (np.abs(G) @ np.abs(w) + np.abs(h) + 1e-300)


def solve_by_rows(
    run: QPRun,
    P: np.ndarray,
    q: np.ndarray,
    G: np.ndarray,
    h: np.ndarray,
    start: np.ndarray | None,
) -> np.ndarray | None:
    """``run(P, q, G, h)`` (``min w^T P w + 2 q^T w``, ``G w <= h``) by row generation.

    Parameters
    ----------
    run : callable
        The QP backend: ``(P, q, G, h) -> w`` or None when it fails.
    P, q : ndarray (n, n), (n,)
        Cost (positive definite, as after the final-state elimination of (2.64)-(2.66)).
    G, h : ndarray (p, n), (p,)
        Inequality rows (2.72), normalised.
    start : ndarray (n,) or None
        The unconstrained optimum; None solves the full problem at once.

    Returns
    -------
    ndarray (n,) or None
        A candidate meeting every row (or the full problem's answer, when the subproblems
        fail or do not settle within :data:`MAX_ROUNDS` rounds); None when the full
        solve fails.
    """
    if start is None or G.shape[0] < MIN_ROWS:
        return run(P, q, G, h)
    rows = _normalised(G, h, start) > NEAR
    for _ in range(MAX_ROUNDS):
        if not rows.any():
            break
        cand = run(P, q, G[rows], h[rows])
        if cand is None:
            break
        new = (_normalised(G, h, cand) > NEAR) & ~rows
        if not new.any():
            return cand
        rows |= new
    return run(P, q, G, h)
