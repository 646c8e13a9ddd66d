"""Robust minimum-time feedforward over a plant set, as linear programs (beyond the book).

The book designs its FSC/FFSC inputs on one model and tunes frequency weights by trial
and error until the worst of the 18 perturbed HDD plants settles (§2.4.2, Table 2.4).
Here the shortest seek that is *guaranteed* on the whole plant set is computed directly.

For a step number ``N`` and a settle index ``s`` on the read-out grid ``t_j = j h``,
the held samples ``u[0..N-1]`` are feasible when, for every plant ``v``:

* ``|y_v[j] - target| <= band`` for ``s <= j <= J`` (the grid rows of eq. R1 of
  :mod:`servokit.seek._matrices`; ``J`` is the horizon, ``tail`` after the delayed
  input ends);
* the rigid body is at rest, ``sum_k u[k] = 0``, and the free motion after the horizon
  stays in the band by the modal envelope bound (R3) - the infinite tail is bounded,
  not truncated;
* ``|u[k]| <= u_max`` and optionally ``|u[k] - u[k-1]| <= slew_max`` (``u[-1] = u[N] = 0``).

That is a linear feasibility problem (HiGHS through ``scipy.optimize.linprog``).  It is
monotone in ``s``, so the smallest feasible ``s`` is found by bisection; ``N`` is scanned
upward from the bang-bang bound ``N dt >= 2 sqrt(|target| / (g u_max))`` (``g`` the
largest rigid-body gain), testing first whether ``N`` can beat the best ``s`` so far
(one LP for most ``N``).  At the best ``(N, s)`` a second problem picks, among the
feasible inputs, the smallest peak (LP) or energy (QP through qpsolvers, via
:func:`servokit.feedforward.solve_fsc_qp`).

The LPs stay small by row generation: they start from the grid rows at the sampling
instants, and rows that the solution violates on the fine grid are added until none
is (a relaxation that is infeasible proves the full problem infeasible, so the search
decisions are exact).  All rows are scaled by the band, the inputs by ``u_max``.  The
feasibility questions of one ``N`` share one HiGHS model (generated rows kept, rows
before the settle index switched off, warm dual simplex;
:mod:`servokit.seek._highs_feasibility`): the decisions of fresh LPs up to HiGHS's
feasibility tolerance (equal in every test and HDD design) at half the CPU, and the
design's input comes from a fresh peak / energy solve at the chosen ``(N, s)``, so
equal decisions give the same array.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import scipy  # scipy.optimize is loaded by SciPy on first use (start-up)

from servokit.errors import ServokitValueError, check_finite, check_memory, check_positive
from servokit.feedforward import FeedforwardInput, constraint_rows, lifted_model, solve_fsc_qp
from servokit.models.modal import ModalPlant
from servokit.seek._matrices import PulseBank
from servokit.simulate._bank import as_plant_list
from servokit.simulate.metrics import readout_substeps

__all__ = ["NoFeasibleSeekError", "RobustFeedforwardInput", "robust_minimum_time"]

#: solver tolerance and rounding absorbed inside the band (fraction of the band)
_SOLVER_SLACK = 1e-6
#: relative violation (of the band) above which a fine-grid row is added to the LP
_ROW_TOL = 1e-9


class NoFeasibleSeekError(ServokitValueError):
    """No step number in the scanned range settles every plant within the band.

    Attributes
    ----------
    N_range : (int, int)
        The step numbers tried (or the bang-bang bound above ``N_max``).
    """

    def __init__(self, message: str, N_range: tuple[int, int]) -> None:
        super().__init__(message)
        self.N_range = N_range


@dataclass(frozen=True, eq=False)
class RobustFeedforwardInput(FeedforwardInput):
    """A :class:`~servokit.feedforward.FeedforwardInput` with its robust-design guarantee.

    Attributes
    ----------
    guaranteed_seek_time : float
        Worst-case seek time over the design set [s] that the LP guarantees (grid time of
        the settle index; the output stays within the design band from then on, tail
        included).
    binding_plant : int
        Index of the design plant that settles last (sets the seek time).
    band : float
        Band the design met (the requested band shrunk by the margin).
    N_values, seek_times : ndarray
        Step numbers tried and the best guaranteed seek time of each [s] (inf: none beat
        the best so far or infeasible).
    n_lp : int
        Number of LP/QP solves.
    """

    guaranteed_seek_time: float = float("inf")
    binding_plant: int = -1
    band: float = 0.0
    N_values: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    seek_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_lp: int = 0


class _SeekLP:
    """The feasibility / peak / energy problems for one ``N`` (rows built once)."""

    def __init__(
        self,
        bank: PulseBank,
        N: int,
        target: float,
        band: float,
        u_max: float,
        tail: float,
        slew_max: float | None,
        limits: Sequence[object] = (),
    ) -> None:
        self.N, self.target, self.band, self.u_max = N, target, band, u_max
        self.substeps = bank.substeps
        self.J = bank.horizon_index(N, tail)
        self.H = bank.output_map(N, np.arange(self.J + 1)) * (u_max / band)  # (V, J+1, N)
        self.tail_A, self.tail_b = self._tail_rows(bank, N, slew_max)
        if limits:
            G, h = _limit_rows(bank, N, limits)
            self.tail_A = np.vstack(
                [self.tail_A, np.hstack([G * u_max, np.zeros((len(G), self.n_env))])]
            )
            self.tail_b = np.concatenate([self.tail_b, h])
        self.n_lp = 0
        self._kept: object = None  # the kept feasibility model; False: not available

    def _tail_rows(
        self, bank: PulseBank, N: int, slew_max: float | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Rows of (R3) over ``[x, c]`` (c: one envelope variable per flexible mode), slew."""
        tm = bank.tail_maps(N, self.J)
        s = self.u_max / self.band
        flex = np.any(tm.a != 0.0, axis=2) | np.any(tm.b != 0.0, axis=2)  # (V, M)
        pv, pm = np.nonzero(flex)
        P = pv.size
        self.n_env = P
        a, b = tm.a[pv, pm] * s, tm.b[pv, pm] * s  # (P, N)
        eye = np.eye(P)
        env = np.vstack([np.hstack([sa * a + sb * b, -eye]) for sa in (1, -1) for sb in (1, -1)])
        owner = (pv[None, :] == np.arange(bank.n_plants)[:, None]).astype(float)  # (V, P)
        rig = tm.rigid * s
        t = self.target / self.band  # rows in band units: the band itself is 1
        rows = [env, np.hstack([rig, owner]), np.hstack([-rig, owner])]
        rhs = [np.zeros(4 * P), np.full(bank.n_plants, 1 + t), np.full(bank.n_plants, 1 - t)]
        if slew_max is not None:
            D = np.eye(N + 1, N) - np.eye(N + 1, N, -1)  # u[k] - u[k-1], u[-1] = u[N] = 0
            Ds = np.hstack([D, np.zeros((N + 1, P))])
            rows += [Ds, -Ds]
            rhs += [np.full(2 * (N + 1), slew_max / self.u_max)]
        return np.vstack(rows), np.concatenate(rhs)

    @property
    def n_var(self) -> int:
        return self.N + self.n_env

    def _grid_rows(self, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        G = self.H[mask]  # (R, N)
        t = self.target / self.band
        Gx = np.hstack([G, np.zeros((G.shape[0], self.n_env))])
        return np.vstack([Gx, -Gx]), np.concatenate(
            [np.full(len(G), 1 + t), np.full(len(G), 1 - t)]
        )

    def outputs(self, x: np.ndarray, s: int) -> np.ndarray:
        """Deviation ``(y - target) / band`` (V, J+1-s) of the scaled input ``x``."""
        return self.H[:, s:] @ x[: self.N] - self.target / self.band

    def _first_rows(self, s: int) -> np.ndarray:
        """Grid rows of the first relaxation at settle index ``s`` (V, J+1)."""
        mask = np.zeros(self.H.shape[:2], dtype=bool)
        # start from the sampling instants just after s (where rows bind) and a sparse
        # sampling of the rest; violated fine-grid rows are added below
        S = self.substeps
        mask[:, s : s + 4 * S : S] = True
        mask[:, s + 4 * S :: 8 * S] = True
        mask[:, self.J] = True
        return mask

    def solve(self, s: int, objective: str = "feasible") -> np.ndarray | None:
        """Scaled solution ``[x, c]`` settling from grid index ``s``, or None if infeasible.

        Feasibility questions go to one HiGHS model kept for this ``N`` (rows generated
        for earlier ``s`` stay, warm start; :mod:`servokit.seek._highs_feasibility`); the
        peak / energy problems are solved fresh, so the design depends only on ``(N, s)``.
        """
        if objective == "feasible" and self._kept is not False:
            try:
                return self._solve_kept(s)
            except RuntimeError:  # a stalled re-solve or no binding: this question fresh
                self._kept = False if self._kept is None else None
        return self._solve_fresh(s, objective)

    def _solve_kept(self, s: int) -> np.ndarray | None:
        from servokit.seek import _highs_feasibility as hf

        if self._kept is None:
            if not hf.available():
                raise RuntimeError("no HiGHS binding")
            n = self.n_var
            lb = np.concatenate([-np.ones(self.N), np.zeros(self.n_env)])
            ub = np.concatenate([np.ones(self.N), np.full(self.n_env, np.inf)])
            a_eq = np.concatenate([np.ones(self.N), np.zeros(self.n_env)])
            self._kept = hf.HighsFeasibility(lb, ub, self.tail_A, self.tail_b, a_eq)
            self._in_model = np.zeros(self.H.shape[:2], dtype=bool)
            assert self._kept.n == n
        model, in_model = self._kept, self._in_model
        t, width = self.target / self.band, self.H.shape[1]
        need = self._first_rows(s)
        while True:
            need &= ~in_model
            v, j = np.nonzero(need)
            G = np.hstack([self.H[v, j], np.zeros((v.size, self.n_env))])
            model.add_ranged(v * width + j, G, np.full(v.size, t - 1), np.full(v.size, t + 1))
            in_model |= need
            model.switch(model.keys % width >= s)
            self.n_lp += 1
            x = model.solve()
            if x is None:
                return None
            dev = np.abs(self.outputs(x, s)) - 1.0
            need = np.zeros_like(in_model)
            need[:, s:] = (dev > _ROW_TOL) & ~in_model[:, s:]
            if not need.any():
                return x

    def _solve_fresh(self, s: int, objective: str) -> np.ndarray | None:
        mask = self._first_rows(s)
        while True:
            x = self._solve_rows(mask, objective)
            if x is None:
                return None
            dev = np.abs(self.outputs(x, s)) - 1.0
            new = (dev > _ROW_TOL) & ~mask[:, s:]
            if not new.any():
                return x
            mask[:, s:] |= new

    def _solve_rows(self, mask: np.ndarray, objective: str) -> np.ndarray | None:
        Ag, bg = self._grid_rows(mask)
        A_ub = np.vstack([Ag, self.tail_A])
        b_ub = np.concatenate([bg, self.tail_b])
        A_eq = np.concatenate([np.ones(self.N), np.zeros(self.n_env)])[None, :]
        self.n_lp += 1
        if objective == "energy":
            return self._solve_energy(A_ub, b_ub, A_eq)
        n = self.n_var
        bounds = [(-1.0, 1.0)] * self.N + [(0.0, None)] * self.n_env
        c = np.zeros(n)
        if objective == "peak":  # one more variable p >= |x_k|, minimised
            peak = np.zeros((2 * self.N, n + 1))
            peak[:, : self.N] = np.vstack([np.eye(self.N), -np.eye(self.N)])
            peak[:, n] = -1.0
            A_ub = np.vstack([np.hstack([A_ub, np.zeros((len(A_ub), 1))]), peak])
            b_ub = np.concatenate([b_ub, np.zeros(2 * self.N)])
            A_eq = np.hstack([A_eq, [[0.0]]])
            bounds.append((0.0, 1.0))
            c = np.zeros(n + 1)
            c[n] = 1.0
        problem = {"A_ub": A_ub, "b_ub": b_ub, "A_eq": A_eq, "b_eq": [0.0], "bounds": bounds}
        res = scipy.optimize.linprog(c, **problem, method="highs-ds")
        tried = "HiGHS's dual simplex"
        if res.status == 4:
            tried += " and interior point"
            # HiGHS "solve error": the dual simplex lost its way on a tiny, badly conditioned
            # LP (hypothesis: 16 rows with coefficients from 8e-11 to 28); the interior point
            # method decides it (at any scale of the output units)
            res = scipy.optimize.linprog(c, **problem, method="highs-ipm")
        if res.status == 2:
            return None
        if res.status != 0:
            raise ServokitValueError(
                f"the robust seek LP failed ({res.message}, {tried}); change N or the band"
            )
        return np.asarray(res.x[:n])

    def _solve_energy(
        self, A_ub: np.ndarray, b_ub: np.ndarray, A_eq: np.ndarray
    ) -> np.ndarray | None:
        from servokit.feedforward import InfeasibleConstraintsError

        n = self.n_var
        box = np.vstack([np.eye(n)[: self.N], -np.eye(n)[: self.N], -np.eye(n)[self.N :]])
        G = np.vstack([A_ub, box])
        h = np.concatenate([b_ub, np.ones(2 * self.N), np.zeros(self.n_env)])
        P = np.diag(np.concatenate([np.ones(self.N), np.zeros(self.n_env)]))
        try:
            return solve_fsc_qp(P, np.zeros(n), A_eq, np.zeros(1), G, h, rtol=1e-7)
        except InfeasibleConstraintsError:
            return None


def _limit_rows(bank: PulseBank, N: int, limits: Sequence[object]) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``G u <= h`` (normalised to ``h = 1``) of §2.6 limits for every rigid-body gain.

    The limits are the constraint objects of :mod:`servokit.feedforward.constraints`
    (``InputLimit``, ``VelocityLimit``, ``VoltageLimit``, ...), evaluated on the book's
    design model of (2.83)-(2.88): the rigid body ``[position, velocity]`` driven by the
    held input, one model per distinct rigid-body gain of the set.
    """
    dt = bank.dt
    gains = np.unique(np.where(bank.w == 0.0, bank.r, 0.0).sum(axis=1))
    A = np.array([[1.0, dt], [0.0, 1.0]])
    G_parts, h_parts = [], []
    for g in gains:
        model = lifted_model(
            A,
            g * np.array([dt**2 / 2, dt]),
            N,
            np.zeros(2),
            dt=dt,
            position=np.array([1.0, 0.0]),
            velocity=np.array([0.0, 1.0]),
        )
        G, h, _ = constraint_rows(limits, model)
        G_parts.append(G / h[:, None])
        h_parts.append(np.ones(len(h)))
    return np.vstack(G_parts), np.concatenate(h_parts)


def _settle_search(lp: _SeekLP, hi: int, lo: int = -1) -> tuple[int, np.ndarray] | None:
    """Smallest settle index ``lo < s <= hi`` with a feasible input (bisection), or None.

    With a known infeasible ``lo`` (e.g. the guarantee of a subset of the plants, which
    no superset can beat) the search gallops up from it first: a redesign on a few more
    plants usually moves the settle index by a step or two.
    """
    step = 1
    while lo >= 0 and lo + step < hi:
        x = lp.solve(lo + step)
        if x is not None:
            hi = lo + step
            break
        lo, step = lo + step, 2 * step
    else:
        x = lp.solve(hi)
    if x is None:
        return None
    while hi - lo > 1:
        mid = (lo + hi) // 2
        cand = lp.solve(mid)
        if cand is None:
            lo = mid
        else:
            hi, x = mid, cand
    return hi, x


def _first_N(bank: PulseBank, target: float, u_max: float) -> int:
    """Bang-bang bound: the rigid body cannot go ``|target|`` and stop in less time."""
    rigid_gain = np.where(bank.w == 0.0, np.abs(bank.r), 0.0).sum(axis=1).max()
    t_min = 2.0 * np.sqrt(abs(target) / (rigid_gain * u_max))
    return max(1, int(np.floor(t_min / bank.dt)))


def _check_args(
    dt: float, target: float, band: float, u_max: float, margin: float, tail: float
) -> tuple[float, ...]:
    dt = check_positive("dt", dt, "s")
    target = float(check_finite("target", target))
    band = check_positive("band", band)
    u_max = check_positive("u_max", u_max)
    margin = float(check_finite("margin", margin))
    if not 0.0 <= margin < 1.0:
        raise ServokitValueError(f"margin must be in [0, 1) (fraction of the band), got {margin}")
    tail = check_positive("horizon", tail, "s")
    if abs(target) <= band * (1.0 - margin):
        raise ServokitValueError(
            f"target {target:g} is already inside the band +-{band:g}: nothing to seek; "
            "increase target or reduce band"
        )
    return dt, target, band, u_max, margin, tail


def robust_minimum_time(
    plants: ModalPlant | Sequence[ModalPlant],
    dt: float,
    target: float,
    *,
    band: float,
    u_max: float,
    N: int | None = None,
    N_max: int | None = None,
    grid: float | None = None,
    horizon: float | None = None,
    slew_max: float | None = None,
    limits: Sequence[object] | None = None,
    margin: float = 0.2,
    objective: Literal["peak", "energy"] = "peak",
    patience: int = 4,
    max_memory_mb: float | None = None,
    settle_below: float | None = None,
) -> RobustFeedforwardInput:
    """Shortest worst-case seek guaranteed on a plant set under input limits (LP/QP).

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Design set (sharing one delay), e.g. the 18 plants of Table 2.3.
    dt : float
        Hold period of the input [s].
    target : float
        Seek distance (plant output units, tracks for the HDD).
    band : float
        Settling band half-width; the seek time is when every plant stays within it.
    u_max : float
        Input limit ``|u[k]| <= u_max`` (plant input units).
    N : int, optional
        Fixed step number; default: scan from the bang-bang bound up to ``N_max``.
    N_max : int, optional
        Largest N scanned (default four times the bang-bang bound plus 10).
    grid : float, optional
        Read-out period of the position [s], dividing ``dt`` (default ``dt / 10``).
    horizon : float, optional
        Grid rows are checked up to this long after the delayed input ends [s]; beyond it
        the modal envelope bound (R3) holds the output in the band.  Default
        ``max(2 ms, 10 dt)``.
    slew_max : float, optional
        ``|u[k] - u[k-1]| <= slew_max`` per sample (from and back to zero).
    limits : sequence of constraint objects, optional
        Limits of §2.6 (:class:`~servokit.feedforward.VoltageLimit`,
        :class:`~servokit.feedforward.VelocityLimit`, ...) on the rigid-body design model
        of every plant's gain, eqs. (2.83)-(2.88); the input itself is the current.
    margin : float
        Design margin: the band is shrunk to ``band (1 - margin)`` so that the guarantee
        carries over to plants near the design set.  The default 0.2 is the smallest of
        0, 0.1, 0.2 for which the HDD designs (1 and 10 tracks, Design 2's peak input) stay
        no worse than Design 2 on 1000 held-out Monte-Carlo plants of Table 2.3 (case
        ``hdd-robust-seek``); with 0 the 1-track design fails on some of them.
    objective : {"peak", "energy"}
        Among the inputs reaching the best seek time, the one of least peak (LP) or
        least sum of squares (QP).
    patience : int
        Stop the N scan after this many N in a row that do not improve the seek time.
    max_memory_mb : float, optional
        Refuse designs whose output maps are estimated above this [MB].
    settle_below : float, optional
        A seek time [s] known to be infeasible for this set (e.g. below the guarantee of a
        subset, with the same ``N``): the settle search starts above it.

    Returns
    -------
    RobustFeedforwardInput
        ``u`` (N,), ``dt``, ``target``; ``guaranteed_seek_time`` [s], ``binding_plant``.

    Raises
    ------
    ServokitValueError
        Bad arguments, an empty plant set, or no N up to ``N_max`` meeting the band
        (the message names what to relax).
    """
    plist = as_plant_list(plants)
    if horizon is None:  # 2 ms for the HDD; slower plants: ten hold periods
        horizon = max(2e-3, 10 * float(check_positive("dt", dt, "s")))
    dt, target, band, u_max, margin, tail = _check_args(dt, target, band, u_max, margin, horizon)
    if objective not in ("peak", "energy"):
        raise ServokitValueError(f"objective must be 'peak' or 'energy', got {objective!r}")
    S = readout_substeps(dt, grid)
    if slew_max is not None:
        slew_max = check_positive("slew_max", slew_max)
    band_eff = band * (1.0 - margin)
    probe = PulseBank.build(plist, dt, 1, dt)  # modal data only, for the N bounds
    N_lo = _first_N(probe, target, u_max) if N is None else int(N)
    N_hi = (4 * N_lo + 10 if N_max is None else int(N_max)) if N is None else int(N)
    if N_lo < 1 or N_hi < N_lo:
        raise NoFeasibleSeekError(
            f"N_max ({N_hi}) is below {N_lo}, the fewest steps in which |u| <= {u_max:g} can "
            "move the rigid body to the target and stop: raise N_max or u_max",
            (N_lo, N_hi),
        )
    duration = N_hi * dt + plist[0].delay + tail + 2 * dt
    n_grid = duration / dt * S
    check_memory(
        len(plist) * n_grid * (N_hi + 1) * 8 * 2,
        what=f"{len(plist)} plants x {n_grid:.0f} grid points x N_max {N_hi}",
        max_memory_mb=max_memory_mb,
    )
    bank = PulseBank.build(plist, dt, S, duration)
    setup = _Setup(target, band_eff, u_max, tail, slew_max, tuple(limits or ()), objective)
    lo = -1 if settle_below is None else int(np.floor(settle_below / (dt / S) + 1e-6))
    return _scan(bank, setup, (N_lo, N_hi), patience, lo)


@dataclass(frozen=True)
class _Setup:
    """The fixed data of one design (everything but N and the settle index)."""

    target: float
    band: float
    u_max: float
    tail: float
    slew_max: float | None
    limits: tuple[object, ...]
    objective: str


def _scan(
    bank: PulseBank, setup: _Setup, N_range: tuple[int, int], patience: int, lo: int = -1
) -> RobustFeedforwardInput:
    """Scan N upward; keep the smallest guaranteed settle time (smallest N on ties)."""
    target, band, u_max, objective = setup.target, setup.band, setup.u_max, setup.objective
    best: tuple[float, _SeekLP, int] | None = None
    Ns, times, n_lp, stale = [], [], 0, 0
    # the LP works a hair inside the band: active rows then sit below it, not on it
    lp_band = band * (1.0 - _SOLVER_SLACK)
    for N in range(N_range[0], N_range[1] + 1):
        lp = _SeekLP(bank, N, target, lp_band, u_max, setup.tail, setup.slew_max, setup.limits)
        h = bank.dt / bank.substeps
        hi = lp.J if best is None else min(lp.J, int(round(best[0] / h)) - 1)
        found = _settle_search(lp, hi, lo) if hi > lo else None
        n_lp += lp.n_lp
        lp.n_lp = 0
        Ns.append(N)
        times.append(np.inf if found is None else found[0] * h)
        if found is not None:
            best, stale = (found[0] * h, lp, found[0]), 0
        elif best is not None:
            stale += 1
            if stale >= patience:
                break
    if best is None:
        raise NoFeasibleSeekError(
            f"no N in {N_range[0]}..{N_range[1]} settles every plant within +-{band:g} with "
            f"|u| <= {u_max:g}: raise u_max, widen the band, reduce the margin or raise N_max",
            N_range,
        )
    seek, lp, s = best
    x = lp.solve(s, objective)
    if x is None:  # the feasible point exists; a second-stage failure is a solver issue
        x = lp.solve(s)
    assert x is not None
    u = x[: lp.N] * u_max
    dev = np.abs(lp.outputs(x, 0)) > 1.0 + _ROW_TOL
    last_out = np.where(dev.any(axis=1), dev.shape[1] - 1 - np.argmax(dev[:, ::-1], axis=1), -1)
    return RobustFeedforwardInput(
        u=u,
        dt=bank.dt,
        target=target,
        jerk=np.diff(np.concatenate([[0.0], u, [0.0]]))[:-1],
        design=f"robust minimum-time LP over {bank.n_plants} plants, |u| <= {u_max:g}",
        guaranteed_seek_time=seek,
        binding_plant=int(np.argmax(last_out)),
        band=band,
        N_values=np.array(Ns),
        seek_times=np.array(times),
        n_lp=n_lp + lp.n_lp,
    )
