"""Initial value compensation on the feedback controller (book §3.3.1, (3.14)-(3.37)).

IVC loads the controller state at the switching instant as ``xc[0] = K xp[0]`` (3.14).

J-min IVC ((3.18)-(3.22), (3.90)-(3.91)). With ``J = sum_k x[k]^T Q x[k] = x[0]^T P x[0]``
and ``A^T P A - P = -Q`` (3.20), partition ``P = [[P_pp, P_pc], [P_pc^T, P_cc]]`` on
``[xp; xc]``. Then ``dJ/dxc[0] = 2 P_cc xc[0] + 2 P_pc^T xp[0]`` and the minimiser is

    xc[0] = -P_cc^{-1} P_pc^T xp[0].

Correction: the printed (3.21)-(3.22) write ``p11`` / ``p12`` (the plant blocks) where the
controller block ``P_cc`` and the transposed coupling ``P_pc^T`` belong; with the printed
indices the dimensions do not even agree unless n = m. When Q is only semidefinite (an
output weight ``Q = Cz^T Cz``, (3.91)) ``P_cc`` may be singular; J is still bounded below
(P >= 0 puts ``P_pc^T xp`` in the range of ``P_cc``), and the minimum-norm minimiser is
returned.

Pole-zero IVC ((3.23)-(3.37)). The transfer from ``xp[0]`` to ``y`` is
``C (zI - A)^{-1} z [I; K] xp[0]`` (3.27). For a simple closed-loop pole ``lam`` with right
and left eigenvectors ``v``, ``w``, ``adj(lam I - A) = c v w^H`` with ``c != 0``, so the
numerator of column i vanishes at ``lam`` exactly when ``w^H [e_i; K_i] = 0`` (given
``C v != 0``, i.e. the mode is observable, and ``lam != 0``). Writing ``w = [w_p; w_c]`` the
conditions (3.34) become ``w_c^H K = -w_p^H`` for every pole to cancel: the rows of the
book's Sigma and Gamma (3.35)-(3.36) up to a non-zero scale per row, without forming
adjugates of a singular matrix. A complex pole contributes the real and imaginary parts
of its equation, so conjugate pairs give a real K. With r equations and m controller
states: r = m is solved exactly, r < m by the minimum-norm K, r > m is refused.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_finite
from servokit.switching.loop import (
    SwitchedLoop,
    left_eig,
    siso_zeros,
    switched_loop,
    weighted_gramian,
)

__all__ = [
    "IvcGains",
    "ivc_jmin_jerk",
    "ivc_jmin",
    "ivc_pole_zero",
    "jmin_cost",
    "lyapunov_cost",
    "ivc_transfer",
    "ivc_zeros",
    "match_poles",
]


def _loop(plant_d: object, controller_d: object) -> SwitchedLoop:
    if isinstance(plant_d, SwitchedLoop):
        return plant_d
    return switched_loop(plant_d, controller_d)


def _require_schur(A: np.ndarray) -> None:
    rho = float(np.max(np.abs(np.linalg.eigvals(A))))
    if rho >= 1.0:
        raise ServokitValueError(
            f"the closed loop is not stable (spectral radius {rho:.6g} >= 1); IVC needs a "
            "stabilising controller"
        )


def _weight(loop: SwitchedLoop, Q: object | None, output_weight: object | None) -> np.ndarray:
    N = loop.n + loop.m
    if (Q is None) == (output_weight is None):
        raise ServokitValueError("give exactly one of Q (state weight) or output_weight (Cz)")
    if output_weight is not None:
        Cz = np.atleast_2d(check_finite("output_weight", output_weight))
        if Cz.shape[1] != N:
            raise ServokitValueError(f"output_weight must have {N} columns (n + m); got {Cz.shape}")
        return Cz.T @ Cz
    Qm = np.atleast_2d(check_finite("Q", Q))
    if Qm.shape == (1, N):
        Qm = np.diag(Qm[0])
    if Qm.shape != (N, N):
        raise ServokitValueError(f"Q must be {N}x{N} (or its diagonal); got {Qm.shape}")
    Qm = 0.5 * (Qm + Qm.T)
    if np.min(np.linalg.eigvalsh(Qm)) < -1e-12 * max(1.0, np.max(np.abs(Qm))):
        raise ServokitValueError("Q must be positive semidefinite")
    return Qm


def lyapunov_cost(loop: SwitchedLoop, Qm: np.ndarray) -> np.ndarray:
    """P of (3.19)-(3.20): ``sum_k x[k]^T Q x[k] = x[0]^T P x[0]`` for the free loop.

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    Qm : ndarray, shape (n + m, n + m)
        Symmetric semidefinite weight.

    Returns
    -------
    ndarray
        ``P`` of (3.20).
    """
    _require_schur(loop.A)
    return weighted_gramian(loop.A, Qm)


def ivc_jmin(
    plant_d: object,
    controller_d: object = None,
    Q: object | None = None,
    *,
    output_weight: object | None = None,
) -> np.ndarray:
    """J-min IVC gain K (m x n) minimising (3.18) over xc[0] (corrected (3.22)).

    Parameters
    ----------
    plant_d, controller_d : control.StateSpace or TransferFunction
        Discrete plant and controller (same dt), or a :class:`SwitchedLoop` as ``plant_d``.
    Q : array_like, optional
        State weight on ``[xp; xc]`` (``(n+m) x (n+m)`` or its diagonal), semidefinite.
    output_weight : array_like, optional
        ``Cz`` with ``Q = Cz^T Cz`` ((3.91): ``loop.Cu`` weighs the control input).

    Returns
    -------
    ndarray, shape (m, n)
    """
    loop = _loop(plant_d, controller_d)
    P = lyapunov_cost(loop, _weight(loop, Q, output_weight))
    n = loop.n
    Pcc, Ppc = P[n:, n:], P[:n, n:]
    K, *_ = np.linalg.lstsq(Pcc, -Ppc.T, rcond=1e-12)
    return K


def jmin_cost(loop: SwitchedLoop, Q: object, xp0: np.ndarray, xc0: np.ndarray) -> float:
    """The cost (3.19) ``x[0]^T P x[0]`` of one initial state (for checks and reports).

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    Q : array_like
        State weight on [xp; xc].
    xp0, xc0 : ndarray
        Plant and controller states at the switch.

    Returns
    -------
    float
        ``J = x[0]^T P x[0]``.
    """
    P = lyapunov_cost(loop, _weight(loop, Q, None))
    x0 = np.concatenate([np.ravel(xp0), np.ravel(xc0)])
    return float(x0 @ P @ x0)


def match_poles(poles: Sequence[complex], eig: np.ndarray, *, rel_tol: float = 0.01) -> list[int]:
    """Indices of the closed-loop eigenvalues nearest to the requested ``poles``.

    One index per conjugate pair (its upper member); a pole farther than ``rel_tol``
    (relative to ``max(1, |pole|)``) from every eigenvalue is refused.

    Parameters
    ----------
    poles : sequence of complex
        Requested poles.
    eig : ndarray
        Closed-loop eigenvalues.
    rel_tol : float
        Largest distance accepted, relative to ``max(1, |pole|)``.

    Returns
    -------
    list of int
        Indices into ``eig``, without repeats.
    """
    chosen: list[int] = []
    for p in np.atleast_1d(np.asarray(poles, dtype=complex)):
        d = np.abs(eig - p)
        i = int(np.argmin(d))
        if d[i] > rel_tol * max(1.0, abs(p)):
            raise ServokitValueError(
                f"pole {p:.6g} is not a closed-loop pole; the poles are "
                + ", ".join(f"{e:.4g}" for e in eig)
            )
        if eig[i].imag < 0:  # use the upper member of a conjugate pair
            i = int(np.argmin(np.abs(eig - np.conj(eig[i]))))
        if i not in chosen:
            chosen.append(i)
    return chosen


def ivc_pole_zero(
    plant_d: object, controller_d: object = None, poles: Sequence[complex] = ()
) -> np.ndarray:
    """Pole-zero IVC gain K (m x n): every ``xp_i[0] -> y`` transfer gets ``poles`` as zeros.

    Parameters
    ----------
    plant_d, controller_d : control.StateSpace or TransferFunction
        Discrete plant and controller (same dt), or a :class:`SwitchedLoop` as ``plant_d``.
    poles : sequence of complex
        Closed-loop poles to cancel (3.34); a complex pole cancels its conjugate too.
        Values are matched to the nearest closed-loop pole (within 1 %).

    Returns
    -------
    ndarray, shape (m, n)
    """
    loop = _loop(plant_d, controller_d)
    eig, wl = left_eig(loop.A)
    idx = match_poles(poles, eig)
    n, m = loop.n, loop.m
    rows_c, rows_p = [], []
    for i in idx:
        w = wl[:, i]  # w^T A = lam w^T
        parts = (np.real, np.imag) if abs(eig[i].imag) > 1e-12 * max(1, abs(eig[i])) else (np.real,)
        for part in parts:
            rows_c.append(part(w[n:]))
            rows_p.append(-part(w[:n]))
    Sigma, Gamma = np.array(rows_c), np.array(rows_p)
    if len(Sigma) > m:
        raise ServokitValueError(
            f"{len(Sigma)} pole conditions (complex poles count twice) exceed the {m} "
            "controller states; cancel fewer poles or use the additional-input IVC"
        )
    if len(Sigma) == 0:
        return np.zeros((m, n))
    K, *_ = np.linalg.lstsq(Sigma, Gamma, rcond=None)
    if np.linalg.norm(Sigma @ K - Gamma) > 1e-8 * max(1.0, np.linalg.norm(Gamma)):
        raise ServokitValueError(
            "the chosen poles cannot be cancelled by the controller state (singular Sigma "
            "of (3.35)); choose other poles"
        )
    return K


def ivc_transfer(loop: SwitchedLoop, K: np.ndarray | None, state: int) -> control.StateSpace:
    """``C (zI - A)^{-1} [I; K] e_state``: the initial-state-to-output transfer (3.27)
    without its factor z (K None: zero reset of the controller).

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    K : ndarray or None
        IVC gain (m x n); None for the zero reset.
    state : int
        Index of the plant state whose initial value drives the output.

    Returns
    -------
    control.StateSpace
        The initial-value-to-output system.
    """
    x0 = loop.stack(np.zeros((loop.m, loop.n)) if K is None else K)[:, [state]]
    return control.ss(loop.A, x0, loop.C, 0, loop.dt)


def ivc_zeros(loop: SwitchedLoop, K: np.ndarray | None, state: int) -> np.ndarray:
    """Zeros of :func:`ivc_transfer` (the book lists them without the zero at z = 0 that
    the factor z of (3.26) adds).

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    K : ndarray or None
        IVC gain (m x n); None for the zero reset.
    state : int
        Index of the plant state.

    Returns
    -------
    ndarray of complex
        The finite zeros.
    """
    x0 = loop.stack(np.zeros((loop.m, loop.n)) if K is None else K)[:, state]
    return siso_zeros(loop.A, x0, loop.C)


@dataclass(frozen=True)
class IvcGains:
    """``xc[0] = Ka xp[0] + Kb r + Kc uw`` (3.100), r a reference vector, uw the input
    applied just before the switch."""

    Ka: np.ndarray
    Kb: np.ndarray
    Kc: np.ndarray

    def state(self, xp0: np.ndarray, r: np.ndarray, uw: float) -> np.ndarray:
        """The controller state to load for one switch."""
        return self.Ka @ np.ravel(xp0) + self.Kb @ np.ravel(r) + self.Kc[:, 0] * float(uw)


def ivc_jmin_jerk(
    loop: SwitchedLoop,
    state_weight: object,
    input_weight: float = 0.0,
    jerk_weight: float = 0.0,
) -> IvcGains:
    """J-min IVC with convergence, input and jerk costs (book §3.4.2, (3.99)-(3.100)).

    With ``z[k] = x[k] - x_ss(r)`` (``z[k+1] = A z[k]``) and ``u[k] - u_ss = Cu z[k]``,

        J = sum z^T Qs z + qu sum (u - u_ss)^2 + qj [(u[0] - uw)^2 + sum_k>=1 (u[k] - u[k-1])^2]
          = z0^T P z0 + qj (Cu z0 + u_ss - uw)^2,

    with ``P`` the Gramian of ``Qs + qu Cu^T Cu + qj (A - I)^T Cu^T Cu (A - I)``. J is
    quadratic in the controller part of ``z0``; its minimiser is affine in ``xp[0]``,
    ``r`` and ``uw``, which gives ``Ka``, ``Kb``, ``Kc``.

    Parameters
    ----------
    loop : SwitchedLoop
        The loop after the switch (its reference path ``B`` sets ``x_ss(r) = (I-A)^-1 B r``).
    state_weight : array_like
        ``Qs`` on ``[xp; xc]`` (matrix or diagonal), semidefinite.
    input_weight, jerk_weight : float
        ``qu`` and ``qj`` >= 0.

    Returns
    -------
    IvcGains
        ``Ka``, ``Kb``, ``Kc`` of (3.100).
    """
    Qs = _weight(loop, state_weight, None)
    n, N = loop.n, loop.n + loop.m
    if input_weight < 0 or jerk_weight < 0:
        raise ServokitValueError("input_weight and jerk_weight must be >= 0")
    _require_schur(loop.A)
    Cu = loop.Cu
    D1 = Cu @ (loop.A - np.eye(N))
    P = weighted_gramian(loop.A, Qs + input_weight * Cu.T @ Cu + jerk_weight * D1.T @ D1)
    H = P[n:, n:] + jerk_weight * Cu[:, n:].T @ Cu[:, n:]
    Gp = P[n:, :n] + jerk_weight * Cu[:, n:].T @ Cu[:, :n]
    g_u = jerk_weight * Cu[:, n:].T  # multiplies (u_ss - uw)
    # z_c = -H^+ (Gp z_p + g_u (u_ss - uw)),  x_ss = S r,  u_ss = (Cu S + Dr) r
    S = np.linalg.solve(np.eye(N) - loop.A, loop.B)
    u_ss = Cu @ S + loop.Dr
    Hi = np.linalg.pinv(H)
    Ka = -Hi @ Gp
    Kb = S[n:] - Ka @ S[:n] - Hi @ g_u @ u_ss
    Kc = Hi @ g_u
    return IvcGains(Ka, Kb, Kc)
