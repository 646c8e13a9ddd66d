"""One convex step of the FRF loop-shaping iteration: the second-order cone program.

With the previous controller ``K_k = x_k / y_k`` and the normalisation ``F = y_k``
(Karimi and Kammer 2017), ``X = x / F`` and ``Y = y / F`` are affine in the parameters
``θ`` and ``Y_k = 1``, ``X_k = K_k``. For each plant FRF ``P`` and frequency ``ω`` of the
active set, with ``c = 1 + P K_k``:

* sensitivity ``|W_S S| ≤ 1  ⇔  |W_S Y| ≤ |Y + P X|``; the right side is replaced by its
  tangent lower bound ``Re{c̄ (Y + P X)} / |c|`` (``|v| ≥ Re{ū v}/|u|``), a convex inner
  approximation that is exact at ``θ_k``;
* lowest crossover at least ``f_t``: ``|P X| ≥ |Y| + τ`` at every ``ω ≤ 2π f_t`` with the
  tangent bound ``Re{(P X_k)^* P X}/|P X_k|`` on the left, ``τ`` maximised;
* complementary sensitivity ``|W_T P X| ≤ Re{c̄ (Y + P X)}/|c|`` (optional);
* a trust region ``|X - K_k Y| ≤ ρ |K_k|`` on a frequency subsample, keeping the tangent
  bounds meaningful;
* the integral-action sign ``x(1) x_k(1) > 0``.

Each is one three-dimensional second-order cone ``t ≥ ‖(Re q, Im q)‖`` (rows scaled per
point), solved by Clarabel (Goulart and Chen 2024) through its Python API.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from servokit.errors import ServokitValueError

__all__ = ["Basis", "StepData", "solve_step"]


@dataclass(frozen=True)
class Basis:
    """Controller polynomials on the grid: ``x = Vx a``, ``y = Y0 + Vy b``."""

    Vx: np.ndarray  # (n, n_num + 1)
    Vy: np.ndarray  # (n, n_den_free)
    Y0: np.ndarray  # (n,)

    @classmethod
    def build(cls, zinv: np.ndarray, den_fixed: np.ndarray, n_num: int, n_free: int) -> Basis:
        """Evaluate the monomials ``z^{-m}`` and the fixed denominator on ``zinv``.

        Parameters
        ----------
        zinv : ndarray
            ``e^{-jωT}`` on the grid.
        den_fixed : ndarray
            Fixed monic denominator factor (powers of ``z^{-1}``).
        n_num : int
            Numerator degree.
        n_free : int
            Free denominator coefficients.

        Returns
        -------
        Basis
            The evaluated basis.
        """
        d = np.polyval(den_fixed[::-1], zinv)
        Vx = zinv[:, None] ** np.arange(n_num + 1)[None, :]
        Vy = d[:, None] * zinv[:, None] ** np.arange(1, n_free + 1)[None, :]
        return cls(Vx, Vy, d)

    def polys(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``x`` and ``y`` on the grid for parameters ``θ = [a, b]``.

        Parameters
        ----------
        theta : ndarray
            Parameters.

        Returns
        -------
        tuple of ndarray
            ``x(e^{jωT})`` and ``y(e^{jωT})``.
        """
        na = self.Vx.shape[1]
        return self.Vx @ theta[:na], self.Y0 + self.Vy @ theta[na:]


@dataclass
class StepData:
    """Everything one convex step needs (masks select the active plant-frequency points)."""

    basis: Basis
    P: np.ndarray  # (M, n) plant FRFs
    theta_k: np.ndarray
    w_s: float  # 1 / s_max (hard)
    s_mask: np.ndarray  # (M, n) bool
    c_mask: np.ndarray | None  # (M, n) bool: crossover points, or None
    w_obj_s: float | None  # phase 1: maximise the modulus margin beyond 1 / s_target
    w_t: float | None
    tr_idx: np.ndarray  # frequency indices of the trust region
    rho: float


def _soc_rows(t0, tz, q0, qz):
    """Cones ``t0 + tz z ≥ |q0 + qz z|`` as clarabel rows ``b - A z``, scaled per point.

    Returns ``(A, b, linear)``: where ``q`` does not depend on ``z`` (fixed denominator) the
    cone is the linear inequality ``t0 - |q0| + tz z ≥ 0`` (one row, ``linear`` True).
    """
    if not np.any(qz):
        t0 = t0 - np.abs(q0)
        scale = np.maximum(np.abs(tz).max(axis=1), np.abs(t0)) + 1e-300
        return -tz / scale[:, None], t0 / scale, True
    scale = np.maximum(np.abs(tz).max(axis=1), np.abs(qz).max(axis=1)) + 1e-300
    scale = np.maximum(scale, np.abs(t0))
    k, nz = tz.shape
    A = np.empty((3 * k, nz))
    b = np.empty(3 * k)
    A[0::3], b[0::3] = -tz / scale[:, None], t0 / scale
    A[1::3], b[1::3] = -qz.real / scale[:, None], q0.real / scale
    A[2::3], b[2::3] = -qz.imag / scale[:, None], q0.imag / scale
    return A, b, False


def _affine(basis: Basis, P: np.ndarray, idx: tuple[np.ndarray, np.ndarray], F: np.ndarray):
    """``Y + P X`` and ``Y`` at points ``idx`` as (constant, gradient in θ) pairs."""
    i, j = idx
    f = F[j][:, None]
    g_x = P[i, j][:, None] * basis.Vx[j] / f
    g_y = basis.Vy[j] / f
    y0 = basis.Y0[j] / F[j]
    return y0, np.hstack([g_x, g_y]), y0, np.hstack([np.zeros_like(g_x), g_y]), g_x


def _tangent(u: np.ndarray, g0: np.ndarray, gz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Re{ū v}/|u|`` for ``v = g0 + gz θ``: (constant, gradient)."""
    uh = np.conj(u) / np.abs(u)
    return (uh * g0).real, (uh[:, None] * gz).real


def _pad(gz: np.ndarray, tau: float = 0.0) -> np.ndarray:
    return np.hstack([gz, np.full((gz.shape[0], 1), tau)])


def _blocks(d: StepData, F: np.ndarray, c: np.ndarray, pxk: np.ndarray):
    """All cone blocks of the step as lists of (A, b)."""
    out = []
    idx = np.nonzero(d.s_mask)
    g0, gz, y0, yz, gx = _affine(d.basis, d.P, idx, F)
    l0, lz = _tangent(c[idx], g0, gz)
    out.append(_soc_rows(l0, _pad(lz), d.w_s * y0, _pad(d.w_s * yz)))
    if d.w_obj_s is not None:
        out.append(_soc_rows(l0, _pad(lz, -1.0), d.w_obj_s * y0, _pad(d.w_obj_s * yz)))
    if d.w_t is not None:
        qx = np.hstack([gx, np.zeros((gx.shape[0], d.basis.Vy.shape[1]))])
        out.append(_soc_rows(l0, _pad(lz), np.zeros_like(y0), _pad(d.w_t * qx)))
    if d.c_mask is not None and d.c_mask.any():
        idx = np.nonzero(d.c_mask)
        _, _, y0, yz, gx = _affine(d.basis, d.P, idx, F)
        qx = np.hstack([gx, np.zeros((gx.shape[0], d.basis.Vy.shape[1]))])
        m0, mz = _tangent(pxk[idx], np.zeros(len(idx[0]), dtype=complex), qx)
        out.append(_soc_rows(m0, _pad(mz, -1.0), y0, _pad(yz)))
    return out


def _trust_rows(d: StepData, F: np.ndarray, K: np.ndarray):
    j = d.tr_idx
    scale = (F[j] * K[j])[:, None]
    na = d.basis.Vx.shape[1]
    qz = np.hstack([d.basis.Vx[j], -K[j][:, None] * d.basis.Vy[j]]) / scale
    q0 = -K[j] * d.basis.Y0[j] / scale[:, 0]
    del na
    return _soc_rows(np.full(len(j), d.rho), _pad(np.zeros((len(j), qz.shape[1]))), q0, _pad(qz))


def solve_step(d: StepData) -> tuple[np.ndarray, float] | None:
    """Solve one convex step; ``None`` if Clarabel does not reach an optimum.

    Parameters
    ----------
    d : StepData
        Linearisation point, active sets, bounds and trust radius.

    Returns
    -------
    tuple of (ndarray, float) or None
        New parameters ``θ`` and the optimal ``τ``.
    """
    import clarabel

    xk, yk = d.basis.polys(d.theta_k)
    F = yk
    K = xk / yk
    c = 1.0 + d.P * K[None, :]
    pxk = d.P * K[None, :]
    blocks = _blocks(d, F, c, pxk) + [_trust_rows(d, F, K)]
    nz = d.theta_k.size + 1
    # integral-action sign and an upper bound on τ (keeps the problem bounded)
    na = d.basis.Vx.shape[1]
    sigma = np.sign(np.sum(d.theta_k[:na])) or 1.0
    lin_A = np.zeros((2, nz))
    lin_A[0, :na] = -sigma
    lin_A[1, -1] = 1.0
    lin_b = np.array([-0.1 * abs(np.sum(d.theta_k[:na])), 10.0])
    lin = [(lin_A, lin_b)] + [(a, bb) for a, bb, is_lin in blocks if is_lin]
    soc = [(a, bb) for a, bb, is_lin in blocks if not is_lin]
    A = sp.csc_matrix(np.vstack([a for a, _ in lin + soc]))
    b = np.concatenate([bb for _, bb in lin + soc])
    n_lin = sum(bb.size for _, bb in lin)
    n_soc = sum(bb.size // 3 for _, bb in soc)
    cones = [clarabel.NonnegativeConeT(n_lin)] + [clarabel.SecondOrderConeT(3)] * n_soc
    q = np.zeros(nz)
    q[-1] = -1.0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    solver = clarabel.DefaultSolver(sp.csc_matrix((nz, nz)), q, A, b, cones, settings)
    sol = solver.solve()
    if str(sol.status) not in ("Solved", "AlmostSolved"):
        return None
    z = np.asarray(sol.x)
    if not np.all(np.isfinite(z)):
        raise ServokitValueError("loop-shaping step returned non-finite parameters")
    return z[:-1], float(z[-1])
