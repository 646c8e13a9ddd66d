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
and ``e = (b/dt) c_u`` (no ``e`` term at ``k = N-1``).  Dense frequency-shaping rows
``W_b`` enter through auxiliary variables ``s = W_b U`` with cost ``||s||^2``, so the
Hessian stays diagonal.  The sparse problem goes to Clarabel (or PIQP's sparse backend)
through qpsolvers; the final state is then restored exactly by the minimum-norm
correction ``U += Sigma^T (Sigma Sigma^T)^-1 (x_N - x[N](U))`` (``Sigma`` of (2.30)),
which moves the inequalities by the solver's tolerance only.  The caller checks the
result and falls back to the dense path (which names binding constraints of an
infeasible problem) when the sparse solve fails.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
import scipy.sparse as sp

__all__ = ["SparseRow", "limit_violation", "solve_banded_fsc_qp"]

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


def _solve(P, q, G, h, E, b, solver: str) -> np.ndarray | None:
    from qpsolvers import Problem, solve_problem

    opts: dict[str, object]
    if solver == "clarabel":
        opts = {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12}
    else:
        opts = {"backend": "sparse", "eps_abs": 1e-11, "eps_rel": 1e-11}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            sol = solve_problem(Problem(P, q, G, h, E, b), solver=solver, **opts)
        except Exception:  # noqa: BLE001 - a failing backend returns None to the caller
            return None
    if not sol.found or sol.x is None or not np.all(np.isfinite(sol.x)):
        return None
    return np.asarray(sol.x, dtype=float)


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
    W: np.ndarray | None = None,
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
    W : ndarray, optional
        Cost factor ``J = ||W U||^2``; rows ``sqrt(rho) I`` first (as built by the FFSC
        design), any further rows become auxiliary variables.  ``None``: ``J = ||U||^2``.
    solver : {"clarabel", "piqp"}

    Returns
    -------
    ndarray (N,) or None when the solver fails (infeasible or numerical trouble).
    """
    n = A.shape[0]
    rho, Wb = 1.0, np.zeros((0, N))
    if W is not None:
        rho = float(W[0, 0] ** 2)
        Wb = W[N:]
    n_aux = Wb.shape[0]
    E, rhs = _dynamics(A, B, N, x0, n_aux)
    # final state and the auxiliary rows s - W_b U = 0
    sel = sp.hstack([sp.csc_matrix((n, N + (N - 1) * n)), sp.identity(n),
                     sp.csc_matrix((n, n_aux))], format="csc")  # fmt: skip
    eq = [E, sel]
    b = [rhs, np.asarray(xN, dtype=float)]
    if n_aux:
        eq.append(sp.hstack([sp.csc_matrix(-Wb), sp.csc_matrix((n_aux, N * n)),
                             sp.identity(n_aux)], format="csc"))  # fmt: skip
        b.append(np.zeros(n_aux))
    Aeq = sp.vstack(eq, format="csc")
    beq = np.concatenate(b)
    diag = np.r_[np.full(N, rho), np.zeros(N * n), np.ones(n_aux)]
    P = sp.diags(diag, format="csc")
    G, h = _limit_rows(limits, np.asarray(input_row, dtype=float), dt, N, x0, n_aux)
    v = _solve(P, np.zeros(diag.size), G, h, Aeq, beq, solver)
    if v is None:
        return None
    U = v[:N]
    # exact final state: minimum-norm correction of the n final-state rows, equilibrated
    # (the Gram matrix Sigma Sigma^T of a fast-sampled rigid body is too ill-conditioned)
    Sigma = _reachability(A, B, N)
    resid = xN - _states(A, B, x0, U)[-1]
    scale = np.linalg.norm(Sigma, axis=1)
    scale[scale == 0] = 1.0
    U = U + np.linalg.lstsq(Sigma / scale[:, None], resid / scale, rcond=None)[0]
    return U


#: from this many steps on the constrained FSC tries the banded QP first (at N = 200 it
#: is already 10x faster than the dense path; below ~100 both take milliseconds)
SPARSE_MIN_STEPS = 100


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
    W: np.ndarray | None,
    *,
    dt: float,
    position: np.ndarray,
    velocity: np.ndarray,
    input_row: np.ndarray,
    constraints: Sequence[object],
    rtol: float = 1e-9,
) -> np.ndarray | None:
    """The banded QP with checks: ``U`` meeting the limits (1e-6) and the final state
    (``rtol``), or None (unsupported constraint, solver failure, infeasible)."""
    limits = limits_of(constraints, position, velocity)
    if limits is None:
        return None
    for solver in ("piqp", "clarabel"):
        U = solve_banded_fsc_qp(
            A, B, N, x0, xN, dt=dt, input_row=input_row, limits=limits, W=W, solver=solver
        )
        if U is None:
            continue
        xs_end = _states(A, B, x0, U)[-1]
        scale = np.abs(_reachability(A, B, N)) @ np.abs(U) + np.abs(xN)
        ok_final = np.all(np.abs(xs_end - xN) <= rtol * np.where(scale > 0, scale, 1.0))
        viol = limit_violation(A, B, x0, U, dt=dt, input_row=input_row, limits=limits)
        if ok_final and viol <= 1e-6:
            return U
    return None
