"""The switched loop of book chapter 3: plant, controller and closed loop on [xp; xc].

Conventions (book (3.12)-(3.17)): a discrete plant ``xp[k+1] = Ap xp + Bp u``,
``y = Cp xp`` (strictly proper) and a discrete controller driven by ``r - y``,
``xc[k+1] = Ac xc + Bc (r - y)``, ``u = Cc xc + Dc (r - y)``. The closed loop on
``x = [xp; xc]`` is

    A = [[Ap - Bp Dc Cp, Bp Cc], [-Bc Cp, Ac]],  B = [Bp Dc; Bc],  C = [Cp, 0],

the control input is ``u = Cu x + Dc r`` with ``Cu = [-Dc Cp, Cc]`` ((3.49), (3.87)).
Note: (3.69) prints ``[-Dc Cc, Cc]``; the input gain on the plant state is ``-Dc Cp``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy  # scipy.linalg loads on first use (start-up)

from servokit._lazy import control
from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.models.rational import RationalTF, StateSpaceData

__all__ = [
    "SwitchedLoop",
    "switched_loop",
    "free_response",
    "siso_zeros",
    "left_eig",
    "weighted_gramian",
]


@dataclass(frozen=True)
class SwitchedLoop:
    """Plant, controller and closed-loop matrices of (3.17), all real ndarrays.

    Attributes
    ----------
    Ap, Bp, Cp : ndarray
        Plant (n states, one input, p outputs; p = 1 in the book's HDD loops).
    Ac, Bc, Cc, Dc : ndarray
        Controller (m states), driven by ``r - y``.
    dt : float
        Common sampling period [s].
    Bcr, Dcr : ndarray or None
        Reference path of a two-degree-of-freedom controller (e.g. I-PD):
        ``xc+ = Ac xc + Bcr r - Bc y``, ``u = Cc xc + Dcr r - Dc y``. None (default)
        means the error-driven controller of (3.13). The free closed loop (A, IVC,
        admissible sets) does not depend on it.
    """

    Ap: np.ndarray
    Bp: np.ndarray
    Cp: np.ndarray
    Ac: np.ndarray
    Bc: np.ndarray
    Cc: np.ndarray
    Dc: np.ndarray
    dt: float
    Bcr: np.ndarray | None = None
    Dcr: np.ndarray | None = None

    @property
    def n(self) -> int:
        """Number of plant states."""
        return self.Ap.shape[0]

    @property
    def m(self) -> int:
        """Number of controller states."""
        return self.Ac.shape[0]

    @property
    def A(self) -> np.ndarray:
        """Closed-loop state matrix of (3.17)."""
        top = np.hstack([self.Ap - self.Bp @ self.Dc @ self.Cp, self.Bp @ self.Cc])
        bottom = np.hstack([-self.Bc @ self.Cp, self.Ac])
        return np.vstack([top, bottom])

    @property
    def B(self) -> np.ndarray:
        """Reference input matrix of (3.17) (or of the controller's reference path)."""
        return np.vstack([self.Bp @ self.Dr, self.Bc if self.Bcr is None else self.Bcr])

    @property
    def Dr(self) -> np.ndarray:
        """Feedthrough from r to u (``Dc`` for an error-driven controller)."""
        return self.Dc if self.Dcr is None else self.Dcr

    @property
    def Bu(self) -> np.ndarray:
        """Input matrix of the additional input r' added to u (3.39)."""
        return np.vstack([self.Bp, np.zeros((self.m, 1))])

    @property
    def C(self) -> np.ndarray:
        """Output matrix ``[Cp, 0]``."""
        return np.hstack([self.Cp, np.zeros((self.Cp.shape[0], self.m))])

    @property
    def Cu(self) -> np.ndarray:
        """Control-input matrix ``[-Dc Cp, Cc]`` of (3.49)/(3.87)."""
        return np.hstack([-self.Dc @ self.Cp, self.Cc])

    def stack(self, K: np.ndarray) -> np.ndarray:
        """``[I; K]``: the closed-loop initial state as a function of xp[0] (3.11)."""
        return np.vstack([np.eye(self.n), np.asarray(K, dtype=float).reshape(self.m, self.n)])

    def poles(self) -> np.ndarray:
        """Closed-loop poles (eigenvalues of A)."""
        return np.linalg.eigvals(self.A)


def _as_discrete_ss(name: str, sys: object) -> StateSpaceData:
    """``sys`` as discrete numpy matrices: servokit's own LTI data as they are (a
    :class:`RationalTF` by the companion form python-control's ``ss`` also builds), a
    python-control system converted (python-control is imported only for one)."""
    if isinstance(sys, RationalTF):
        sys = sys.to_state_space()
    elif not isinstance(sys, StateSpaceData):
        if isinstance(sys, control.TransferFunction):
            sys = control.ss(sys)
        if not isinstance(sys, control.StateSpace):
            raise ServokitTypeError(
                f"{name} must be a python-control StateSpace or TransferFunction, or "
                f"servokit's StateSpaceData or RationalTF (got {type(sys).__name__})"
            )
        if sys.dt is None or sys.dt is True:  # continuous, or discrete with no period
            sys = StateSpaceData(sys.A, sys.B, sys.C, sys.D, 0.0)
        else:
            sys = StateSpaceData(sys.A, sys.B, sys.C, sys.D, sys.dt)
    if not sys.dt:
        raise ServokitValueError(f"{name} must be discrete with a numeric dt; discretise it first")
    return sys


def switched_loop(plant_d: object, controller_d: object) -> SwitchedLoop:
    """Build the closed loop of (3.15)-(3.17) from a discrete plant and controller.

    Parameters
    ----------
    plant_d : control.StateSpace, control.TransferFunction, StateSpaceData or RationalTF
        Discrete, strictly proper plant with one input (one or more outputs, e.g. the
        PMR of §3.4.2). Its state coordinates are the xp the IVC
        gain acts on, so pass a state space when the states have a physical meaning.
    controller_d : control.StateSpace, control.TransferFunction, StateSpaceData or RationalTF
        Discrete controller with the same ``dt``, one output, driven by ``r - y``.

    Returns
    -------
    SwitchedLoop
    """
    p = _as_discrete_ss("plant", plant_d)
    c = _as_discrete_ss("controller", controller_d)
    if p.ninputs != 1 or c.noutputs != 1 or c.ninputs != p.noutputs:
        raise ServokitValueError(
            f"the plant must have one input and the controller one output, and the controller "
            f"as many inputs as the plant has outputs (got plant {p.noutputs}x{p.ninputs}, "
            f"controller {c.noutputs}x{c.ninputs})"
        )
    if abs(float(p.dt) - float(c.dt)) > 1e-9 * float(p.dt):
        raise ServokitValueError(
            f"plant dt = {p.dt:g} s and controller dt = {c.dt:g} s differ; use one sampling period"
        )
    if np.any(np.asarray(p.D) != 0):
        raise ServokitValueError("plant must be strictly proper (D = 0) for the loop of (3.17)")
    if c.nstates == 0:
        raise ServokitValueError("controller has no states; IVC needs a dynamic controller")
    mats = [np.array(M, dtype=float) for M in (p.A, p.B, p.C, c.A, c.B, c.C, c.D)]  # writable
    loop = SwitchedLoop(*mats, dt=float(p.dt))
    if not np.all(np.isfinite(loop.A)):
        raise ServokitValueError("plant or controller holds NaN/inf coefficients")
    return loop


def free_response(A: np.ndarray, C: np.ndarray, x0: np.ndarray, n_samples: int) -> np.ndarray:
    """Output ``C A^k x0`` for k = 0..n_samples-1 (columns of x0 give columns of the result).

    Brute-force iteration, used as the independent reference for the closed forms.

    Parameters
    ----------
    A : ndarray, shape (N, N)
        State matrix.
    C : ndarray, shape (q, N)
        Output matrix.
    x0 : ndarray, shape (N,) or (N, c)
        Initial state(s).
    n_samples : int
        Number of samples.

    Returns
    -------
    ndarray
        ``(n_samples, c)`` for one output row, else ``(n_samples, q, c)``.
    """
    x = np.asarray(x0, dtype=float)
    x = x.reshape(-1, 1) if x.ndim == 1 else x
    out = np.empty((n_samples, C.shape[0], x.shape[1]))
    for k in range(n_samples):
        out[k] = C @ x
        x = A @ x
    return out[:, 0, :] if C.shape[0] == 1 else out


def siso_zeros(A: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Finite zeros of ``c (zI - A)^{-1} b``: generalised eigenvalues of the Rosenbrock pencil.

    The state is balanced first (zeros are invariant under diagonal state scaling), which
    keeps the zeros accurate when the states have very different scales (position vs
    velocity in SI), where an unbalanced pencil or the numerator polynomial loses digits.

    Parameters
    ----------
    A : ndarray, shape (N, N)
        State matrix.
    b : ndarray, shape (N,)
        Input vector.
    c : ndarray, shape (N,)
        Output vector.

    Returns
    -------
    ndarray of complex
        The finite zeros.
    """
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    Ab = A * (scale[None, :] / scale[:, None])
    bb = np.ravel(b) / scale
    cb = np.ravel(c) * scale
    bb, cb = bb / max(np.linalg.norm(bb), 1e-300), cb / max(np.linalg.norm(cb), 1e-300)
    N = A.shape[0]
    M = np.block([[Ab, bb[:, None]], [cb[None, :], np.zeros((1, 1))]])
    E = np.zeros((N + 1, N + 1))
    E[:N, :N] = np.eye(N)
    z = scipy.linalg.eigvals(M, E)
    return z[np.isfinite(z) & (np.abs(z) < 1e12)]


def left_eig(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and left eigenvectors (columns w with ``w^T A = lam w^T``) of A.

    Computed on the balanced matrix ``D^{-1} A D`` and mapped back (``w = D^{-1} w_b``), so
    states of very different scales (position, velocity in SI) keep their accuracy.

    Parameters
    ----------
    A : ndarray, shape (N, N)
        Square matrix.

    Returns
    -------
    lam : ndarray, shape (N,)
        Eigenvalues.
    w : ndarray, shape (N, N)
        Left eigenvectors in the columns.
    """
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    Ab = A * (scale[None, :] / scale[:, None])
    lam, wl = scipy.linalg.eig(Ab, left=True, right=False)
    return lam, wl.conj() / scale[:, None]


def weighted_gramian(A: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``P`` with ``A^T P A - P + Q = 0`` (so ``sum_k x_k^T Q x_k = x_0^T P x_0``).

    Solved on the balanced ``D^{-1} A D`` (``P = D^{-1} P_b D^{-1}``) so that states of
    very different scales do not make the Lyapunov solve ill-conditioned.

    Parameters
    ----------
    A : ndarray, shape (N, N)
        Schur-stable state matrix.
    Q : ndarray, shape (N, N)
        Symmetric weight.

    Returns
    -------
    ndarray, shape (N, N)
        Symmetric ``P``.
    """
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    Ab = A * (scale[None, :] / scale[:, None])
    Qb = Q * np.outer(scale, scale)
    Pb = scipy.linalg.solve_discrete_lyapunov(Ab.T, Qb)
    P = Pb / np.outer(scale, scale)
    return 0.5 * (P + P.T)
