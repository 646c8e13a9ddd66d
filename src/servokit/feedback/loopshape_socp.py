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
* the integral-action sign ``x(1) x_k(1) > 0`` and ``τ ≤ 1`` (the code wrote ``τ ≤ 10``
  before the row scaling, which made it ``τ ≤ 1``; kept as it acts: the HDD design's
  steps have ``τ ≤ 0.1``; a step whose ``τ`` reaches 1 has no unique optimum).

Each is one three-dimensional second-order cone ``t ≥ ‖(Re q, Im q)‖`` (rows scaled per
point), solved by Clarabel (Goulart and Chen 2024) through its Python API.

Constraint generation (issue 24). The masks of a step hold 10^4-4·10^4 linear rows, of
which a few hundred bind (the valleys of ``1/|S|``, of the low-frequency floor and of
``|L|`` below the target, per plant). :func:`solve_step` starts from the rows at the
valleys of their slack at ``θ_k`` and the rows ``θ_k`` violates, solves, evaluates every
row of the masks at the new ``θ`` (with ``r_j = |Y(ω_j)|``, its least feasible value),
adds the valleys of the violated ones with three grid neighbours each side, and repeats
until every row holds to ``GEN_TOL``. The program of the selected rows is a relaxation
of the program of all rows and its optimum satisfies them all, so it is an optimum of
that program (the same ``τ``; ``θ`` itself is unique only where enough rows bind, an
interior-point method returns the analytic centre of the optimal set). On the 54-loop
HDD design a step takes 3-7 programs of 300-2300 rows instead of one of 13k-43k rows.
A :class:`WarmStart` carried from step to step adds the rows within ``WARM_SLACK`` of
binding at the previous step's optimum to the first program (32 programs instead of 61
on the HDD design); the valleys at ``θ_k`` join it only for rows the previous step did
not have (a re-solve of the same step with a grown mask; none for a new step), and
``WARM_SLACK`` is 1e-5 (was 1e-3): 35 smaller programs. The 150 trust-region cones are
in every program (85-128 bind at the HDD optima: generating them saved no time).
The generated programs are solved to 1e-8 / 1e-9 (1e-6 / 1e-7 where Clarabel stalls),
first without Clarabel's iterative refinement, whose ``z`` is taken only where every row
and cone of the program holds to ``PROGRAM_FEAS`` (checked here). Clarabel's CPU on the
HDD design: 0.8 s instead of 2.3 s (docs/guide/loopshape_cpu.md). A program that is not
"Solved" sends the step back to the one program of every row at 1e-6 / 1e-7, as before
(``solve_step(..., generate=False)``: the earlier matrices, bit for bit, checked on the
12 programs of the HDD design); where Clarabel stalls on that one too (``RESCUE``), its
point is offered to the iteration's exact acceptance test if every row holds to
``RESCUE_FEAS`` (orders 6 and 8 on the stage example: every first step stalled).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from servokit._lazy import scipy_sparse as sp
from servokit.errors import ServokitValueError

__all__ = ["Basis", "StepData", "WarmStart", "solve_step"]


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


@dataclass
class _Lin:
    """Linear rows ``b + G θ + g_τ τ - w r_j ≥ 0`` at frequency index ``j``.

    ``r_j ≥ |Y(ω_j)|`` is a variable only when the denominator is free; with ``Y = 1`` the
    term ``w |Y_j|`` is folded into ``b`` and ``w`` is zero. ``pt`` numbers the
    plant-frequency point a row belongs to: the rows of one point enter the program together.
    """

    b: np.ndarray
    G: np.ndarray
    gtau: np.ndarray
    w: np.ndarray
    j: np.ndarray
    pt: np.ndarray
    seg: np.ndarray

    @classmethod
    def cat(cls, parts: list[_Lin]) -> _Lin:
        """Rows of ``parts`` one after the other."""
        return cls(*(np.concatenate([getattr(p, k) for p in parts]) for k in _FIELDS_LIN))

    def take(self, rows: np.ndarray) -> _Lin:
        """The rows ``rows`` (indices or mask)."""
        return _Lin(*(getattr(self, k)[rows] for k in _FIELDS_LIN))

    def scale(self) -> np.ndarray:
        """Largest entry of each row (the program divides each row by it)."""
        parts = [np.abs(self.G).max(axis=1, initial=0.0), np.abs(self.gtau), np.abs(self.w)]
        return np.maximum(np.maximum.reduce(parts + [np.abs(self.b)]), 1e-300)


@dataclass
class _Soc:
    """3-D cones ``t0 + t_G θ (+ r_j) ≥ |q0 + q_G θ|`` (``r_j`` where ``j ≥ 0``)."""

    t0: np.ndarray
    tG: np.ndarray
    q0: np.ndarray
    qG: np.ndarray
    j: np.ndarray
    pt: np.ndarray

    def take(self, rows: np.ndarray) -> _Soc:
        """The cones ``rows`` (indices or mask)."""
        return _Soc(*(getattr(self, k)[rows] for k in _FIELDS_SOC))

    def scale(self) -> np.ndarray:
        """Largest entry of each cone's three rows (cones without ``r``)."""
        parts = [np.abs(m).max(axis=1, initial=0.0) for m in (self.tG, self.qG.real, self.qG.imag)]
        parts += [np.abs(self.t0), np.abs(self.q0.real), np.abs(self.q0.imag)]
        return np.maximum(np.maximum.reduce(parts), 1e-300)


_FIELDS_LIN = ("b", "G", "gtau", "w", "j", "pt", "seg")
_FIELDS_SOC = ("t0", "tG", "q0", "qG", "j", "pt")


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


def _lin(t0, G, gtau: float, w, idx, pt: np.ndarray, seg0: int, d: StepData, F, free) -> _Lin:
    """Rows ``t0 + G θ + gtau τ ≥ w |Y_j|`` (``|Y_j|`` a variable when ``free``)."""
    k, j = t0.size, idx[1]
    w = np.broadcast_to(np.asarray(w, dtype=float), (k,))
    seg = seg0 + idx[0]
    if free:
        return _Lin(t0, G, np.full(k, gtau), w.copy(), j, pt, seg)
    y_abs = np.abs(d.basis.Y0[j] / F[j])  # |Y| when the denominator is fixed
    return _Lin(t0 - w * y_abs, G, np.full(k, gtau), np.zeros(k), j, pt, seg)


def _loop_gain_rows(d: StepData, F, K, idx, gtau: float, w, pt0: int, seg0: int, free: bool):
    """``|P X| ≥ w |Y| - gtau τ`` at points ``idx`` (tangent bound on ``|P X|``)."""
    _, _, gx = _affine(d.basis, d.P, idx, F)
    m0, mz = _tangent(d.P[idx] * K[idx[1]], np.zeros(len(idx[0]), dtype=complex), gx)
    return _lin(m0, mz, gtau, w, idx, pt0 + np.arange(m0.size), seg0, d, F, free)


def _candidates(d: StepData, F: np.ndarray, K: np.ndarray) -> tuple[_Lin, _Soc | None]:
    """Every linear row of the step's masks and the ``‖T‖∞`` cones (same order as the program).

    Sensitivity (and phase-1 objective, ``‖T‖∞``) rows at ``s_mask``, the low-frequency
    floor ``|P X| ≥ w_floor |Y|``, the crossover rows ``|P X| ≥ |Y| + τ`` at ``c_mask``.
    """
    free = d.basis.Vy.shape[1] > 0
    c = 1.0 + d.P * K[None, :]
    idx = np.nonzero(d.s_mask)
    n_s = idx[0].size
    pt = np.arange(n_s)
    g0, gz, gx = _affine(d.basis, d.P, idx, F)
    l0, lz = _tangent(c[idx], g0, gz)
    m = d.P.shape[0]
    parts = [_lin(l0, lz, 0.0, d.w_s, idx, pt, 0, d, F, free)]
    if d.w_obj_s is not None:
        parts.append(_lin(l0, lz, -1.0, d.w_obj_s, idx, pt, m, d, F, free))
    t_cones = None
    if d.w_t is not None:
        none = np.full(n_s, -1)
        t_cones = _Soc(l0, lz, np.zeros(n_s, dtype=complex), d.w_t * gx, none, pt)
    n_pt = n_s
    if d.floor_idx is not None:  # |P X| >= w_floor |Y|: no loss of low-frequency gain
        fidx = (np.repeat(np.arange(m), d.floor_idx.size), np.tile(d.floor_idx, m))
        parts.append(_loop_gain_rows(d, F, K, fidx, 0.0, d.floor_w.ravel(), n_pt, 2 * m, free))
        n_pt += fidx[0].size
    if d.c_mask is not None and d.c_mask.any():
        cidx = np.nonzero(d.c_mask)
        parts.append(_loop_gain_rows(d, F, K, cidx, -1.0, 1.0, n_pt, 3 * m, free))
    return _Lin.cat(parts), t_cones


def _r_cones(d: StepData, F: np.ndarray, freqs: np.ndarray) -> _Soc:
    """``r_j ≥ |Y(ω_j)|`` at the frequencies ``freqs``."""
    k, na = freqs.size, d.basis.Vx.shape[1]
    qth = np.hstack([np.zeros((k, na)), d.basis.Vy[freqs] / F[freqs][:, None]])
    zero = np.zeros((k, qth.shape[1]))
    return _Soc(np.zeros(k), zero, d.basis.Y0[freqs] / F[freqs], qth, freqs, np.full(k, -1))


def _trust(d: StepData, F: np.ndarray, K: np.ndarray) -> _Soc:
    """``|X - K_k Y| ≤ ρ |K_k|`` on the trust-region frequencies."""
    j = d.tr_idx
    scale = (F[j] * K[j])[:, None]
    qth = np.hstack([d.basis.Vx[j], -K[j][:, None] * d.basis.Vy[j]]) / scale
    q0 = -K[j] * d.basis.Y0[j] / scale[:, 0]
    none = np.full(j.size, -1)
    return _Soc(np.full(j.size, d.rho), np.zeros_like(qth, dtype=float), q0, qth, none, none)


def _triplets(M: np.ndarray, row0: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nonzero entries of a dense block as (row, column, value), rows offset by ``row0``."""
    r, c = np.nonzero(M)
    return r + row0, c, M[r, c]


class _Program:
    """Clarabel data ``s = b - A z ∈ K`` for ``z = [θ, τ, r]`` from selected rows and cones.

    Rows are scaled by their largest entry (a cone's three rows together). Order: the two
    sign rows, the linear rows, then the cones (``‖T‖∞``, ``r_j ≥ |Y_j|``, trust region).
    """

    def __init__(self, d: StepData, lin: _Lin, cones: list[_Soc], freqs: np.ndarray) -> None:
        self.nt = d.theta_k.size
        r_of = np.full(d.P.shape[1], -1)
        r_of[freqs] = np.arange(freqs.size)
        self.nz = self.nt + 1 + freqs.size
        blocks = [_sign_rows(d, self.nt), self._linear(lin, r_of)]
        soc = [c for c in cones if c.t0.size]
        blocks += [self._cones(c, r_of) for c in soc]
        rows, cols, vals, b = [], [], [], []
        row0 = 0
        for r, c, v, bb in blocks:
            rows.append(r + row0)
            cols.append(c)
            vals.append(v)
            b.append(bb)
            row0 += bb.size
        self.b = np.concatenate(b)
        self.A = sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(self.b.size, self.nz),
        )
        self.n_lin = 2 + lin.b.size
        self.n_soc = sum(c.t0.size for c in soc)

    def _linear(self, lin: _Lin, r_of: np.ndarray):
        r, c, v = _triplets(np.hstack([-lin.G, -lin.gtau[:, None]]))
        has_r = lin.w != 0
        r = np.concatenate([r, np.nonzero(has_r)[0]])
        c = np.concatenate([c, self.nt + 1 + r_of[lin.j[has_r]]])
        v = np.concatenate([v, lin.w[has_r]])
        return _scale(r, c, v, lin.b, lin.scale()[:, None])

    def _cones(self, cone: _Soc, r_of: np.ndarray):
        k = cone.t0.size
        M = np.empty((3 * k, self.nt))
        M[0::3], M[1::3], M[2::3] = -cone.tG, -cone.qG.real, -cone.qG.imag
        b = np.empty(3 * k)
        b[0::3], b[1::3], b[2::3] = cone.t0, cone.q0.real, cone.q0.imag
        r, c, v = _triplets(M)
        has_r = cone.j >= 0
        r = np.concatenate([r, 3 * np.nonzero(has_r)[0]])
        c = np.concatenate([c, self.nt + 1 + r_of[cone.j[has_r]]])
        v = np.concatenate([v, np.full(int(has_r.sum()), -1.0)])
        mag = np.abs(M).max(axis=1)
        mag[3 * np.nonzero(has_r)[0]] = np.maximum(mag[3 * np.nonzero(has_r)[0]], 1.0)
        return _scale(r, c, v, b, np.maximum(mag, np.abs(b)).reshape(k, 3))


def _scale(r, c, v, b, mag: np.ndarray):
    """Divide each row group (a row of ``mag``) by its largest entry."""
    inv = np.repeat(1.0 / np.maximum(mag.max(axis=1), 1e-300), mag.shape[1])
    return r, c, v * inv[r], b * inv


def _sign_rows(d: StepData, nt: int):
    """Integral-action sign ``σ x(1) ≥ 0.1 |x_k(1)|`` and ``τ ≤ 1`` (keeps it bounded)."""
    na = d.basis.Vx.shape[1]
    x1 = float(np.sum(d.theta_k[:na]))
    sigma = np.sign(x1) or 1.0
    inv = 1.0 / max(1.0, 0.1 * abs(x1))
    r = np.concatenate([np.zeros(na, dtype=int), [1]])
    c = np.concatenate([np.arange(na), [nt]])
    v = np.concatenate([np.full(na, -sigma * inv), [1.0]])
    return r, c, v, np.array([-0.1 * abs(x1) * inv, 1.0])


#: Clarabel's (gap, feasibility) tolerances of the one program of every row (as before
#: constraint generation: each accepted step is re-checked exactly)
TOL_ONE = (1e-6, 1e-7)
#: the generated programs are small: their optimum is taken 100x tighter, and only a
#: "Solved" status is taken (a badly scaled step falls back to the one program)
TOL_GEN = (1e-8, 1e-9)
#: a left-out row joins the program when violated by more than this (scaled)
GEN_TOL = TOL_GEN[1]
#: rounds of constraint generation before falling back to the one program
GEN_ROUNDS = 50
#: an unrefined solve is taken where every scaled row and cone holds to this (the HDD
#: design's final programs: worst row -1.1e-7 unrefined, -3.2e-8 refined); None: refined
PROGRAM_FEAS: float | None = 1e-6
#: Clarabel statuses of a stalled solve whose point may still be offered (``_solve``), if
#: every scaled row and cone holds to ``RESCUE_FEAS`` (the exact test decides): order-6
#: and -8 designs on the stage example stalled in every first step (tau at its cap of 1,
#: rows off by 1e-5-5e-5) and ended at the start controller
RESCUE = ("InsufficientProgress", "NumericalError", "MaxIterations")
RESCUE_FEAS = 1e-3


def _solve(
    prog: _Program,
    tol: tuple[float, float],
    ok: tuple[str, ...],
    refine: bool = True,
    rescue: bool = False,
) -> np.ndarray | None:
    """Clarabel on one program (maximise ``τ``): ``z`` if its status is in ``ok``, else None.

    ``refine`` is Clarabel's iterative refinement of each KKT solve. With ``rescue``, a
    point where Clarabel stalled (:data:`RESCUE`) is returned when every row and cone holds
    to :data:`RESCUE_FEAS`: a candidate for the exact acceptance test of the iteration.
    """
    import clarabel

    cones = [clarabel.NonnegativeConeT(prog.n_lin)] + [clarabel.SecondOrderConeT(3)] * prog.n_soc
    q = np.zeros(prog.nz)
    q[prog.nt] = -1.0
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = tol[0]
    settings.tol_feas = tol[1]
    settings.iterative_refinement_enable = refine
    P = sp.csc_matrix((prog.nz, prog.nz))
    sol = clarabel.DefaultSolver(P, q, prog.A, prog.b, cones, settings).solve()
    z = np.asarray(sol.x)
    if rescue and str(sol.status) in RESCUE and np.all(np.isfinite(z)):
        return z if _worst_slack(prog, z) >= -RESCUE_FEAS else None
    if str(sol.status) not in ok:
        return None
    if not np.all(np.isfinite(z)):
        raise ServokitValueError("loop-shaping step returned non-finite parameters")
    return z


def _worst_slack(prog: _Program, z: np.ndarray) -> float:
    """Most negative slack of the program's (scaled) rows and cones at ``z``."""
    s = prog.b - prog.A @ z
    cones = s[prog.n_lin :].reshape(-1, 3)
    soc = cones[:, 0] - np.hypot(cones[:, 1], cones[:, 2])
    return float(min(s[: prog.n_lin].min(initial=0.0), soc.min(initial=0.0)))


def _solve_generated(prog: _Program, stats: dict | None) -> np.ndarray | None:
    """A generated program: without refinement if its rows hold (``PROGRAM_FEAS``), else
    with it at ``TOL_GEN``, else at ``TOL_ONE`` (Clarabel stalled short of 1e-8 / 1e-9)."""
    z = None if PROGRAM_FEAS is None else _solve(prog, TOL_GEN, ("Solved",), refine=False)
    fast = z is not None and _worst_slack(prog, z) >= -PROGRAM_FEAS
    if not fast:
        z = _solve(prog, TOL_GEN, ("Solved",))
    if stats is not None:
        stats["refined"] = stats.get("refined", 0) + (not fast)
        stats["loose"] = stats.get("loose", 0) + (z is None)
    return z if z is not None else _solve(prog, TOL_ONE, ("Solved",))


def _program(d: StepData, F, lin: _Lin, t_cones: _Soc | None, trust: _Soc) -> _Program:
    """The program of the rows ``lin`` and the cones ``t_cones``, ``r_j`` and ``trust``."""
    free = d.basis.Vy.shape[1] > 0
    freqs = np.unique(lin.j) if free else np.empty(0, dtype=int)
    cones = [] if t_cones is None else [t_cones]
    if free:
        cones.append(_r_cones(d, F, freqs))
    cones.append(trust)
    return _Program(d, lin, cones, freqs)


def _lin_slack(lin: _Lin, theta: np.ndarray, tau: float, y_abs: np.ndarray) -> np.ndarray:
    """Row values at ``(θ, τ)`` with ``r_j = |Y_j(θ)|`` (its least value), scaled."""
    return (lin.b + lin.G @ theta + lin.gtau * tau - lin.w * y_abs[lin.j]) / lin.scale()


def _soc_slack(c: _Soc, theta: np.ndarray) -> np.ndarray:
    """``t - |q|`` of cones without ``r`` at ``θ``, scaled as in the program."""
    return (c.t0 + c.tG @ theta - np.abs(c.q0 + c.qG @ theta)) / c.scale()


def _valleys(v: np.ndarray, seg: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Rows of ``keep`` where ``v`` has a local minimum along its segment (plant and kind)."""
    left = np.ones(v.size, dtype=bool)
    right = np.ones(v.size, dtype=bool)
    same = seg[1:] == seg[:-1]
    left[1:] = ~same | (v[1:] < v[:-1]) | ~keep[:-1]
    right[:-1] = ~same | (v[:-1] <= v[1:]) | ~keep[1:]
    return keep & left & right


#: grid neighbours (each side) that join with a violated valley
GEN_WIDEN = 3


def _widen(rows: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """``rows`` and their ``GEN_WIDEN`` neighbours on each side in the same segment."""
    out = rows.copy()
    for k in range(1, GEN_WIDEN + 1):
        same = seg[k:] == seg[:-k]
        out[k:] |= rows[:-k] & same
        out[:-k] |= rows[k:] & same
    return out


def _violated(d: StepData, F, lin: _Lin, t_cones: _Soc | None, z: np.ndarray, inp: np.ndarray):
    """Points left out of the program whose rows ``z`` violates, and every row's slack.

    ``inp`` marks the points in the program. The new points are the valleys of the
    violated rows with their ``GEN_WIDEN`` neighbours and the points of violated ``‖T‖∞``
    cones; the slack is scaled, at ``z``.
    """
    nt, sel = d.theta_k.size, inp[lin.pt]
    theta, tau = z[:nt], float(z[nt])
    v = _lin_slack(lin, theta, tau, np.abs(d.basis.polys(theta)[1] / F))
    bad = (v < -GEN_TOL) & ~sel
    new = np.zeros(inp.size, dtype=bool)
    new[lin.pt[_widen(_valleys(v, lin.seg, bad), lin.seg) & ~sel]] = True
    if t_cones is not None:
        out = _soc_slack(t_cones, theta) < -GEN_TOL
        new[t_cones.pt[out & ~inp[t_cones.pt]]] = True
    return new, v


@dataclass
class WarmStart:
    """Rows near binding at the last step's optimum, to start the next generation from.

    :func:`solve_step` adds the rows of its masks listed in ``keys`` (``seg · n + j``:
    segment of plant and kind, frequency index) to its first program and, when it ends,
    replaces ``keys`` by the rows of its final program within ``WARM_SLACK`` of binding.
    Consecutive steps (and the re-solves of one step with a larger mask) bind at nearly
    the same points: on the HDD design this halves the programs solved.
    """

    keys: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))
    #: linearisation point of the last step and the keys of every row of its masks
    theta_k: np.ndarray | None = None
    seen: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64))


#: rows of a final program within this scaled slack (100x the rows' accuracy, 1e-7) are
#: carried to the next step; 1e-3 carried many that do not bind: 30 % more Clarabel time
WARM_SLACK = 1e-5


def _keys(d: StepData, lin: _Lin) -> np.ndarray:
    """One integer per row: its segment (plant and kind) and frequency index."""
    return lin.seg.astype(np.int64) * d.P.shape[1] + lin.j


def _unseen(d: StepData, lin: _Lin, warm: WarmStart | None) -> np.ndarray:
    """Rows whose valleys at ``θ_k`` seed the first program.

    Every row on a cold start. From a warm start of a new step (``θ_k`` moved), none:
    the rows binding at the last optimum, carried in ``warm.keys``, bind again (on the
    HDD design the valleys doubled the first program and saved no round). On a re-solve
    of the same step with a grown mask, the rows of the new points.
    """
    if warm is None or warm.theta_k is None or not warm.keys.size:
        return np.ones(lin.b.size, dtype=bool)
    if not np.array_equal(warm.theta_k, d.theta_k):
        return np.zeros(lin.b.size, dtype=bool)
    return ~np.isin(_keys(d, lin), warm.seen)


def _start(d: StepData, F, lin: _Lin, warm: WarmStart | None) -> np.ndarray:
    """Points of the first program: the valleys of every row's slack at ``θ_k``, the rows
    ``θ_k`` violates (``τ = 0``) and the rows of ``warm``."""
    v = _lin_slack(lin, d.theta_k, 0.0, np.abs(d.basis.polys(d.theta_k)[1] / F))
    rows = _valleys(v, lin.seg, _unseen(d, lin, warm)) | (v <= 0)
    if warm is not None and warm.keys.size:
        rows |= np.isin(_keys(d, lin), warm.keys)
    inp = np.zeros(int(lin.pt.max()) + 1 if lin.pt.size else 0, dtype=bool)
    inp[lin.pt[rows]] = True
    return inp


def _generate(d: StepData, F, K, lin: _Lin, t_cones: _Soc | None, stats, warm):
    """Constraint generation over the rows of the masks (module doc); ``z`` or None.

    Starts from the points of :func:`_start`; after each solve the valleys of the
    violated rows and their ``GEN_WIDEN`` neighbours join. It ends when every row of the
    masks holds within ``GEN_TOL``: an optimum of the program of all rows (``warm`` then
    holds the rows near binding). None when a program is not "Solved" (at either
    tolerance) or the rounds run out.
    """
    inp = _start(d, F, lin, warm)
    trust = _trust(d, F, K)
    for _ in range(GEN_ROUNDS):
        sel = inp[lin.pt]
        t_sel = None if t_cones is None else t_cones.take(inp[t_cones.pt])
        prog = _program(d, F, lin.take(sel), t_sel, trust)
        if stats is not None:
            stats.setdefault("rows", []).append(int(sel.sum()))
        z = _solve_generated(prog, stats)
        if z is None:
            return None
        new, v = _violated(d, F, lin, t_cones, z, inp)
        if not new.any():
            if warm is not None:
                keys = _keys(d, lin)
                warm.keys, warm.seen = keys[sel & (v < WARM_SLACK)], keys
                warm.theta_k = d.theta_k.copy()
            return z
        inp |= new
    return None


def solve_step(
    d: StepData,
    *,
    generate: bool = True,
    stats: dict | None = None,
    warm: WarmStart | None = None,
) -> tuple[np.ndarray, float] | None:
    """Solve one convex step; ``None`` if Clarabel does not reach an optimum.

    Parameters
    ----------
    d : StepData
        Linearisation point, active sets, bounds and trust radius.
    generate : bool
        Constraint generation over the rows of the masks (the same optimum, a fraction of
        the rows); False, and where a generated program is not "Solved", one program
        with every row of the masks (1e-6 / 1e-7, as before).
    stats : dict, optional
        Receives ``"rows"``: the linear rows of each program solved, and
        ``"one_program": True`` when the program of every row was solved.
    warm : WarmStart, optional
        Rows to start the generation from, replaced by the rows near binding at this
        step's optimum (the optimum is that of every row either way).

    Returns
    -------
    tuple of (ndarray, float) or None
        New parameters ``θ`` and the optimal ``τ``.
    """
    xk, F = d.basis.polys(d.theta_k)
    K = xk / F
    lin, t_cones = _candidates(d, F, K)
    z = _generate(d, F, K, lin, t_cones, stats, warm) if generate else None
    if z is None:  # one program of every row, as before constraint generation
        full = _program(d, F, lin, t_cones, _trust(d, F, K))
        z = _solve(full, TOL_ONE, ("Solved", "AlmostSolved"), rescue=True)
        if stats is not None:
            stats.setdefault("rows", []).append(lin.b.size)
            stats["one_program"] = True
    return None if z is None else (z[: d.theta_k.size], float(z[d.theta_k.size]))
