"""Nonlinear least squares of a modal model with delay on a measured FRF (private core).

The model is the book's modal plant (eq. 2.73) with the gain folded into each residue,

    G(jw) = exp(-jw T) * [ b_r / (jw)^2 + sum_i b_i / (w_i^2 - w^2 + 2j zeta_i w_i w) ],

fitted to data ``H`` by weighted least squares on the relative error (G - H) / |H|, which
is the maximum-likelihood criterion for complex noise proportional to |H| (the usual
form of an averaged FRF measurement's error).  Parameters are ``log w_i``, ``log zeta_i``
(positive by construction), ``b`` (scaled by the data's level) and ``T``; the Jacobian is
analytic:

    dG/db_i     = E / D_i                     (E = exp(-jw T))
    dG/dw_i     = -E b_i (2 w_i + 2j zeta_i w) / D_i^2
    dG/dzeta_i  = -E b_i (2j w_i w) / D_i^2
    dG/dT       = -jw G
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Layout", "evaluate", "jacobian", "solve", "linear_residues"]


@dataclass(frozen=True)
class Layout:
    """Which parameters a model has: rigid body, flexible modes, fitted delay.

    ``theta = [log w (n), log zeta (n), b (rigid + n), T (if fit_delay)]``; a fixed delay
    is ``delay``.
    """

    n_modes: int
    rigid: bool
    fit_delay: bool
    delay: float = 0.0

    @property
    def n_b(self) -> int:
        """Number of residues (rigid body first)."""
        return self.n_modes + int(self.rigid)

    def split(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        """``(w [rad/s], zeta, b, T)`` of a parameter vector."""
        n = self.n_modes
        w = np.exp(theta[:n])
        z = np.exp(theta[n : 2 * n])
        b = theta[2 * n : 2 * n + self.n_b]
        T = float(theta[-1]) if self.fit_delay else self.delay
        return w, z, b, T

    def join(self, w: np.ndarray, z: np.ndarray, b: np.ndarray, T: float) -> np.ndarray:
        """The parameter vector of ``(w, zeta, b, T)`` (inverse of :meth:`split`)."""
        parts = [np.log(w), np.log(z), np.asarray(b, dtype=float)]
        if self.fit_delay:
            parts.append([T])
        return np.concatenate(parts)


def _basis(layout: Layout, omega: np.ndarray, w: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Columns 1/(jw)^2 (rigid) and 1/D_i, shape (m, n_b), no delay."""
    s = 1j * omega[:, None]
    cols = []
    if layout.rigid:
        cols.append(1.0 / s**2)
    if layout.n_modes:
        cols.append(1.0 / (w**2 + 2.0 * z * w * s + s**2))
    return np.hstack(cols) if cols else np.zeros((omega.size, 0), complex)


def evaluate(layout: Layout, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Model response G(jw) at ``omega`` [rad/s].

    Parameters
    ----------
    layout : Layout
        Model structure.
    theta : numpy.ndarray
        Parameter vector.
    omega : numpy.ndarray
        Frequencies [rad/s].

    Returns
    -------
    numpy.ndarray
        Complex response.
    """
    w, z, b, T = layout.split(theta)
    return np.exp(-1j * omega * T) * (_basis(layout, omega, w, z) @ b)


def jacobian(layout: Layout, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Complex Jacobian dG/dtheta, shape (m, len(theta)) (formulas in the module docstring).

    Parameters
    ----------
    layout : Layout
        Model structure.
    theta : numpy.ndarray
        Parameter vector.
    omega : numpy.ndarray
        Frequencies [rad/s].

    Returns
    -------
    numpy.ndarray
        Complex derivatives, one column per parameter.
    """
    w, z, b, T = layout.split(theta)
    E = np.exp(-1j * omega * T)[:, None]
    basis = _basis(layout, omega, w, z)
    s = 1j * omega[:, None]
    bm = b[int(layout.rigid) :]
    inv2 = basis[:, int(layout.rigid) :] ** 2  # 1 / D_i^2
    d_logw = -E * bm * (2.0 * w + 2.0 * z * s) * inv2 * w  # chain rule d/dlog w = w d/dw
    d_logz = -E * bm * (2.0 * w * s) * inv2 * z
    cols = [d_logw, d_logz, E * basis]
    if layout.fit_delay:
        cols.append(-s * E * (basis @ b)[:, None])
    return np.hstack(cols)


def linear_residues(
    layout: Layout, w: np.ndarray, z: np.ndarray, T: float, omega: np.ndarray, H: np.ndarray
) -> np.ndarray:
    """Best real residues for fixed poles and delay (weighted linear least squares).

    Parameters
    ----------
    layout : Layout
        Model structure.
    w, z : numpy.ndarray
        Mode frequencies [rad/s] and damping ratios.
    T : float
        Delay [s].
    omega : numpy.ndarray
        Frequencies [rad/s].
    H : numpy.ndarray
        Data.

    Returns
    -------
    numpy.ndarray
        Residues ``b`` (rigid body first).
    """
    A = np.exp(-1j * omega * T)[:, None] * _basis(layout, omega, w, z) / np.abs(H)[:, None]
    rhs = H / np.abs(H)
    A2 = np.vstack([A.real, A.imag])
    scale = np.linalg.norm(A2, axis=0)
    scale[scale == 0] = 1.0
    sol = np.linalg.lstsq(A2 / scale, np.concatenate([rhs.real, rhs.imag]), rcond=None)[0]
    return sol / scale


def solve(
    layout: Layout,
    theta0: np.ndarray,
    omega: np.ndarray,
    H: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Minimise the relative error over ``theta`` (trust-region reflective, bounded).

    Parameters
    ----------
    layout : Layout
        Model structure.
    theta0 : numpy.ndarray
        Start.
    omega : numpy.ndarray
        Frequencies [rad/s].
    H : numpy.ndarray
        Data (no zero entries).
    bounds : (numpy.ndarray, numpy.ndarray)
        Lower and upper bounds of ``theta``.

    Returns
    -------
    theta : numpy.ndarray
        Optimum.
    residual : numpy.ndarray
        Relative complex error (G - H)/|H| at the optimum.
    jac : numpy.ndarray
        Real Jacobian of the stacked (real, imaginary) weighted residual at the optimum.
    """
    from scipy.optimize import least_squares

    wgt = 1.0 / np.abs(H)

    def fun(theta: np.ndarray) -> np.ndarray:
        r = (evaluate(layout, theta, omega) - H) * wgt
        return np.concatenate([r.real, r.imag])

    def jac(theta: np.ndarray) -> np.ndarray:
        J = jacobian(layout, theta, omega) * wgt[:, None]
        return np.vstack([J.real, J.imag])

    theta0 = np.clip(theta0, bounds[0] + 1e-12, bounds[1] - 1e-12)
    sol = least_squares(
        fun,
        theta0,
        jac=jac,
        bounds=bounds,
        x_scale="jac",
        method="trf",
        xtol=1e-12,
        ftol=1e-12,
        gtol=1e-12,
        max_nfev=200,
    )
    r = sol.fun[: omega.size] + 1j * sol.fun[omega.size :]
    return sol.x, r, sol.jac
