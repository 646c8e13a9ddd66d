"""Final-state control (FSC): minimum-norm inputs that steer x[0] to x[N] in N steps.

Implements the book's eqs. (2.26)-(2.35) (§2.3.1):

* (2.29)-(2.30): ``x[N] - A^N x[0] = Sigma U`` with ``Sigma = [A^{N-1}B, ..., AB, B]``;
* (2.35): ``U = Q^{-1} Sigma^T (Sigma Q^{-1} Sigma^T)^{-1} (x[N] - A^N x[0])``, the input of
  minimum ``U^T Q U`` satisfying (2.29);
* (2.67)-(2.71): the lifted ("stacked") map from the decision vector to the state after
  every step, which the frequency-shaped (FFSC) and constrained (QP) designs reuse.

Numerics.  (2.35) is never evaluated as written: the Gram matrix ``Sigma Q^{-1} Sigma^T``
of a rigid body sampled fast is ill-conditioned far beyond double precision for
N of a few hundred.  Instead, with ``Q = R^T R`` (Cholesky, or the R of a QR of a
weighting matrix W with ``Q = W^T W``) and ``V = R U``, the problem becomes the
minimum-Euclidean-norm solution of ``(Sigma R^{-1}) V = X``; its rows are equilibrated
(each state scaled by its row norm, which does not change the solution) and the
minimum-norm solution is taken from a QR factorisation of the transposed matrix.  The
final-state residual is checked row-wise against the size of each equation
(||Sigma_i|| ||U|| + |x_i|) before returning.

Start-up (issue 23): the factorisations are numpy's LAPACK (``numpy.linalg.qr``, the same
Householder QR as ``scipy.linalg.qr``, and the triangular solves of :func:`_solve_upper`),
so that a seek design does not import scipy.linalg, whose import alone costs a command a
fifth of a second.  ``tests/test_fsc.py`` compares them with the SciPy routines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite

__all__ = [
    "LiftedModel",
    "final_state_control",
    "lifted_model",
    "lifted_state_map",
    "min_norm_final_state",
]

#: relative threshold below which an equilibrated reachability matrix is rank deficient
_RANK_TOL = 1e-13


def _as_system(A: object, B: object) -> tuple[np.ndarray, np.ndarray]:
    """Validate a single-input discrete pair; return ``A`` (n, n) and ``B`` (n,)."""
    A = check_finite("A", A)
    B = check_finite("B", B)
    if A.ndim != 2 or A.shape[0] != A.shape[1] or A.shape[0] == 0:
        raise ServokitValueError(f"A must be a square (n, n) matrix, got shape {A.shape}")
    n = A.shape[0]
    if B.ndim == 2 and B.shape[1] != 1:
        raise ServokitValueError(
            f"B must be a single input column (n,) or (n, 1), got shape {B.shape}; "
            "final-state control here is single-input"
        )
    B = B.reshape(-1)
    if B.shape[0] != n:
        raise ServokitValueError(f"B must have {n} rows to match A, got {B.shape[0]}")
    return A, B


def _solve_upper(R: np.ndarray, b: np.ndarray, *, trans: bool = False) -> np.ndarray:
    """``R^{-1} b`` (or ``R^{-T} b``) for an upper-triangular, non-singular ``R``.

    ``numpy.linalg.solve`` factorises ``R = P L U`` with partial pivoting; below the
    diagonal of an upper-triangular matrix every entry is an exact zero, so no row is
    swapped, ``L = I`` and ``U = R`` exactly, and the solve is the back substitution of
    ``scipy.linalg.solve_triangular`` (equal to rounding, tested).  ``R^T`` is lower
    triangular: reversing the order of rows and columns makes it upper triangular again.
    """
    if not trans:
        return np.linalg.solve(R, b)
    return np.linalg.solve(R.T[::-1, ::-1], b[::-1])[::-1]


def _as_steps(N: object) -> int:
    if isinstance(N, bool) or not isinstance(N, int | np.integer):
        raise ServokitTypeError(f"N must be an integer number of steps, got {N!r}")
    if N < 1:
        raise ServokitValueError(f"N must be >= 1 steps, got {N}")
    return int(N)


def _as_state(name: str, x: object, n: int) -> np.ndarray:
    x = check_finite(name, x).reshape(-1)
    if x.shape[0] != n:
        raise ServokitValueError(
            f"{name} must have {n} entries (the state dimension), got {x.size}"
        )
    return x


def _input_powers(A: np.ndarray, B: np.ndarray, N: int) -> np.ndarray:
    """``A^m B`` for ``m = 0..N-1`` (N, n), one matrix-vector product per step."""
    out = np.empty((N, B.shape[0]))
    out[0] = B
    for m in range(1, N):
        out[m] = A @ out[m - 1]
    return out


def lifted_state_map(A: np.ndarray, B: np.ndarray, N: int) -> tuple[np.ndarray, np.ndarray]:
    """Stacked maps ``x[k] = Phi[k] x[0] + Gamma[k] U`` for ``k = 0..N`` (eqs. 2.29, 2.67-2.71).

    Parameters
    ----------
    A : ndarray (n, n)
        Discrete state matrix.
    B : ndarray (n,) or (n, 1)
        Single input column.
    N : int
        Number of steps.

    Returns
    -------
    Phi : ndarray (N + 1, n, n)
        ``A^k``, built by repeated multiplication (one product per step).
    Gamma : ndarray (N + 1, n, N)
        Column ``j`` of ``Gamma[k]`` is ``A^{k-1-j} B`` for ``j < k`` and zero otherwise;
        ``Gamma[N]`` is the reachability matrix ``Sigma`` of eq. (2.30).
    """
    A, B = _as_system(A, B)
    N = _as_steps(N)
    n = A.shape[0]
    Phi = np.empty((N + 1, n, n))
    Phi[0] = np.eye(n)
    for k in range(1, N + 1):
        Phi[k] = A @ Phi[k - 1]
    # Gamma[k, :, j] = A^(k-1-j) B: row k is row k-1 shifted by one step with B in front,
    # copied slice by slice (a gather over the (N+1, N) lag grid took 2.3 s at N = 1000)
    powers_t = _input_powers(A, B, N)[::-1].T  # (n, N): column j is A^(N-1-j) B
    Gamma = np.zeros((N + 1, n, N))
    for k in range(1, N + 1):
        Gamma[k, :, :k] = powers_t[:, N - k :]
    return Phi, Gamma


def min_norm_final_state(
    Sigma: np.ndarray,
    X: np.ndarray,
    R: np.ndarray | None = None,
    *,
    rtol: float = 1e-9,
) -> np.ndarray:
    """Minimum ``||R U||`` solution of ``Sigma U = X`` (eq. 2.35 with ``Q = R^T R``).

    Parameters
    ----------
    Sigma : ndarray (n, N)
        Full-row-rank constraint matrix (the reachability matrix of eq. 2.30).
    X : ndarray (n,)
        Right-hand side ``x[N] - A^N x[0]``.
    R : ndarray (N, N), optional
        Upper-triangular, non-singular factor of the weight ``Q = R^T R``; identity if None.
    rtol : float
        Largest accepted row-wise normwise backward error of the final state.

    Returns
    -------
    ndarray (N,)

    Raises
    ------
    ServokitValueError
        If ``Sigma`` is (numerically) rank deficient or the residual check fails.
    """
    n, N = Sigma.shape
    M = Sigma if R is None else _solve_upper(R, Sigma.T, trans=True).T
    # Row equilibration: scaling equation i by 1/||M_i|| leaves the solution unchanged but
    # makes the QR below insensitive to the very different units of the states.
    row_norm = np.linalg.norm(M, axis=1)
    if np.any(row_norm == 0.0):
        i = int(np.flatnonzero(row_norm == 0.0)[0])
        raise ServokitValueError(
            f"state {i} cannot be moved by the input: the pair (A, B) is not controllable; "
            "remove the uncontrollable state or check B"
        )
    Ms = M / row_norm[:, None]
    Xs = X / row_norm
    Qf, Rf = np.linalg.qr(Ms.T, mode="reduced")
    diag = np.abs(np.diag(Rf))
    if diag.min() <= _RANK_TOL * max(diag.max(), 1.0) * np.sqrt(N):
        raise ServokitValueError(
            "the reachability matrix is rank deficient: the pair (A, B) is not controllable "
            f"in N={N} steps (or numerically uncontrollable); check A and B, or use a larger N"
        )
    V = Qf @ _solve_upper(Rf, Xs, trans=True)
    U = V if R is None else _solve_upper(R, V)
    if not np.all(np.isfinite(U)):
        raise ServokitValueError(
            "final-state control produced a non-finite input; rescale the model"
        )
    # Row-wise normwise backward error of the final-state equation: each residual is
    # judged against the size of its equation, ||Sigma_i|| ||U|| + |x_i|.  The
    # component-wise (Oettli-Prager) form divided a rounding-level residual by a zero
    # target (the delay state u[N-1] = 0) and refused correct inputs (issue 7).
    denom = np.linalg.norm(Sigma, axis=1) * np.linalg.norm(U) + np.abs(X)
    resid = np.abs(Sigma @ U - X)
    scale = np.where(denom > 0, denom, 1.0)
    err = float(np.max(resid / scale))
    if err > rtol:
        raise ServokitValueError(
            f"final state missed by a relative {err:.2e} > rtol={rtol:.1e}: the problem is too "
            "ill-conditioned in double precision; reduce N or rescale the model"
        )
    return U


def final_state_control(
    A: object,
    B: object,
    N: int,
    x0: object,
    xN: object,
    Q: object | None = None,
    *,
    Q_factor: object | None = None,
    rtol: float = 1e-9,
) -> np.ndarray:
    """Minimum-(weighted-)norm input steering ``x[0]`` to ``x[N]`` in ``N`` steps, eq. (2.35).

    Solves ``min U^T Q U`` subject to ``x[N] - A^N x[0] = Sigma U`` (eqs. 2.27-2.30) for
    the single-input discrete system ``x[k+1] = A x[k] + B u[k]`` (2.26).

    Parameters
    ----------
    A : array_like (n, n)
        Discrete state matrix.
    B : array_like (n,) or (n, 1)
        Input column.
    N : int
        Number of steps, ``N >= n`` (the system order).
    x0, xN : array_like (n,)
        Initial and final states.
    Q : array_like (N, N), optional
        Symmetric positive-definite weight of (2.27); identity if omitted.
    Q_factor : array_like (M, N), optional
        A matrix W with ``Q = W^T W`` (M >= N, full column rank).  Preferred over ``Q``
        when the weight is a sum of squares, as in the frequency-shaped cost (2.59):
        it is QR-factorised instead of forming and Cholesky-factorising ``Q``.
    rtol : float
        Largest accepted row-wise normwise backward error of the final state
        (residual of each equation over ``||Sigma_i|| ||U|| + |x_i|``).

    Returns
    -------
    ndarray (N,)
        ``U = (u[0], ..., u[N-1])``, eq. (2.28).

    Raises
    ------
    ServokitValueError
        ``N`` below the order, ``(A, B)`` not controllable, ``Q`` not positive definite,
        or the final state not met to ``rtol``.

    Examples
    --------
    >>> import numpy as np
    >>> A = np.array([[1.0, 1.0], [0.0, 1.0]]); B = np.array([0.5, 1.0])
    >>> u = final_state_control(A, B, 2, [0, 0], [1, 0])
    >>> np.allclose(u, [1.0, -1.0])
    True
    """
    A_, B_ = _as_system(A, B)
    N = _as_steps(N)
    n = A_.shape[0]
    if N < n:
        raise ServokitValueError(
            f"N={N} is below the system order {n}; final-state control needs N >= {n} steps"
        )
    x0_ = _as_state("x0", x0, n)
    xN_ = _as_state("xN", xN, n)
    if Q is not None and Q_factor is not None:
        raise ServokitValueError("give either Q or Q_factor, not both")
    R = None
    if Q is not None:
        Qm = check_finite("Q", Q)
        if Qm.shape != (N, N):
            raise ServokitValueError(f"Q must be ({N}, {N}) to match N, got {Qm.shape}")
        if not np.allclose(Qm, Qm.T, rtol=1e-10, atol=0.0):
            raise ServokitValueError("Q must be symmetric; pass (Q + Q.T) / 2")
        try:  # numpy returns the lower factor L = R^T
            R = np.linalg.cholesky(Qm).T
        except np.linalg.LinAlgError:
            raise ServokitValueError("Q must be positive definite (Cholesky failed)") from None
    elif Q_factor is not None:
        W = check_finite("Q_factor", Q_factor)
        if W.ndim != 2 or W.shape[1] != N or W.shape[0] < N:
            raise ServokitValueError(f"Q_factor must be (M, {N}) with M >= {N}, got {W.shape}")
        R = np.linalg.qr(W, mode="r")[:N]
        if np.min(np.abs(np.diag(R))) <= 1e-14 * np.max(np.abs(np.diag(R))):
            raise ServokitValueError("Q_factor must have full column rank (Q = W^T W singular)")
    # x[N] - A^N x[0] by N matrix-vector products (never A^N as a matrix power).
    free = x0_.copy()
    for _ in range(N):
        free = A_ @ free
    Sigma = _input_powers(A_, B_, N)[::-1].T
    return min_norm_final_state(Sigma, xN_ - free, R, rtol=rtol)


@dataclass(frozen=True, eq=False)
class LiftedModel:
    """Affine maps from the FSC decision vector ``U`` to everything a constraint can bound.

    For ``k = 0..N`` the state of the design model is ``x[k] = x_offset[k] + x_gain[k] @ U``
    (eqs. 2.67-2.68 for all states at once) and the held plant input over
    ``[k dt, (k+1) dt)`` is ``u_plant[k] = u_offset[k] + u_gain[k] @ U`` for ``k = 0..N-1``.
    For the augmented integrator design of (2.40)-(2.42) the decision vector is the
    jerk-like input and ``u_plant`` is ``u_c = Omega_w U`` of (2.46)-(2.48).

    Attributes
    ----------
    dt : float
        Sampling period [s].
    N : int
        Number of steps (length of ``U``).
    x_offset : ndarray (N + 1, n)
    x_gain : ndarray (N + 1, n, N)
    u_offset : ndarray (N,)
    u_gain : ndarray (N, N)
    position : ndarray (n,)
        Row ``c`` with output (position) ``y[k] = c @ x[k]``.
    velocity : ndarray (n,)
        Row with the output's time derivative ``dy/dt (k dt) = velocity @ x[k]``.
    """

    dt: float
    N: int
    x_offset: np.ndarray
    x_gain: np.ndarray
    u_offset: np.ndarray
    u_gain: np.ndarray
    position: np.ndarray
    velocity: np.ndarray

    @property
    def n_states(self) -> int:
        """Dimension of the design model's state."""
        return int(self.x_gain.shape[1])

    def states(self, U: np.ndarray) -> np.ndarray:
        """States ``x[0..N]`` (N + 1, n) produced by ``U``."""
        return self.x_offset + self.x_gain @ np.asarray(U, dtype=float)

    def plant_input(self, U: np.ndarray) -> np.ndarray:
        """Held plant input ``u_plant[0..N-1]`` produced by ``U``."""
        return self.u_offset + self.u_gain @ np.asarray(U, dtype=float)


def lifted_model(
    A: np.ndarray,
    B: np.ndarray,
    N: int,
    x0: np.ndarray,
    *,
    dt: float,
    position: np.ndarray,
    velocity: np.ndarray,
    input_row: np.ndarray | None = None,
) -> LiftedModel:
    """Build a :class:`LiftedModel` for ``x[k+1] = A x[k] + B u[k]`` from ``x[0] = x0``.

    Parameters
    ----------
    A : ndarray (n, n)
        Discrete state matrix.
    B : ndarray (n,) or (n, 1)
        Single input column.
    N : int
        Horizon (number of steps, the length of ``U``).
    x0 : ndarray (n,)
        Initial state.
    dt : float
        Sampling period [s].
    position, velocity : ndarray (n,)
        Output and output-rate rows of the design model.
    input_row : ndarray (n,), optional
        When given, the plant input is the state component ``input_row @ x[k]`` (the
        augmented integrator of eq. 2.41); otherwise the plant input is ``U`` itself.

    Returns
    -------
    LiftedModel
        ``x_offset[k] = A^k x0`` and ``x_gain = Gamma`` of :func:`lifted_state_map`
        (eqs. 2.67-2.71) for ``k = 0..N``; ``u_offset``, ``u_gain`` the plant input's
        affine map (zero and the identity without ``input_row``); ``position`` and
        ``velocity`` as given.
    """
    Phi, Gamma = lifted_state_map(A, B, N)
    x0 = np.asarray(x0, dtype=float)
    x_offset = Phi @ x0
    if input_row is None:
        u_offset, u_gain = np.zeros(N), np.eye(N)
    else:
        row = np.asarray(input_row, dtype=float)
        u_offset = x_offset[:N] @ row
        u_gain = np.einsum("i,kij->kj", row, Gamma[:N])
    return LiftedModel(
        dt=float(dt),
        N=int(N),
        x_offset=x_offset,
        x_gain=Gamma,
        u_offset=u_offset,
        u_gain=u_gain,
        position=np.asarray(position, dtype=float),
        velocity=np.asarray(velocity, dtype=float),
    )
