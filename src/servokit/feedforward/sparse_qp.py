"""Constrained FSC as a sparse (banded) QP: states as variables (book §2.3.4, §2.6.2).

The dense formulation of :func:`servokit.feedforward.constraints.solve_fsc_qp` works on
the lifted rows (2.67)-(2.72): every constraint row depends on every earlier input, so
``G`` is dense (4N x N for two limits) and an interior-point solve costs ``O(N^3)``
(4 s at N = 1000).  Keeping the states ``x[1..N]`` as variables instead makes every
matrix banded::

    minimise    rho ||U||^2 + ||W_b U||^2                       (2.59)-(2.61), (2.74)
    subject to  x[k+1] - A x[k] - B U[k] = 0,  k = 0..N-1         (dynamics, x[0] given)
                x[N] = x_N                                       (2.29)
                |d x[k] + e x[k+1]| <= zmax,   k = 0..N-1         (2.62)-(2.63), (2.84)-(2.88)

with, for ``z[k] = Cz x[k] + a uc[k] + b (uc[k+1] - uc[k]) / dt`` and ``uc[k] = c_u x[k]``
(the integrator state of the augmented model, ``uc[N] = 0``), ``d = Cz + (a - b/dt) c_u``
and ``e = (b/dt) c_u`` (no ``e`` term at ``k = N-1``).

Dense frequency-shaping rows ``W_b`` are first compressed to their numerical rank
(:func:`compress_band_rows`: 480 rows of the HDD Table 2.4 bands carry ~110 directions at
N = 300) and enter through auxiliary variables ``s = R U`` with cost ``||s||^2``, so the
Hessian stays diagonal.  When even the compressed rows would dominate the factorisation,
:func:`prefers_banded` sends the problem to the dense QP instead.

The problem is scaled before a solver sees it (issue 24): the HDD benchmark in SI units
has inputs of ~1e-7 per step and an objective of ~1e-13, so the absolute tolerances of
the solvers (1e-11 ... 1e-12) stopped them far from the optimum (a cost 80 % off).  With
``U = s_u U~`` and ``x = diag(s_x) x~`` (scales of the minimum-norm input reaching the
final state and of its states), every limit divided by its bound and the cost by
``rho s_u^2``, all variables and rows are O(1).  The answer of Clarabel (or PIQP's sparse
backend) is accepted only when its KKT residuals (primal, dual, duality gap) are below
:data:`KKT_TOL`, iterations are capped, and the final state is then restored exactly by
the minimum-norm correction ``U += Sigma^T (Sigma Sigma^T)^-1 (x_N - x[N](U))`` (``Sigma``
of (2.30)), which moves the inequalities by the solver's tolerance only.  The caller
checks the result and falls back to the dense path (which names binding constraints of
an infeasible problem) when the sparse solve fails.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from servokit._lazy import scipy_sparse as sp

__all__ = [
    "SparseRow",
    "compress_band_rows",
    "limit_violation",
    "prefers_banded",
    "solve_banded_fsc_qp",
]

SparseRow = tuple[np.ndarray | None, float, float, float]  # (Cz, a, b, zmax)


def _dynamics(A: np.ndarray, B: np.ndarray, N: int, x0: np.ndarray, n_aux: int):
    """Equality rows of the dynamics over ``v = [U (N), x[1..N] (N n), s (n_aux)]``."""
    n = A.shape[0]
    eye_N = sp.identity(N, format="csc")
    sub = sp.diags([np.ones(N - 1)], [-1], shape=(N, N), format="csc")
    Ex = sp.identity(N * n, format="csc") - sp.kron(sub, sp.csc_matrix(A), format="csc")
    Eu = -sp.kron(eye_N, sp.csc_matrix(B.reshape(n, 1)), format="csc")
    E = sp.hstack([Eu, Ex, sp.csc_matrix((N * n, n_aux))], format="csc")
    rhs = np.zeros(N * n)
    rhs[:n] = A @ x0
    return E, rhs


def _limit_rows(rows: Sequence[SparseRow], input_row: np.ndarray, dt: float, N: int,
                x0: np.ndarray, n_aux: int):  # fmt: skip
    """``G v <= h`` for every ``|z[k]| <= zmax`` (two rows per step and limit)."""
    n = input_row.size
    blocks, hs = [], []
    for Cz, a, b, zmax in rows:
        c = np.zeros(n) if Cz is None else np.asarray(Cz, dtype=float)
        d = c + (a - b / dt) * input_row
        e = (b / dt) * input_row
        # z[k] uses x[k] (variable for k >= 1, constant x0 for k = 0) and x[k+1] (k < N-1)
        Zx = sp.kron(sp.diags([np.ones(N - 1)], [-1], shape=(N, N)), sp.csr_matrix(d))
        Zx = Zx + sp.kron(sp.diags([np.r_[np.ones(N - 1), 0.0]], [0], shape=(N, N)),
                          sp.csr_matrix(e))  # fmt: skip
        Z = sp.hstack([sp.csr_matrix((N, N)), Zx, sp.csr_matrix((N, n_aux))], format="csr")
        off = np.zeros(N)
        off[0] = d @ x0
        blocks += [Z, -Z]
        hs += [zmax - off, zmax + off]
    return sp.vstack(blocks, format="csc"), np.concatenate(hs)


#: accepted KKT residuals of the scaled problem (states, inputs and limits all O(1))
KKT_TOL = 1e-7


def _solve(P, q, G, h, E, b, solver: str) -> np.ndarray | None:
    """Solution of the scaled QP, or None unless its KKT residuals are all small.

    The problem is scaled (module docstring), so relative tolerances apply and the
    solver's answer is accepted only after checking primal and dual residuals and the
    duality gap against :data:`KKT_TOL` (a solver's "found" alone is not trusted).
    """
    from qpsolvers import Problem, solve_problem

    opts: dict[str, object]
    if solver == "clarabel":
        opts = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10,
                "max_iter": 60}  # fmt: skip
    else:
        opts = {"backend": "sparse", "eps_abs": 1e-10, "eps_rel": 1e-10, "max_iter": 60}
    problem = Problem(P, q, G, h, E, b)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            sol = solve_problem(problem, solver=solver, **opts)
        except Exception:  # noqa: BLE001 - a failing backend returns None to the caller
            return None
    if not sol.found or sol.x is None or not np.all(np.isfinite(sol.x)):
        return None
    cost = abs(float(sol.x @ (P @ sol.x)))
    if (
        sol.primal_residual() > KKT_TOL
        or sol.dual_residual() > KKT_TOL * max(1.0, float(np.abs(P @ sol.x).max()))
        or sol.duality_gap() > KKT_TOL * max(1.0, cost)
    ):
        return None
    return np.asarray(sol.x, dtype=float)


def polish_active_set(P, G, h, E, b, v: np.ndarray, tol: float = 1e-7) -> np.ndarray:  # noqa: ANN001
    """The exact optimum of ``min v'Pv/2, E v = b, G v <= h`` on the active set of ``v``.

    An interior-point answer sits within its tolerance of the optimum, which moves the
    minimiser by up to ~1e-6 along weakly curved directions. Taking the inequalities
    ``v`` holds with equality (to ``tol``) as equalities, the KKT system
    ``[[P, A'], [A, 0]] [v; y] = [0; c]`` gives the optimum of that face directly (the
    polish step of OSQP). It is accepted only if it is the optimum of the whole problem:
    every inequality holds (to 1e-9) and every active multiplier has the right sign;
    otherwise ``v`` is returned unchanged.

    Parameters
    ----------
    P : sparse (n, n)
        Hessian (positive semi-definite; positive definite on the null space of ``E``).
    G, h : sparse (m, n), ndarray (m,)
        Inequalities ``G v <= h`` (scaled: ``h`` of order one).
    E, b : sparse (p, n), ndarray (p,)
        Equalities.
    v : ndarray (n,)
        The solver's answer.
    tol : float
        Slack below which an inequality counts as active (then 100x and 1e4x that, for an
        answer that stopped short of its face).

    Returns
    -------
    ndarray (n,)
        The polished optimum, or ``v``.
    """
    tried: set[bytes] = set()
    for slack in (tol, 1e2 * tol, 1e4 * tol):  # an interior point may stop short of a face
        active = np.flatnonzero(G @ v >= h - slack * np.maximum(1.0, np.abs(h)))
        if active.tobytes() in tried:
            continue
        tried.add(active.tobytes())
        x = _face_optimum(P, G, h, E, b, active)
        if x is not None:
            return x
    return v


def _face_optimum(P, G, h, E, b, active: np.ndarray) -> np.ndarray | None:  # noqa: ANN001
    """KKT solution with ``G[active]`` as equalities, if it is the whole problem's optimum."""
    from scipy.sparse.linalg import spsolve

    A = sp.vstack([E, G[active]], format="csc")
    rhs = np.concatenate([np.zeros(P.shape[0]), b, h[active]])
    kkt = sp.bmat([[P, A.T], [A, None]], format="csc")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a singular face (redundant rows): not this one
        sol = spsolve(kkt, rhs)
    n, p = P.shape[0], E.shape[0]
    x, y_ineq = sol[:n], sol[n + p :]
    scale = max(1.0, float(np.abs(h).max(initial=1.0)))
    if (
        not np.all(np.isfinite(sol))
        or np.any(G @ x > h + 1e-9 * scale)
        or np.any(y_ineq < -1e-9 * max(1.0, float(np.abs(y_ineq).max(initial=1.0))))
        or np.abs(A @ x - rhs[n:]).max(initial=0.0) > 1e-9 * scale
    ):
        return None
    return x


def _reachability(A: np.ndarray, B: np.ndarray, N: int) -> np.ndarray:
    """``Sigma = [A^(N-1) B, ..., A B, B]`` of (2.30), (n, N)."""
    cols = np.empty((N, A.shape[0]))
    col = np.asarray(B, dtype=float).reshape(-1)
    for j in range(N - 1, -1, -1):
        cols[j] = col
        col = A @ col
    return cols.T


def _states(A: np.ndarray, B: np.ndarray, x0: np.ndarray, U: np.ndarray) -> np.ndarray:
    """``x[0..N]`` (N+1, n) by direct recursion (the check of a solution)."""
    xs = np.empty((U.size + 1, A.shape[0]))
    xs[0] = x0
    Bv = np.asarray(B, dtype=float).reshape(-1)
    for k, u in enumerate(U):
        xs[k + 1] = A @ xs[k] + Bv * u
    return xs


def limit_violation(
    A: np.ndarray, B: np.ndarray, x0: np.ndarray, U: np.ndarray, *, dt: float,
    input_row: np.ndarray, limits: Sequence[SparseRow],
) -> float:  # fmt: skip
    """Largest ``(|z[k]| - zmax) / zmax`` over all limits (<= 0 when all hold).

    Parameters
    ----------
    A, B : numpy.ndarray
        Discrete design model ``x[k+1] = A x[k] + B u[k]``.
    x0 : numpy.ndarray
        Initial state.
    U : numpy.ndarray
        Input samples, shape (N,).
    dt : float
        Hold period [s] (the rate term ``b du/dt`` of a limit).
    input_row : numpy.ndarray
        Row giving the continuous input (e.g. the current) from the state.
    limits : sequence of SparseRow
        ``(Cz, a, b, zmax)``: limit ``|Cz x + a u + b du/dt| <= zmax``.

    Returns
    -------
    float
        The largest relative violation; ``<= 0`` when every limit holds.
    """
    xs = _states(A, B, x0, U)
    uc = np.append(xs[:-1] @ input_row, 0.0)
    worst = -np.inf
    for Cz, a, b, zmax in limits:
        z = a * uc[:-1] + b * np.diff(uc) / dt
        if Cz is not None:
            z = z + xs[:-1] @ np.asarray(Cz, dtype=float)
        worst = max(worst, float(np.max(np.abs(z))) / zmax - 1.0)
    return worst


def compress_band_rows(band_rows: np.ndarray | None, rho: float) -> np.ndarray:
    """Rows ``R`` (r, N) with ``||R U||^2 = ||W_b U||^2`` up to ``1e-12 rho ||U||^2``.

    The band rows of (2.74) are numerically low-rank (a narrow band of a length-N
    sequence has few degrees of freedom): of the 480 rows of the HDD Table 2.4 bands at
    N = 300 about 120 carry any weight.  A thin SVD keeps the directions whose squared
    singular value exceeds ``1e-12 rho``; the discarded part of the cost is below
    ``1e-12`` of the jerk term ``rho ||U||^2``, so it moves the minimiser by a relative
    ``1e-12`` at most (the Hessian is ``>= rho I``).

    Parameters
    ----------
    band_rows : numpy.ndarray or None
        ``W_b`` (m, N): the frequency-shaping rows of the cost factor.
    rho : float
        Weight of ``||U||^2`` in the cost.

    Returns
    -------
    numpy.ndarray
        ``R`` (r, N), ``r <= min(m, N)``; ``(0, N)`` when there are no band rows.
    """
    if band_rows is None or band_rows.shape[0] == 0:
        return np.zeros((0, 0 if band_rows is None else band_rows.shape[1]))
    _, sv, vt = np.linalg.svd(band_rows, full_matrices=False)
    keep = sv**2 > 1e-12 * rho
    return sv[keep, None] * vt[keep]


def _scales(A, B, x0, xN, Sigma):
    """Input scale and per-state scales from the minimum-norm input reaching ``xN``."""
    free = xN - _states(A, B, x0, np.zeros(Sigma.shape[1]))[-1]
    row = np.linalg.norm(Sigma, axis=1)
    row[row == 0] = 1.0
    U_ref = np.linalg.lstsq(Sigma / row[:, None], free / row, rcond=None)[0]
    xs = _states(A, B, x0, U_ref)
    su = float(np.max(np.abs(U_ref), initial=0.0)) or 1.0
    sx = np.max(np.abs(xs), axis=0)
    floor = float(np.max(sx, initial=0.0)) or 1.0
    return su, np.where(sx > 1e-9 * floor, sx, floor)


def solve_banded_fsc_qp(
    A: np.ndarray,
    B: np.ndarray,
    N: int,
    x0: np.ndarray,
    xN: np.ndarray,
    *,
    dt: float,
    input_row: np.ndarray,
    limits: Sequence[SparseRow],
    rho: float = 1.0,
    band_rows: np.ndarray | None = None,
    solver: str = "clarabel",
) -> np.ndarray | None:
    """The constrained FSC input ``U`` (N,) of the banded QP (module docstring), or None.

    Parameters
    ----------
    A, B : ndarray
        Discrete (augmented) design model ``x[k+1] = A x[k] + B U[k]``.
    N : int
        Steps.
    x0, xN : ndarray (n,)
        Initial and final state.
    dt : float
        Sampling period [s].
    input_row : ndarray (n,)
        Row giving the held plant input ``uc[k] = input_row @ x[k]``.
    limits : sequence of (Cz or None, a, b, zmax)
        ``|Cz x[k] + a uc[k] + b (uc[k+1] - uc[k]) / dt| <= zmax``.
    rho : float
        Weight of ``||U||^2`` (2.74).
    band_rows : ndarray (m, N), optional
        Frequency-shaping rows ``W_b``: the cost is ``rho ||U||^2 + ||W_b U||^2``; they
        are compressed by :func:`compress_band_rows` before they enter the QP.
    solver : {"clarabel", "piqp"}

    Returns
    -------
    ndarray (N,) or None when the solver fails (infeasible, numerical trouble, or an
    answer whose KKT residuals are not small).
    """
    n = A.shape[0]
    Sigma = _reachability(A, B, N)
    su, sx = _scales(A, B, x0, xN, Sigma)
    # scaled model: x = sx * xt, U = su * Ut; limits divided by zmax; cost by rho su^2
    As, Bs = A * sx[None, :] / sx[:, None], np.asarray(B, dtype=float).reshape(-1) * su / sx
    x0s, xNs = x0 / sx, xN / sx
    rows = [(None if Cz is None else np.asarray(Cz) * sx / zm, a / zm, b / zm, 1.0)
            for Cz, a, b, zm in limits]  # fmt: skip
    R = compress_band_rows(band_rows, rho) / np.sqrt(rho)
    n_aux = R.shape[0]
    E, rhs = _dynamics(As, Bs, N, x0s, n_aux)
    sel = sp.hstack([sp.csc_matrix((n, N + (N - 1) * n)), sp.identity(n),
                     sp.csc_matrix((n, n_aux))], format="csc")  # fmt: skip
    eq, b = [E, sel], [rhs, xNs]
    if n_aux:  # auxiliary rows s - R U = 0 keep the Hessian diagonal
        eq.append(sp.hstack([sp.csc_matrix(-R), sp.csc_matrix((n_aux, N * n)),
                             sp.identity(n_aux)], format="csc"))  # fmt: skip
        b.append(np.zeros(n_aux))
    diag = np.r_[np.ones(N), np.zeros(N * n), np.ones(n_aux)]
    G, h = _limit_rows(rows, np.asarray(input_row, dtype=float) * sx, dt, N, x0s, n_aux)
    P, Eq, beq = sp.diags(diag, format="csc"), sp.vstack(eq, format="csc"), np.concatenate(b)
    v = _solve(P, np.zeros(diag.size), G, h, Eq, beq, solver)
    if v is None:
        return None
    v = polish_active_set(P, G, h, Eq, beq, v)
    U = su * v[:N]
    # exact final state: minimum-norm correction of the n final-state rows, equilibrated
    # (the Gram matrix Sigma Sigma^T of a fast-sampled rigid body is too ill-conditioned)
    resid = xN - _states(A, B, x0, U)[-1]
    scale = np.linalg.norm(Sigma, axis=1)
    scale[scale == 0] = 1.0
    return U + np.linalg.lstsq(Sigma / scale[:, None], resid / scale, rcond=None)[0]


#: from this many steps on the constrained FSC tries the banded QP first (measured by
#: bench/qp.py: at N = 100 the dense path is as fast, at N = 300 it is 6x slower)
SPARSE_MIN_STEPS = 200


def prefers_banded(N: int, n_states: int, n_band_rows: int) -> bool:
    """Whether the banded QP is expected to beat the dense one (module docstring).

    The dense interior-point iteration costs ``~N^3``; the banded one ``~N n (n + r)^2``
    once the ``r <= min(m, N)`` band rows fill the factor.  The factor 8 is measured:
    with the HDD Table 2.4 bands (m = 480 rows, n = 15) the banded QP lost at every
    N = 100 ... 1000 (0.2-3 s vs 0.02-2.5 s), so such problems go to the dense path.

    Parameters
    ----------
    N : int
        Steps.
    n_states : int
        States of the design model.
    n_band_rows : int
        Frequency-shaping rows ``m`` of the cost (0 without bands).

    Returns
    -------
    bool
    """
    if N < SPARSE_MIN_STEPS:
        return False
    r = min(n_band_rows, N)
    return r == 0 or 8 * n_states * (n_states + r) ** 2 <= N**2


def limits_of(
    constraints: Sequence[object], position: np.ndarray, velocity: np.ndarray
) -> list[SparseRow] | None:
    """``(Cz, a, b, zmax)`` of every constraint, or None if one is not a row limit."""
    from types import SimpleNamespace

    from servokit.feedforward.constraints import SignalLimit, _RowLimit

    rows_model = SimpleNamespace(position=position, velocity=velocity)
    out: list[SparseRow] = []
    for con in constraints:
        if isinstance(con, _RowLimit):
            con = con._limit(rows_model)  # type: ignore[arg-type]
        if not isinstance(con, SignalLimit):
            return None
        Cz = None if con.state_row is None else np.asarray(con.state_row, dtype=float)
        if Cz is not None and Cz.size != position.size:
            return None  # the dense path reports the shape error
        out.append((Cz, float(con.input_coef), float(con.rate_coef), float(con.max_abs)))
    return out


def sparse_constrained_fsc(
    A: np.ndarray,
    B: np.ndarray,
    N: int,
    x0: np.ndarray,
    xN: np.ndarray,
    *,
    rho: float,
    band_rows: np.ndarray | None,
    dt: float,
    position: np.ndarray,
    velocity: np.ndarray,
    input_row: np.ndarray,
    constraints: Sequence[object],
    rtol: float = 1e-9,
) -> np.ndarray | None:
    """The banded QP with checks, or None (unsupported constraint, solver failure,
    infeasible, an answer missing the limits (1e-6) or the final state (``rtol``)).

    Parameters
    ----------
    A, B, N, x0, xN, rho, band_rows, dt, input_row
        As for :func:`solve_banded_fsc_qp`.
    position, velocity : numpy.ndarray
        State rows of the output position and velocity (for the constraint objects).
    constraints : sequence
        Constraint objects of :mod:`servokit.feedforward.constraints`.
    rtol : float
        Accepted relative error of the final state.

    Returns
    -------
    numpy.ndarray or None
        ``U`` (N,), or None when the dense path must decide.
    """
    limits = limits_of(constraints, position, velocity)
    if limits is None:
        return None
    # Clarabel first: its sparse LDL copes with the (compressed) band rows; PIQP's sparse
    # backend is the second opinion
    for solver in ("clarabel", "piqp"):
        U = solve_banded_fsc_qp(
            A, B, N, x0, xN, dt=dt, input_row=input_row, limits=limits, rho=rho,
            band_rows=band_rows, solver=solver,
        )  # fmt: skip
        if U is None:
            continue
        xs_end = _states(A, B, x0, U)[-1]
        scale = np.abs(_reachability(A, B, N)) @ np.abs(U) + np.abs(xN)
        ok_final = np.all(np.abs(xs_end - xN) <= rtol * np.where(scale > 0, scale, 1.0))
        viol = limit_violation(A, B, x0, U, dt=dt, input_row=input_row, limits=limits)
        if ok_final and viol <= 1e-6:
            return U
    return None
