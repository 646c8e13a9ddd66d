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

from servokit._lazy import scipy_sparse as sp
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
    floor_idx: np.ndarray | None = None  # frequency indices of the low-frequency gain floor
    floor_w: np.ndarray | None = None  # (M, len(floor_idx)) floor of |L| there


def _scaled(A: sp.spmatrix, b: np.ndarray, group: int = 1) -> tuple[sp.csr_matrix, np.ndarray]:
    """Scale rows (in groups of ``group`` rows, one cone each) by their largest entry."""
    A = sp.csr_matrix(A)
    mag = np.maximum(abs(A).max(axis=1).toarray().ravel(), np.abs(b))
    mag = np.maximum(mag.reshape(-1, group).max(axis=1), 1e-300)
    inv = np.repeat(1.0 / mag, group)
    return sp.diags(inv) @ A, b * inv


class _Rows:
    """Accumulates clarabel rows ``s = b - A z`` for z = [θ, τ, r]: linear ones and 3-D cones.

    ``r_j ≥ |Y(ω_j)|`` (one cone per active frequency) is shared by every plant, so the
    sensitivity and crossover constraints of all plants at ``ω_j`` are linear rows in r_j.
    With a fixed denominator ``Y = y / y_k = 1`` and there is no r at all.
    """

    def __init__(self, n_theta: int, n_r: int) -> None:
        self.nt, self.nr = n_theta, n_r
        self.lin: list[tuple[sp.csr_matrix, np.ndarray]] = []
        self.soc: list[tuple[sp.csr_matrix, np.ndarray]] = []

    @property
    def nz(self) -> int:
        return self.nt + 1 + self.nr

    def linear(self, t0, tth, ttau: float, rcoef, ridx) -> None:
        """Rows ``t0 + tth θ + ttau τ - rcoef r[ridx] ≥ 0`` (ridx None: no r)."""
        k = t0.size
        dense = np.hstack([tth, np.full((k, 1), ttau)])
        A = sp.hstack([sp.csr_matrix(-dense), sp.csr_matrix((k, self.nr))], format="lil")
        if ridx is not None:
            A = sp.csr_matrix(A)
            A = A + sp.csr_matrix(
                (np.broadcast_to(rcoef, (k,)), (np.arange(k), self.nt + 1 + ridx)),
                shape=(k, self.nz),
            )
        self.lin.append(_scaled(A, t0))

    def cone(self, t0, tz, q0, qz) -> None:
        """Cones ``t0 + tz z ≥ |q0 + qz z|`` (``tz``, ``qz`` over the full z)."""
        k = t0.size
        A = np.empty((3 * k, self.nz))
        b = np.empty(3 * k)
        A[0::3], b[0::3] = -tz, t0
        A[1::3], b[1::3] = -qz.real, q0.real
        A[2::3], b[2::3] = -qz.imag, q0.imag
        self.soc.append(_scaled(sp.csr_matrix(A), b, group=3))

    def full(self, gth: np.ndarray, gtau: float = 0.0) -> np.ndarray:
        """A θ-gradient widened to all of z."""
        k = gth.shape[0]
        return np.hstack([gth, np.full((k, 1), gtau), np.zeros((k, self.nr))])


def _affine(basis: Basis, P: np.ndarray, idx: tuple[np.ndarray, np.ndarray], F: np.ndarray):
    """``Y + P X`` (constant, θ-gradient) and ``P X`` (θ-gradient) at points ``idx``."""
    i, j = idx
    f = F[j][:, None]
    g_x = P[i, j][:, None] * basis.Vx[j] / f
    g_y = basis.Vy[j] / f
    return basis.Y0[j] / F[j], np.hstack([g_x, g_y]), np.hstack([g_x, np.zeros_like(g_y)])


def _tangent(u: np.ndarray, g0: np.ndarray, gz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``Re{ū v}/|u|`` for ``v = g0 + gz θ``: (constant, gradient)."""
    uh = np.conj(u) / np.abs(u)
    return (uh * g0).real, (uh[:, None] * gz).real


def _build(d: StepData, rows: _Rows, F: np.ndarray, K: np.ndarray, r_of: np.ndarray | None):
    """Sensitivity, objective, complementary-sensitivity and crossover rows of the step."""
    c = 1.0 + d.P * K[None, :]
    idx = np.nonzero(d.s_mask)
    ridx = None if r_of is None else r_of[idx[1]]
    y_abs = np.abs(d.basis.Y0[idx[1]] / F[idx[1]])  # |Y| when the denominator is fixed
    g0, gz, gx = _affine(d.basis, d.P, idx, F)
    l0, lz = _tangent(c[idx], g0, gz)

    def lin(t0, tth, ttau, w, r_index, yabs):
        if r_index is None:
            rows.linear(t0 - w * yabs, tth, ttau, 0.0, None)
        else:
            rows.linear(t0, tth, ttau, w, r_index)

    lin(l0, lz, 0.0, d.w_s, ridx, y_abs)
    if d.w_obj_s is not None:
        lin(l0, lz, -1.0, d.w_obj_s, ridx, y_abs)
    if d.w_t is not None:
        rows.cone(l0, rows.full(lz), np.zeros(l0.size, dtype=complex), rows.full(d.w_t * gx))
    if d.floor_idx is not None:  # |P X| >= w_floor |Y|: no loss of low-frequency gain
        m = d.P.shape[0]
        idx = (np.repeat(np.arange(m), d.floor_idx.size), np.tile(d.floor_idx, m))
        _, _, gx = _affine(d.basis, d.P, idx, F)
        m0, mz = _tangent(d.P[idx] * K[idx[1]], np.zeros(len(idx[0]), dtype=complex), gx)
        y_abs = np.abs(d.basis.Y0[idx[1]] / F[idx[1]])
        lin(m0, mz, 0.0, d.floor_w.ravel(), None if r_of is None else r_of[idx[1]], y_abs)
    if d.c_mask is not None and d.c_mask.any():
        idx = np.nonzero(d.c_mask)
        _, _, gx = _affine(d.basis, d.P, idx, F)
        m0, mz = _tangent(d.P[idx] * K[idx[1]], np.zeros(len(idx[0]), dtype=complex), gx)
        y_abs = np.abs(d.basis.Y0[idx[1]] / F[idx[1]])
        lin(m0, mz, -1.0, 1.0, None if r_of is None else r_of[idx[1]], y_abs)


def _r_cones(d: StepData, rows: _Rows, F: np.ndarray, freqs: np.ndarray) -> None:
    """``r_j ≥ |Y(ω_j)|`` at the active frequencies."""
    na = d.basis.Vx.shape[1]
    k = freqs.size
    tz = np.zeros((k, rows.nz))
    tz[np.arange(k), rows.nt + 1 + np.arange(k)] = 1.0
    qth = np.hstack([np.zeros((k, na)), d.basis.Vy[freqs] / F[freqs][:, None]])
    rows.cone(np.zeros(k), tz, d.basis.Y0[freqs] / F[freqs], rows.full(qth))


def _trust(d: StepData, rows: _Rows, F: np.ndarray, K: np.ndarray) -> None:
    """``|X - K_k Y| ≤ ρ |K_k|`` on the trust-region frequencies."""
    j = d.tr_idx
    scale = (F[j] * K[j])[:, None]
    qth = np.hstack([d.basis.Vx[j], -K[j][:, None] * d.basis.Vy[j]]) / scale
    q0 = -K[j] * d.basis.Y0[j] / scale[:, 0]
    rows.cone(np.full(j.size, d.rho), np.zeros((j.size, rows.nz)), q0, rows.full(qth))


def _signs(d: StepData, rows: _Rows) -> None:
    """Integral-action sign ``σ x(1) ≥ 0.1 |x_k(1)|`` and ``τ ≤ 10`` (keeps it bounded)."""
    na = d.basis.Vx.shape[1]
    x1 = float(np.sum(d.theta_k[:na]))
    sigma = np.sign(x1) or 1.0
    tth = np.zeros((2, rows.nt))
    tth[0, :na] = sigma
    rows.linear(np.array([-0.1 * abs(x1), 10.0]), tth, 0.0, 0.0, None)
    rows.lin[-1] = (rows.lin[-1][0].tolil(), rows.lin[-1][1])
    A, b = rows.lin[-1]
    A[1, rows.nt] = 1.0  # 10 - τ ≥ 0
    rows.lin[-1] = (sp.csr_matrix(A), b)


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

    xk, F = d.basis.polys(d.theta_k)
    K = xk / F
    free = d.basis.Vy.shape[1] > 0
    active = d.s_mask.any(axis=0) | (d.c_mask.any(axis=0) if d.c_mask is not None else False)
    if d.floor_idx is not None:
        active[d.floor_idx] = True
    freqs = np.nonzero(active)[0] if free else np.empty(0, dtype=int)
    r_of = None
    if free:
        r_of = np.full(F.size, -1)
        r_of[freqs] = np.arange(freqs.size)
    rows = _Rows(d.theta_k.size, freqs.size)
    _signs(d, rows)
    _build(d, rows, F, K, r_of)
    if free:
        _r_cones(d, rows, F, freqs)
    _trust(d, rows, F, K)
    A = sp.vstack([a for a, _ in rows.lin + rows.soc], format="csc")
    b = np.concatenate([bb for _, bb in rows.lin + rows.soc])
    n_lin = sum(bb.size for _, bb in rows.lin)
    n_soc = sum(bb.size // 3 for _, bb in rows.soc)
    cones = [clarabel.NonnegativeConeT(n_lin)] + [clarabel.SecondOrderConeT(3)] * n_soc
    q = np.zeros(rows.nz)
    q[rows.nt] = -1.0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    # each accepted step is re-checked exactly, so a 1e-6 optimum is plenty
    settings.tol_gap_abs = settings.tol_gap_rel = 1e-6
    settings.tol_feas = 1e-7
    solver = clarabel.DefaultSolver(sp.csc_matrix((rows.nz, rows.nz)), q, A, b, cones, settings)
    sol = solver.solve()
    if str(sol.status) not in ("Solved", "AlmostSolved"):
        return None
    z = np.asarray(sol.x)
    if not np.all(np.isfinite(z)):
        raise ServokitValueError("loop-shaping step returned non-finite parameters")
    return z[: rows.nt], float(z[rows.nt])
