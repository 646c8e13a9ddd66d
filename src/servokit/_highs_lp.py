"""``scipy.optimize.linprog(method="highs")`` for small dense LPs, without its call overhead.

The admissible sets (:mod:`servokit.switching.admissible_lp`) and the feasibility checks
of the constrained FSC (:mod:`servokit.feedforward.constraints`) solve hundreds of LPs of
2-20 variables; ``linprog`` spends about 1 ms of each call outside HiGHS (input
cleaning, and in SciPy's wrapper a ``HighsOptionsManager`` built for every one of the
five options it checks), two thirds of a 17-variable LP of the ``switching-acoustic``
case (issue 24).  :func:`linprog_highs` hands HiGHS exactly what ``linprog`` hands it:
the same column-wise matrix (``csc_array`` of the stacked rows), the same row and
column bounds (infinite ones replaced by HiGHS's infinity), the same five options
(presolve, no debug output, no log, no output, dual simplex), then reads the status,
objective and solution as ``linprog`` does and runs its ``_check_result``.  The same
solver on the same model with the same options gives the same answer, bit for bit
(tests/test_highs_lp.py compares status, objective and ``x`` with ``linprog`` on
random bounded, unbounded and infeasible LPs).

The binding is SciPy's own HiGHS (``scipy.optimize._highspy._core``, as in
:mod:`servokit.seek._highs_feasibility`); where it, or ``_check_result``, is missing,
:func:`linprog_highs` calls ``linprog`` itself.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["LPResult", "highs_core", "linprog_highs"]


@dataclass(frozen=True)
class LPResult:
    """The fields of ``linprog``'s result used by servokit.

    Attributes
    ----------
    status : int
        SciPy's status: 0 optimal, 1 limit, 2 infeasible, 3 unbounded, 4 numerical.
    fun : float or None
        Objective at ``x``.
    x : ndarray or None
        Solution (None unless HiGHS reports an optimum).
    message : str
        SciPy's message.
    """

    status: int
    fun: float | None
    x: np.ndarray | None
    message: str


def highs_core():  # noqa: ANN201 - the private binding has no public type
    """SciPy's bundled HiGHS binding (``scipy.optimize._highspy._core``), or None.

    Returns
    -------
    module or None
        None before SciPy 1.15 (no bundled binding); callers then keep ``linprog``.
    """
    try:
        from scipy.optimize._highspy import _core
    except ImportError:
        return None
    return _core


@functools.cache
def _parts():  # noqa: ANN202 - private SciPy objects, None when absent
    _core = highs_core()
    if _core is None:
        return None
    try:
        from scipy.optimize._linprog_highs import _highs_to_scipy_status_message
        from scipy.optimize._linprog_util import _check_result

        _core.HighsLp, _core._Highs, _core.HighsOptions, _core.MatrixFormat.kColwise  # noqa: B018
        dual = _core.simplex_constants.SimplexStrategy.kSimplexStrategyDual
        quiet = _core.HighsDebugLevel.kHighsDebugLevelNone
    except (ImportError, AttributeError):  # another SciPy layout: linprog itself
        return None
    return _core, _highs_to_scipy_status_message, _check_result, dual, quiet


def _bounds(bounds: Sequence[tuple[float | None, float | None]] | None, n: int) -> np.ndarray:
    """``(n, 2)`` column bounds as ``linprog`` cleans them (None: infinite)."""
    if bounds is None:
        out = np.zeros((n, 2))
        out[:, 1] = np.inf
        return out
    out = np.array([[-np.inf if lo is None else lo, np.inf if hi is None else hi]
                    for lo, hi in bounds], dtype=float)  # fmt: skip
    return out


def _solve(parts, c, A, lhs, rhs, lb, ub, presolve):  # noqa: ANN001, ANN202, PLR0913
    """One HiGHS run as ``scipy.optimize._highspy._highs_wrapper`` makes it."""
    core, to_scipy, _, dual, quiet = parts
    lp = core.HighsLp()
    lp.num_col_, lp.num_row_ = c.size, rhs.size
    lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = c.size, rhs.size
    lp.a_matrix_.format_ = core.MatrixFormat.kColwise
    lp.col_cost_, lp.col_lower_, lp.col_upper_ = c, lb, ub
    lp.row_lower_, lp.row_upper_ = lhs, rhs
    lp.a_matrix_.start_, lp.a_matrix_.index_, lp.a_matrix_.value_ = A.indptr, A.indices, A.data
    highs, options = core._Highs(), core.HighsOptions()
    options.presolve = "on" if presolve else "off"
    options.highs_debug_level = quiet
    options.log_to_console = False
    options.output_flag = False
    options.simplex_strategy = dual
    if highs.passOptions(options) == core.HighsStatus.kError:
        return to_scipy(highs.getModelStatus(), ""), None, None, None
    if highs.passModel(lp) == core.HighsStatus.kError:
        return to_scipy(core.HighsModelStatus.kModelError, ""), None, None, None
    if highs.run() == core.HighsStatus.kError:
        return to_scipy(highs.getModelStatus(), ""), None, None, None
    status = highs.getModelStatus()
    if status != core.HighsModelStatus.kOptimal:
        return to_scipy(status, highs.modelStatusToString(status)), None, None, None
    info, solution = highs.getInfo(), highs.getSolution()
    x = np.array(solution.col_value)
    slack = rhs - solution.row_value
    return (
        to_scipy(status, highs.modelStatusToString(status)),
        info.objective_function_value,
        x,
        slack,
    )


def linprog_highs(
    c: np.ndarray,
    A_ub: np.ndarray,
    b_ub: np.ndarray,
    bounds: Sequence[tuple[float | None, float | None]] | None = None,
    *,
    presolve: bool = True,
) -> LPResult:
    """``linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs")``, the same answer.

    Parameters
    ----------
    c : ndarray (n,)
        Objective (minimised).
    A_ub, b_ub : ndarray (m, n), (m,)
        Rows ``A_ub x <= b_ub`` (dense).
    bounds : sequence of (low, high), optional
        One pair per variable, None for infinite; default ``x >= 0`` as ``linprog``.
    presolve : bool
        HiGHS presolve (``options={"presolve": False}`` of ``linprog``).

    Returns
    -------
    LPResult
        Status, objective, solution and message as ``linprog`` returns them.
    """
    parts = _parts()
    c = np.array(c, dtype=float).ravel()
    A_ub = np.array(A_ub, dtype=float).reshape(-1, c.size)
    b_ub = np.array(b_ub, dtype=float).ravel()
    if parts is None:
        from scipy.optimize import linprog

        res = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=bounds, method="highs",
                      options={"presolve": presolve})  # fmt: skip
        return LPResult(int(res.status), res.fun, res.x, str(res.message))
    from scipy.sparse import csc_array

    core, _, check, _, _ = parts
    box = _bounds(bounds, c.size)
    lb, ub = box.T.copy()
    lhs, rhs = np.full(b_ub.size, -np.inf), b_ub.copy()
    for v in (lhs, rhs, lb, ub):  # linprog's _replace_inf
        v[np.isinf(v)] = np.sign(v[np.isinf(v)]) * core.kHighsInf
    A = csc_array(np.vstack((A_ub, np.zeros((0, c.size)))))
    (status, message), fun, x, slack = _solve(parts, c, A, lhs, rhs, lb, ub, presolve)
    con = None if slack is None else np.array(slack[b_ub.size :])
    slack = None if slack is None else np.array(slack[: b_ub.size])
    status, message = check(x, fun, status, slack, con, box, 1e-9, message, None)
    return LPResult(int(status), fun, x, message)
