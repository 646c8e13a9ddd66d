"""One HiGHS model kept between the feasibility LPs of a robust seek search (issue 24).

The settle search of :mod:`servokit.seek.robust` asks, for one step number ``N``, a
sequence of feasibility questions "is there an input settling from grid index ``s``?",
each answered by row generation (solve with some grid rows, add the violated ones,
repeat).  Every grid row ``|H[v, j] x - t| <= 1`` with ``j >= s`` is a constraint of the
full problem at ``s``, so a row generated for one ``s`` is valid for every later
question with a smaller or equal ``s``' ... and a row with ``j < s`` is simply switched
off (free bounds).  This module keeps one HiGHS model per ``N`` with every grid row
generated so far as a ranged row ``t - 1 <= H[v, j] x <= t + 1``, switches rows on and
off by their bounds and re-solves from the last basis (dual simplex, no presolve).

The objective is zero, so every basis is dual feasible and the dual simplex restarts
from the last one after any change of row bounds or added rows: a re-solve costs a few
pivots instead of a new LP.  The answers are the decisions of a fresh
``scipy.optimize.linprog`` of the same rows up to HiGHS's feasibility tolerance (1e-7 on
the rows in the model, which here runs without presolve; the rows outside it are held to
the caller's 1e-9): equal on every question of the tests' hypothesis runs and of the HDD
designs, not guaranteed for a row exactly at the margin.  "Infeasible"
of a relaxation proves the full problem infeasible, "feasible" is accepted only when
every fine-grid row holds to the caller's tolerance.  The feasible point itself may be a
different vertex of the feasible set; the robust design takes its input from a separate,
fresh peak / energy solve at the chosen ``(N, s)``, so the design does not depend on it.

A warm re-solve can stall in degenerate pivots; it is stopped after
:data:`ITERATION_LIMIT` pivots and the question goes to a fresh ``linprog``.

The binding is SciPy's own HiGHS (``scipy.optimize._highspy._core``, SciPy >= 1.15);
where it is missing, or lacks a method used here, :func:`available` is False and the
caller keeps ``linprog``.  The public ``highspy`` package was not taken: its ``Highs()``
(1.16) writes HiGHS's banner to stdout on construction, before any option can be set,
which would corrupt the ``--json`` output of the commands that design robust seeks.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = ["ITERATION_LIMIT", "HighsFeasibility", "available"]

#: dual simplex pivots allowed per warm re-solve; a cold solve of the HDD design's LPs
#: takes 150-320, a warm one 1-300.  One warm re-solve (an infeasibility proof after
#: rows were switched off) stalled for 12278 pivots (0.47 s): past the limit the
#: caller solves that question fresh instead.
ITERATION_LIMIT = 1000


def _core():  # noqa: ANN202 - the private binding has no public type
    from servokit._highs_lp import highs_core

    _core = highs_core()
    if _core is None:  # SciPy < 1.15: no bundled highspy binding
        return None
    highs = getattr(_core, "_Highs", None)
    if highs is None or not all(hasattr(highs, m) for m in _METHODS):
        return None  # another binding layout: the caller keeps linprog
    return _core


#: the binding's methods used here (highspy's names)
_METHODS = (
    "setOptionValue", "getInfinity", "addVars", "addRows", "getNumRow", "changeRowBounds",
    "run", "getModelStatus", "getSolution", "modelStatusToString",
)  # fmt: skip


@functools.cache
def available() -> bool:
    """Whether SciPy's bundled HiGHS binding is importable and answers as used here.

    The binding is private to SciPy: beyond the method names, a one-variable model is
    built, given a ranged row, switched and solved once (per process), so that a binding
    whose types or statuses changed makes the caller keep ``linprog`` instead of failing.

    Returns
    -------
    bool
        True when :class:`HighsFeasibility` can be built and solves.
    """
    if _core() is None:
        return False
    one = np.ones(1)
    try:
        lp = HighsFeasibility(-one, one, np.zeros((0, 1)), np.zeros(0), np.zeros(1))
        lp.add_ranged(np.array([7]), np.ones((1, 1)), np.array([0.5]), np.array([2.0]))
        x = lp.solve()  # 0.5 <= x <= 1: feasible
        lp.switch(np.array([False]))
        lp.add_ranged(np.array([8]), np.ones((1, 1)), np.array([3.0]), np.array([4.0]))
        none = lp.solve()  # x >= 3 with x <= 1: infeasible
    except Exception:  # noqa: BLE001 - any failure of a private binding: keep linprog
        return False
    return x is not None and 0.5 - 1e-9 <= x[0] <= 1.0 + 1e-9 and none is None


class HighsFeasibility:
    """A feasibility LP ``lb <= x <= ub``, ``A_ub x <= b_ub``, ``a_eq x = 0`` plus ranged rows.

    Parameters
    ----------
    lb, ub : ndarray
        Column bounds (n,); ``inf`` entries are free.
    A_ub, b_ub : ndarray
        Fixed rows ``A_ub x <= b_ub`` (m, n), (m,).
    a_eq : ndarray
        One equality row ``a_eq x = 0`` (n,).
    """

    def __init__(
        self, lb: np.ndarray, ub: np.ndarray, A_ub: np.ndarray, b_ub: np.ndarray, a_eq: np.ndarray
    ) -> None:
        core = _core()
        assert core is not None, "check available() first"
        self._core = core
        h = core._Highs()
        for name, value in (
            ("output_flag", False),
            ("presolve", "off"),
            ("solver", "simplex"),
            ("simplex_strategy", 1),  # dual simplex, as linprog(method="highs-ds")
            ("simplex_iteration_limit", ITERATION_LIMIT),
        ):
            h.setOptionValue(name, value)
        self._h, self._inf, self.n = h, h.getInfinity(), len(lb)
        n = self.n
        h.addVars(n, self._finite(lb), self._finite(ub))
        rows = np.vstack([A_ub, a_eq[None, :]])
        lower = np.concatenate([np.full(len(b_ub), -self._inf), [0.0]])
        upper = np.concatenate([np.asarray(b_ub, dtype=float), [0.0]])
        self._add(rows, lower, upper)
        self.keys = np.zeros(0, dtype=np.int64)  # key of each ranged row, in model order
        self._lower = np.zeros(0)  # the ranged rows' bounds when switched on
        self._upper = np.zeros(0)
        self._on = np.zeros(0, dtype=bool)
        self._first = h.getNumRow()  # index of the first ranged row

    def _finite(self, v: np.ndarray) -> np.ndarray:
        return np.clip(np.asarray(v, dtype=float), -self._inf, self._inf)

    def _add(self, rows: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        nz = rows != 0.0
        starts = np.concatenate([[0], np.cumsum(nz.sum(axis=1))[:-1]]).astype(np.int32)
        idx = np.nonzero(nz)[1].astype(np.int32)
        self._h.addRows(
            len(rows),
            self._finite(lower),
            self._finite(upper),
            int(idx.size),
            starts,
            idx,
            rows[nz],
        )

    def add_ranged(
        self, keys: np.ndarray, rows: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> None:
        """Add ranged rows ``lower <= rows x <= upper`` named by integer ``keys`` (on).

        Parameters
        ----------
        keys : ndarray of int
            Caller's names of the rows (k,), not yet in the model.
        rows : ndarray
            Coefficients (k, n).
        lower, upper : ndarray
            Bounds (k,).
        """
        if len(keys) == 0:
            return
        self._add(rows, lower, upper)
        self.keys = np.concatenate([self.keys, keys])
        self._lower = np.concatenate([self._lower, lower])
        self._upper = np.concatenate([self._upper, upper])
        self._on = np.concatenate([self._on, np.ones(len(keys), dtype=bool)])

    def switch(self, on: np.ndarray) -> None:
        """Switch the ranged rows on (their bounds) or off (free), in model order.

        Parameters
        ----------
        on : ndarray of bool
            One flag per ranged row (``len(keys)``).
        """
        for i in np.nonzero(on != self._on)[0]:
            lo, up = (self._lower[i], self._upper[i]) if on[i] else (-self._inf, self._inf)
            self._h.changeRowBounds(int(self._first + i), float(lo), float(up))
        self._on = np.array(on, dtype=bool)

    def solve(self) -> np.ndarray | None:
        """A feasible point (n,), None if infeasible; raises on any other solver status.

        Returns
        -------
        ndarray or None
            Column values of a feasible point, or None when HiGHS proves infeasibility.

        Raises
        ------
        RuntimeError
            Any other model status (the caller falls back to a fresh ``linprog``).
        """
        self._h.run()
        status = self._h.getModelStatus()
        ms = self._core.HighsModelStatus
        if status == ms.kOptimal:
            return np.asarray(self._h.getSolution().col_value, dtype=float)
        if status == ms.kInfeasible:
            return None
        raise RuntimeError(f"HiGHS status {self._h.modelStatusToString(status)}")
