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

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, NoReturn

import numpy as np

# scipy.linalg, scipy.optimize and scipy.sparse load on first attribute access (SciPy's
# lazy submodules): an unconstrained FSC design never needs them (start-up, issue 23)
import scipy

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite, check_positive
from servokit.feedforward._qp_solve import feasible, max_violation, solve_reduced

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
    P, q, A_eq, b_eq, G, h, groups = _checked_qp(P, q, A_eq, b_eq, G, h, groups, solver)
    U_p, Z = _null_space_split(A_eq, b_eq)
    red = _reduced(P, q, G, h, U_p, Z, groups)
    w = np.zeros(0)  # no null space: every row is constant and was checked
    if Z.shape[1]:

        def violation_at(w0: np.ndarray) -> float:
            return max_violation(G, h, U_p + red.w_scale * (Z @ w0))

        w = solve_reduced(red.P, red.q, red.G, red.h, solver, violation_at)
    if w is None:
        _raise_unsolved(red)
    U = U_p + Z @ (red.w_scale * w)
    _check_final_state(A_eq, b_eq, U, rtol)
    return U


def _checked_qp(
    P: np.ndarray, q: np.ndarray, A_eq: np.ndarray, b_eq: np.ndarray,
    G: np.ndarray | None, h: np.ndarray | None,
    groups: Sequence[tuple[str, int]] | None, solver: str,
) -> tuple[Any, ...]:  # fmt: skip
    """The arguments of :func:`solve_fsc_qp` as checked float arrays, and the groups."""
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
    return P, q, A_eq, b_eq, G, h, groups


@dataclass
class _Reduced:
    """The QP in ``w`` (``U = U_p + w_scale Z w``), scaled to O(1): ``w^T P w + 2 q^T w``
    subject to ``G w <= h``, with the row groups that survived."""

    P: np.ndarray
    q: np.ndarray
    G: np.ndarray
    h: np.ndarray
    w_scale: float
    groups: list[tuple[str, np.ndarray]]


def _reduced(
    P: np.ndarray, q: np.ndarray, G: np.ndarray, h: np.ndarray, U_p: np.ndarray,
    Z: np.ndarray, groups: Sequence[tuple[str, int]],
) -> _Reduced:  # fmt: skip
    """The QP in the null space of the final state; rows it cannot move are checked here
    (:class:`InfeasibleConstraintsError` naming the group) and dropped."""
    # rows of G are equilibrated so the solver tolerance is relative to each one's size
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
    # w = w_scale * w~ with w_scale the size of the particular solution: the solvers'
    # absolute tolerances then apply to an O(1) problem (a HDD input of 1e-7 A/step with
    # a cost of 1e-13 otherwise stops PIQP at its first iterate, far from the optimum)
    w_scale = float(np.max(np.abs(U_p), initial=0.0)) or 1.0
    Pw = Z.T @ P @ Z
    Pw = 0.5 * (Pw + Pw.T)
    qw = Z.T @ (P @ U_p + q)
    cost_scale = max(float(np.max(np.abs(np.diag(Pw)), initial=0.0)), 1e-300)
    return _Reduced(
        Pw / cost_scale,
        qw / (cost_scale * w_scale),
        Gw / row[:, None],
        hw / (row * w_scale),
        w_scale,
        _kept_groups(groups, keep),
    )


def _raise_unsolved(red: _Reduced) -> NoReturn:
    """Why no answer was found: the binding groups, or the solvers' failure."""
    if not feasible(red.G, red.h):
        binding = _binding_groups(red.G, red.h, red.groups)
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


def _check_final_state(A_eq: np.ndarray, b_eq: np.ndarray, U: np.ndarray, rtol: float) -> None:
    resid = np.abs(A_eq @ U - b_eq)
    denom = np.abs(A_eq) @ np.abs(U) + np.abs(b_eq)
    err = float(np.max(resid / np.where(denom > 0, denom, 1.0), initial=0.0))
    if err > rtol:
        raise ServokitValueError(
            f"constrained FSC missed the final state by a relative {err:.2e} > rtol={rtol:.1e}; "
            "reduce N or rescale the model"
        )


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
    return [name for i, (name, _) in enumerate(groups) if feasible(G[labels != i], h[labels != i])]
