"""Constrained final-state control: constraint rows and the QP solver (book §2.3.4, §2.6.2).

Implements

- (2.62)-(2.63): a constrained variable ``z[k] = Cz x[k] + Dz u[k]`` kept within
  ``|z[k]| <= zmax`` for ``k = 0..N-1``;
- (2.67)-(2.71): its lifted form ``Z = Phi_z x[0] + Omega_z U`` (here taken from the
  :class:`~servokit.feedforward.fsc.LiftedModel` of the FSC design, which holds the
  state after every step as an affine function of the decision vector ``U``);
- (2.72): the inequality rows ``[Omega_z; -Omega_z] U <= [Zmax - Phi_z x0; Zmax + Phi_z x0]``;
- (2.64)-(2.66): the QP ``min U^T P U + 2 q^T U`` (``P`` from (2.27) or (2.59)) with the
  final-state equality (2.29) and those inequalities, solved by :func:`solve_fsc_qp`;
- (2.83)-(2.88): the motor-voltage, current and velocity constraints of a current-driven
  actuator: ``zvol[k] = R uc[k] + L (uc[k+1] - uc[k]) / tau + Ke xv[k]`` (2.84)-(2.86),
  ``zcur[k] = uc[k]`` (2.87), ``zvel[k] = xv[k]`` (2.88).  The book's (2.71) shows a zero
  diagonal; with ``Dz != 0`` (the voltage's ``L / tau``) the diagonal is ``Dz``.

Every constraint object has a ``name`` and ``rows(model) -> (G, h)``; pass several to
``fsc_input(..., constraints=[...])``.  :func:`constraint_rows` stacks them and returns the
row groups that :func:`solve_fsc_qp` uses to name the binding constraint when the problem
is infeasible (:class:`InfeasibleConstraintsError`).
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

# scipy.linalg, scipy.optimize and scipy.sparse load on first attribute access (SciPy's
# lazy submodules): an unconstrained FSC design never needs them (start-up, issue 23)
import scipy

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite, check_positive
from servokit.feedforward import _qp_rows
from servokit.feedforward._qp_rows import solve_by_rows

if TYPE_CHECKING:
    from servokit.feedforward.fsc import LiftedModel

__all__ = [
    "InfeasibleConstraintsError",
    "MotorModel",
    "SignalLimit",
    "InputLimit",
    "CurrentLimit",
    "VelocityLimit",
    "PositionLimit",
    "VoltageLimit",
    "constraint_rows",
    "solve_fsc_qp",
]

#: accepted relative violation of an inequality row after the solve
_INEQ_RTOL = 1e-6


class InfeasibleConstraintsError(ServokitValueError):
    """No input satisfies the final state and the constraints together.

    Attributes
    ----------
    binding : tuple of str
        Names of the constraint groups each of which, when dropped, makes the problem
        feasible (empty when only several of them dropped together would).
    """

    def __init__(self, message: str, binding: Sequence[str] = ()) -> None:
        super().__init__(message)
        self.binding = tuple(binding)


@dataclass(frozen=True)
class MotorModel:
    """Electrical and mechanical constants of a current-driven actuator (Fig. 2.33).

    Parameters
    ----------
    resistance : float
        Armature resistance R [ohm].
    inductance : float
        Armature inductance L [H].
    back_emf : float
        Back-EMF coefficient Ke [V per unit of the plant-output velocity], e.g. V s/m.
    torque_constant, inertia : float, optional
        Kt and J; not needed by the constraints (they only enter the plant gain ``Kt/J``).
    """

    resistance: float
    inductance: float
    back_emf: float
    torque_constant: float | None = None
    inertia: float | None = None

    def __post_init__(self) -> None:
        for name in ("resistance", "inductance", "back_emf"):
            if float(check_finite(name, getattr(self, name))) < 0:
                raise ServokitValueError(f"MotorModel.{name} must be >= 0")

    def voltage(self, current: np.ndarray, velocity: np.ndarray, dt: float) -> np.ndarray:
        """Discrete motor voltage (2.84) for held currents ``uc[0..N-1]`` (``uc[N] = 0``)."""
        i = np.asarray(current, dtype=float)
        di = np.diff(np.append(i, 0.0)) / check_positive("dt", dt)
        return self.resistance * i + self.inductance * di + self.back_emf * np.asarray(velocity)


@dataclass(frozen=True)
class SignalLimit:
    """``|z[k]| <= max_abs`` for ``z[k] = state_row @ x[k] + input_coef * uc[k]
    + rate_coef * (uc[k+1] - uc[k]) / dt``, ``k = 0..N-1`` (eqs. 2.62-2.63, 2.72).

    ``uc`` is the held plant input of the lifted model (``uc[N] = 0``).  The specific
    limits below are this class with the rows of (2.84)-(2.88).

    Parameters
    ----------
    max_abs : float
        ``zmax`` > 0 (units of z).
    state_row : ndarray (n,), optional
        ``Cz`` over the design model's state.
    input_coef, rate_coef : float
        Weights of the plant input and of its forward difference per second.
    name : str
        Name used in error messages.
    """

    max_abs: float
    state_row: np.ndarray | None = None
    input_coef: float = 0.0
    rate_coef: float = 0.0
    name: str = "signal"

    def __post_init__(self) -> None:
        check_positive(f"{self.name} limit max_abs", self.max_abs)

    def signal(self, model: LiftedModel) -> tuple[np.ndarray, np.ndarray]:
        """Lifted ``Z = offset + gain @ U`` (eq. 2.68): ``(offset (N,), gain (N, N))``."""
        N = model.N
        offset = np.zeros(N)
        gain = np.zeros((N, N))
        if self.state_row is not None:
            row = np.asarray(self.state_row, dtype=float).reshape(-1)
            if row.size != model.n_states:
                raise ServokitValueError(
                    f"{self.name}: state_row has {row.size} entries, the model has "
                    f"{model.n_states} states"
                )
            offset += model.x_offset[:N] @ row
            gain += np.einsum("i,kij->kj", row, model.x_gain[:N])
        if self.input_coef or self.rate_coef:
            u_off = np.append(model.u_offset, 0.0)
            u_gain = np.vstack([model.u_gain, np.zeros((1, N))])
            rate = self.rate_coef / model.dt
            offset += self.input_coef * u_off[:N] + rate * np.diff(u_off)
            gain += self.input_coef * u_gain[:N] + rate * np.diff(u_gain, axis=0)
        return offset, gain

    def rows(self, model: LiftedModel) -> tuple[np.ndarray, np.ndarray]:
        """Inequality rows ``G U <= h`` of eq. (2.72): ``(G (2N, N), h (2N,))``."""
        offset, gain = self.signal(model)
        zmax = float(self.max_abs)
        return np.vstack([gain, -gain]), np.concatenate([zmax - offset, zmax + offset])


@dataclass(frozen=True)
class _RowLimit:
    """A named ``|z[k]| <= max_abs`` whose rows come from a :class:`SignalLimit`."""

    max_abs: float

    def __post_init__(self) -> None:
        check_positive(f"{type(self).__name__}.max_abs", self.max_abs)

    @property
    def name(self) -> str:
        """Label used in error messages."""
        raise NotImplementedError  # pragma: no cover - abstract

    def _limit(self, model: LiftedModel) -> SignalLimit:
        raise NotImplementedError  # pragma: no cover - abstract

    def signal(self, model: LiftedModel) -> tuple[np.ndarray, np.ndarray]:
        """Lifted ``Z = offset + gain @ U`` (eq. 2.68)."""
        return self._limit(model).signal(model)

    def rows(self, model: LiftedModel) -> tuple[np.ndarray, np.ndarray]:
        """Inequality rows ``G U <= h`` of eq. (2.72)."""
        return self._limit(model).rows(model)


@dataclass(frozen=True)
class InputLimit(_RowLimit):
    """``|uc[k]| <= max_abs`` on the held plant input (saturation, §2.3.4)."""

    @property
    def name(self) -> str:
        """Label used in error messages."""
        return f"input |u| <= {self.max_abs:g}"

    def _limit(self, model: LiftedModel) -> SignalLimit:
        return SignalLimit(self.max_abs, input_coef=1.0, name=self.name)


@dataclass(frozen=True)
class CurrentLimit(InputLimit):
    """``|zcur[k]| = |uc[k]| <= max_abs`` [A] for a current-input plant (2.87)."""

    @property
    def name(self) -> str:
        """Label used in error messages."""
        return f"current |i| <= {self.max_abs:g} A"


@dataclass(frozen=True)
class VelocityLimit(_RowLimit):
    """``|zvel[k]| = |xv[k]| <= max_abs`` on the output velocity (2.88) [output units/s]."""

    @property
    def name(self) -> str:
        """Label used in error messages."""
        return f"velocity |v| <= {self.max_abs:g}"

    def _limit(self, model: LiftedModel) -> SignalLimit:
        return SignalLimit(self.max_abs, state_row=model.velocity, name=self.name)


@dataclass(frozen=True)
class PositionLimit(_RowLimit):
    """``|y[k]| <= max_abs`` on the output at the sampling instants (overshoot limit)."""

    @property
    def name(self) -> str:
        """Label used in error messages."""
        return f"position |y| <= {self.max_abs:g}"

    def _limit(self, model: LiftedModel) -> SignalLimit:
        return SignalLimit(self.max_abs, state_row=model.position, name=self.name)


@dataclass(frozen=True)
class VoltageLimit(_RowLimit):
    """``|zvol[k]| <= max_abs`` [V], motor voltage approximated by (2.84)-(2.86).

    ``zvol[k] = R uc[k] + L (uc[k+1] - uc[k]) / tau + Ke xv[k]`` with the plant input
    ``uc`` the motor current [A] and ``xv`` the output velocity.
    """

    motor: MotorModel | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.motor, MotorModel):
            raise ServokitTypeError(
                "VoltageLimit needs motor=MotorModel(resistance, inductance, back_emf)"
            )

    @property
    def name(self) -> str:
        """Label used in error messages."""
        return f"voltage |V| <= {self.max_abs:g} V"

    def _limit(self, model: LiftedModel) -> SignalLimit:
        m = self.motor
        assert m is not None  # checked in __post_init__
        return SignalLimit(
            self.max_abs,
            state_row=m.back_emf * model.velocity,
            input_coef=m.resistance,
            rate_coef=m.inductance,
            name=self.name,
        )


def constraint_rows(
    constraints: Iterable[object], model: LiftedModel
) -> tuple[np.ndarray, np.ndarray, list[tuple[str, int]]]:
    """Stack the rows of several constraints: ``(G, h, groups)``.

    Parameters
    ----------
    constraints : iterable
        Constraint objects of this module, each with a ``rows(model)`` method returning
        ``(G, h)`` for ``G U <= h``.
    model : LiftedModel
        The lifted FSC model (input samples ``U`` as variables).

    Returns
    -------
    G : numpy.ndarray
        Stacked inequality matrix, shape (rows, N).
    h : numpy.ndarray
        Stacked right-hand side, shape (rows,).
    groups : list of (str, int)
        ``(name, n_rows)`` in order; pass it to :func:`solve_fsc_qp` so that an infeasible
        problem names its binding constraint.
    """
    G_parts, h_parts, groups = [], [], []
    for i, con in enumerate(constraints):
        if not callable(getattr(con, "rows", None)):
            raise ServokitTypeError(
                f"constraints[{i}] has no rows(model) method; use the classes of "
                "servokit.feedforward.constraints"
            )
        G, h = con.rows(model)
        G = np.atleast_2d(np.asarray(G, dtype=float))
        h = np.asarray(h, dtype=float).reshape(-1)
        G_parts.append(G)
        h_parts.append(h)
        groups.append((str(getattr(con, "name", f"constraints[{i}]")), G.shape[0]))
    if not G_parts:
        return np.zeros((0, model.N)), np.zeros(0), []
    return np.vstack(G_parts), np.concatenate(h_parts), groups


# ------------------------------------------------------------------------- QP solve
def _null_space_split(A_eq: np.ndarray, b_eq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Particular (minimum-norm) solution and null-space basis of ``A_eq U = b_eq``.

    Eliminating the final-state equality this way keeps it exact to round-off whatever
    tolerance the QP solver works to.
    """
    scale = np.linalg.norm(A_eq, axis=1)
    if np.any(scale == 0):
        i = int(np.flatnonzero(scale == 0)[0])
        if b_eq[i] != 0:
            raise InfeasibleConstraintsError(
                f"final-state row {i} of A_eq is zero but b_eq is not: that state cannot be "
                "reached; check the model's controllability",
                ("final state",),
            )
        scale[i] = 1.0
    As, bs = A_eq / scale[:, None], b_eq / scale
    u_svd, s, vt = scipy.linalg.svd(As, full_matrices=True)
    rank = int(np.sum(s > s[0] * max(As.shape) * np.finfo(float).eps)) if s.size else 0
    coeff = (u_svd[:, :rank].T @ bs) / s[:rank]
    U_p = vt[:rank].T @ coeff
    if np.linalg.norm(As @ U_p - bs) > 1e-9 * max(np.linalg.norm(bs), 1e-300):
        raise InfeasibleConstraintsError(
            "the final-state equality A_eq U = b_eq is inconsistent (A_eq rank deficient); "
            "check the model's controllability or use a larger N",
            ("final state",),
        )
    return U_p, vt[rank:].T


def _feasible(G: np.ndarray, h: np.ndarray) -> bool:
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


def _max_violation(G: np.ndarray, h: np.ndarray, w: np.ndarray) -> float:
    if G.shape[0] == 0:
        return 0.0
    scale = np.abs(G) @ np.abs(w) + np.abs(h) + 1e-300
    return float(np.max((G @ w - h) / scale))


def solve_fsc_qp(
    P: np.ndarray,
    q: np.ndarray,
    A_eq: np.ndarray,
    b_eq: np.ndarray,
    G: np.ndarray | None = None,
    h: np.ndarray | None = None,
    *,
    groups: Sequence[tuple[str, int]] | None = None,
    solver: str = "piqp",
    rtol: float = 1e-9,
) -> np.ndarray:
    """Solve the constrained FSC QP (2.64)-(2.66): ``min U^T P U + 2 q^T U``.

    Subject to ``A_eq U = b_eq`` (final state, (2.29)) and ``G U <= h`` ((2.72)).  The
    equality is eliminated exactly (minimum-norm particular solution plus a null-space
    basis from an SVD of the row-equilibrated ``A_eq``); the remaining inequality QP goes
    to ``qpsolvers`` with PIQP, falling back to Clarabel.

    Parameters
    ----------
    P : ndarray (N, N)
        Symmetric positive (semi-)definite cost matrix.
    q : ndarray (N,)
        Linear cost term (``q = 0`` for (2.64)).
    A_eq, b_eq : ndarray (m, N), (m,)
        Final-state equality.
    G, h : ndarray (p, N), (p,), optional
        Inequality rows (e.g. from :func:`constraint_rows`).
    groups : sequence of (name, n_rows), optional
        Names of consecutive row blocks of ``G`` (from :func:`constraint_rows`), used to
        name the binding constraint when the problem is infeasible.
    solver : {"piqp", "clarabel"}
        First QP backend tried; the other one is the fallback.
    rtol : float
        Largest accepted component-wise relative residual of the final state.

    Returns
    -------
    ndarray (N,)

    Raises
    ------
    InfeasibleConstraintsError
        No ``U`` meets the final state and the inequalities; ``.binding`` names the group(s).
    ServokitValueError
        Shapes inconsistent, or both solvers fail on a feasible problem.
    """
    P = check_finite("P", P)
    N = P.shape[0]
    if P.shape != (N, N):
        raise ServokitValueError(f"P must be square (N, N), got {P.shape}")
    q = check_finite("q", q).reshape(-1)
    A_eq = np.atleast_2d(check_finite("A_eq", A_eq))
    b_eq = check_finite("b_eq", b_eq).reshape(-1)
    G = np.zeros((0, N)) if G is None else np.atleast_2d(check_finite("G", G))
    h = np.zeros(0) if h is None else check_finite("h", h).reshape(-1)
    if q.size != N or A_eq.shape[1] != N or G.shape[1] != N:
        raise ServokitValueError(
            f"q, A_eq and G must have N={N} entries/columns to match P; got {q.size}, "
            f"{A_eq.shape[1]}, {G.shape[1]}"
        )
    if b_eq.size != A_eq.shape[0] or h.size != G.shape[0]:
        raise ServokitValueError("b_eq and h must have one entry per row of A_eq and G")
    if solver not in ("piqp", "clarabel"):
        raise ServokitValueError(f"solver must be 'piqp' or 'clarabel', got {solver!r}")
    if groups is None:
        groups = [("inequality constraints", G.shape[0])] if G.shape[0] else []
    if sum(n for _, n in groups) != G.shape[0]:
        raise ServokitValueError("groups must cover the rows of G exactly (sum of n_rows)")

    U_p, Z = _null_space_split(A_eq, b_eq)
    # In w-space: U = U_p + Z w.  Rows of G are equilibrated so the solver tolerance is
    # relative to each constraint's size.
    Gw = G @ Z
    hw = h - G @ U_p
    row = np.linalg.norm(Gw, axis=1)
    # rows the null space cannot move are fixed by the final state alone
    const_rows = row <= 1e-12 * np.linalg.norm(G, axis=1)
    violated = const_rows & (hw < -1e-9 * (np.abs(h) + np.abs(G) @ np.abs(U_p)))
    if np.any(violated):
        bad = _group_of(int(np.flatnonzero(violated)[0]), groups)
        raise InfeasibleConstraintsError(
            f"constraint '{bad}' is violated by every input that reaches the final state; "
            "relax it or change N",
            (bad,),
        )
    keep = ~const_rows
    Gw, hw, row = Gw[keep], hw[keep], row[keep]
    kept_groups = _kept_groups(groups, keep)
    # w = w_scale * w~ with w_scale the size of the particular solution: the solvers'
    # absolute tolerances then apply to an O(1) problem (a HDD input of 1e-7 A/step with
    # a cost of 1e-13 otherwise stops PIQP at its first iterate, far from the optimum)
    w_scale = float(np.max(np.abs(U_p), initial=0.0)) or 1.0
    Gw, hw = Gw / row[:, None], hw / (row * w_scale)
    Pw = Z.T @ P @ Z
    Pw = 0.5 * (Pw + Pw.T)
    qw = Z.T @ (P @ U_p + q)
    cost_scale = max(float(np.max(np.abs(np.diag(Pw)), initial=0.0)), 1e-300)
    Pw, qw = Pw / cost_scale, qw / (cost_scale * w_scale)

    # with an empty null space every row is constant and was checked above
    w = np.zeros(0) if Z.shape[1] == 0 else None
    start = None  # the unconstrained optimum, where the row generation starts
    if w is None:
        # the unconstrained optimum, when it meets every limit, is the answer: exact, and it
        # spares the interior-point solvers the degenerate case of limits touching it
        w0 = _stationary_point(Pw, qw)
        stationary = np.linalg.norm(Pw @ w0 + qw) <= 1e-10 * max(np.linalg.norm(qw), 1.0)
        start = w0 if stationary else None
        # judged in U-space: in w-space the relative scale vanishes where w0 = 0
        if stationary and _max_violation(G, h, U_p + w_scale * (Z @ w0)) <= _INEQ_RTOL:
            w = w0
        elif stationary and 0 < Gw.shape[0] < _qp_rows.MIN_ROWS:
            # active-set iterations from the unconstrained optimum: exact, and on the FSC
            # problems a few dense solves instead of a whole interior-point run (with more
            # rows the generated-rows solve below is cheaper: the galvano N = 351 designs
            # never settled in 12 iterations, 40 ms each)
            w = _active_set(Pw, qw, Gw, hw, w0, iterations=12)
    backends = (solver, "clarabel" if solver == "piqp" else "piqp")
    for name in backends if w is None else ():
        # on the rows the unconstrained optimum violates first (_qp_rows): same optimum
        cand = solve_by_rows(functools.partial(_run_solver, name), Pw, qw, Gw, hw, start)
        if cand is not None and _max_violation(Gw, hw, cand) <= _INEQ_RTOL:
            w = _polish(Pw, qw, Gw, hw, cand)
            break
    if w is None:
        if not _feasible(Gw, hw):
            binding = _binding_groups(Gw, hw, kept_groups)
            names = ", ".join(f"'{b}'" for b in binding) or "all constraints together"
            raise InfeasibleConstraintsError(
                f"no input reaches the final state within the constraints; binding: {names}. "
                "Relax that limit or increase N",
                binding,
            )
        raise ServokitValueError(
            "the QP solvers (piqp, clarabel) failed on a feasible constrained FSC problem; "
            "rescale the model (e.g. normalised units) or change N"
        )
    U = U_p + Z @ (w_scale * w)
    resid = np.abs(A_eq @ U - b_eq)
    denom = np.abs(A_eq) @ np.abs(U) + np.abs(b_eq)
    err = float(np.max(resid / np.where(denom > 0, denom, 1.0), initial=0.0))
    if err > rtol:
        raise ServokitValueError(
            f"constrained FSC missed the final state by a relative {err:.2e} > rtol={rtol:.1e}; "
            "reduce N or rescale the model"
        )
    return U


def _group_of(index: int, groups: Sequence[tuple[str, int]]) -> str:
    start = 0
    for name, n in groups:
        if index < start + n:
            return name
        start += n
    return "inequality constraints"  # pragma: no cover - index always inside the groups


def _kept_groups(
    groups: Sequence[tuple[str, int]], keep: np.ndarray
) -> list[tuple[str, np.ndarray]]:
    out, start = [], 0
    for name, n in groups:
        out.append((name, keep[start : start + n]))
        start += n
    return out


def _binding_groups(
    G: np.ndarray, h: np.ndarray, groups: list[tuple[str, np.ndarray]]
) -> list[str]:
    """Groups whose removal alone makes ``G w <= h`` feasible."""
    labels = np.concatenate([np.full(int(m.sum()), i) for i, (_, m) in enumerate(groups)])
    if len(groups) == 1:
        return [groups[0][0]]
    return [name for i, (name, _) in enumerate(groups) if _feasible(G[labels != i], h[labels != i])]
