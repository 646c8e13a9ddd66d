"""Fixed-structure controller design straight from the measured FRFs of a plant set.

:func:`loopshape` maximises the lowest gain crossover over a set of frequency responses
subject to ``‖S‖∞ ≤ s_max`` (optionally ``‖T‖∞ ≤ t_max``) on every one, for a controller of
fixed structure (:mod:`~servokit.feedback.loopshape_problem`), by the convex-concave
iteration of data-driven fixed-structure design:

* A. Karimi and C. Kammer, "A data-driven approach to robust control of multivariable
  systems by convex optimization", Automatica 85 (2017) 227-233: ``K = X Y^{-1}`` with
  ``X, Y`` linear in the parameters; ``|W S| ≤ 1`` written ``|W Y| ≤ |Y + P X|`` and its
  right side replaced by the tangent bound ``Re{(Y_k + P X_k)^* (Y + P X)}/|Y_k + P X_k|``
  around the previous iterate, a convex inner approximation (so every iterate stays
  feasible and the objective is monotone);
* A. Karimi and G. Galdos, "Fixed-order H∞ controller design for nonparametric models by
  convex optimization", Automatica 46 (2010) 1388-1394, and Karimi, Nicoletti and Zhu,
  "Robust H∞ controller design using frequency-domain data via convex optimization",
  Int. J. Robust Nonlinear Control 28 (2018): the stability certificate. If
  ``Re{(Y_k + P X_k)^* (Y + P X)} > 0`` at every frequency, the characteristic polynomials
  ``φ = D_P y + N_P x`` and ``φ_k`` have the same winding number on the unit circle; with
  ``y`` monic in ``z^{-1}`` both have full degree, so ``K`` stabilises ``P`` whenever
  ``K_k`` does, without a model of ``P``. The tangent sensitivity constraint implies it.

The crossover is maximised by continuation: at an iterate of lowest crossover ``f_k`` the
target is ``f_t = (1 + δ) f_k`` and the step maximises ``τ`` in ``|P X| ≥ |Y| + τ`` at every
frequency up to ``f_t`` (tangent bound on ``|P X|``), i.e. pushes ``|L|`` above 1 there.
A frequency-domain trust region ``|K - K_k| ≤ ρ |K_k|`` keeps each step where the tangent
bounds are accurate. Only points near activity enter the cone program; after each solve
every plant-frequency point is checked and violated ones are added (constraint generation).

Below the grid. The cone programs also hold on ``ASYMPTOTE_DECADES`` decades below the
first measured point, where each plant is its asymptote ``g/(z - 1)^m`` (the assumption of
the stability count, :mod:`~servokit.feedback.loopshape_eval`): without them a step could
move controller zeros there unseen. On ``servokit loopshape examples/data/stage_frf.csv
--dt 2.5e-5 --order 4`` (grid from 10 Hz) the steps drove a lag zero pair at 6.8 Hz to
modulus 0.99999 and stalled at 312.3 Hz with a closed-loop pole of the fitted model at
0.999999; with the extension the run reaches 705.5 Hz, largest pole modulus 0.999757.
The tables, the acceptance test and the history are on the measured points only.

Limits (documented in docs/guide/loopshape.md): the guarantees hold on the grid; between
grid points they rest on the grid resolving the resonances. Every accepted step is
therefore certified exactly: Nyquist winding count of every loop on the full grid
(:func:`~servokit.feedback.loopshape_eval.closed_loop_unstable`) and the sensitivity peak
on every point; where models exist, :func:`certify_models` checks the closed-loop poles of
the exact ZOH discretisation. The iteration is a local method: it needs a stabilising
initial controller (given, or found by a PID gain scan) and converges to a local optimum.
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_finite, check_positive
from servokit.feedback.loopshape_eval import LoopTable, asymptote_gain, evaluate_set
from servokit.feedback.loopshape_init import initial_parameters, plant_integrators
from servokit.feedback.loopshape_problem import (
    Structure,
    check_frf_set,
    fixed_order_structure,
    modal_banks,
    pid_notch_structure,
)
from servokit.feedback.loopshape_socp import Basis, StepData, WarmStart, solve_step

__all__ = ["LoopshapeResult", "loopshape", "certify_banks", "certify_models"]


@dataclass(frozen=True)
class LoopshapeResult:
    """Outcome of :func:`loopshape`.

    Attributes
    ----------
    controller : control.TransferFunction
        The designed discrete controller (``dt`` set).
    table : LoopTable
        Per-plant crossover, margins, ``‖S‖∞`` and stability on the design grid.
    initial_table : LoopTable
        The same for the initial controller.
    history : list of dict
        One entry per accepted step (lowest crossover, worst ``‖S‖∞``, τ, trust radius).
    structure : Structure
        The controller structure.
    theta : ndarray
        Final parameters.
    design_time_s : float
        Wall time of the iteration [s].
    initial_controller : control.TransferFunction
        The starting controller in the structure.
    notes : list of str
        How the start was obtained; an unmet bound.
    """

    controller: control.TransferFunction
    table: LoopTable
    initial_table: LoopTable
    history: list[dict[str, Any]]
    structure: Structure
    theta: np.ndarray
    design_time_s: float
    initial_controller: control.TransferFunction | None = None
    notes: list[str] = field(default_factory=list)


@dataclass
class _State:
    theta: np.ndarray
    table: LoopTable
    rho: float


def _resolve_structure(
    structure: str | Structure, order: int | None, dt: float, notches, lowpass_hz
) -> Structure:
    if isinstance(structure, Structure):
        return structure
    if structure == "order":
        if order is None:
            raise ServokitValueError("structure 'order' needs order (number of states)")
        return fixed_order_structure(order)
    if structure == "pid-notch":
        return pid_notch_structure(dt, notches=tuple(notches or ()), lowpass_hz=tuple(lowpass_hz))
    raise ServokitValueError(f"structure must be 'pid-notch' or 'order', got {structure!r}")


class _Problem:
    """The data and evaluation of one design (grid, FRFs, structure, bounds)."""

    def __init__(
        self, f, P, dt, structure: Structure, s_max, t_max, n_plant_int, names, n_below=0
    ):
        self.f, self.P, self.dt, self.st = f, P, dt, structure
        self.n_below = n_below  # leading asymptote points: in the cone programs only
        self.zinv = np.exp(-2j * np.pi * f * dt)
        self.basis = Basis.build(
            self.zinv, structure.den_fixed, structure.n_num, structure.n_den_free
        )
        self.s_max, self.t_max = s_max, t_max
        self.m = n_plant_int + structure.n_integrators
        self.names = names
        n = f.size
        self.tr_idx = np.unique(np.linspace(0, n - 1, min(n, 150)).astype(int))
        self.floor_idx: np.ndarray | None = None
        self.floor_w: np.ndarray | None = None
        self.warm = WarmStart()  # rows binding at the last step (loopshape_socp)

    def set_floor(self, theta0: np.ndarray, f_c: float, keep: float | None) -> None:
        """Keep ``|L| ≥ keep |L_0|`` at 40 log-spaced grid points below ``0.7 f_c``."""
        below = np.nonzero(self.f <= 0.7 * f_c)[0]
        if keep is None or below.size == 0:
            return
        pick = np.unique(np.rint(np.geomspace(1, below.size, 40)).astype(int) - 1)
        self.floor_idx = below[pick]
        self.floor_w = keep * np.abs(self.P[:, self.floor_idx] * self.K(theta0)[self.floor_idx])

    def K(self, theta: np.ndarray) -> np.ndarray:
        x, y = self.basis.polys(theta)
        return x / y

    def table(self, theta: np.ndarray) -> LoopTable:
        # on the measured points; below them the controller is known exactly (a step may
        # put zeros there): only the plant is left to the asymptote rule
        i = self.n_below
        return evaluate_set(
            self.f[i:],
            self.P[:, i:],
            self.K(theta)[i:],
            self.dt,
            n_integrators=self.m,
            names=self.names,
            controller_coefficients=self.st.split(theta),
            controller_integrators=self.st.n_integrators,
        )

    def ok(self, theta: np.ndarray, s_bound: float) -> tuple[bool, LoopTable]:
        """Exact acceptance test: every loop stable and resolved, ‖S‖∞ within the bound."""
        tab = self.table(theta)
        good = tab.all_stable and all(r.resolved for r in tab.rows)
        good = good and tab.worst_s_peak_db <= s_bound + 1e-9
        if self.t_max is not None:
            good = good and max(r.t_peak_db for r in tab.rows) <= self.t_max + 1e-9
        return good, tab


def _masks(pb: _Problem, theta: np.ndarray, f_t: float | None, s_lin: float):
    K = pb.K(theta)
    L = pb.P * K[None, :]
    s_mask = np.abs(1.0 / (1.0 + L)) >= 0.8 * s_lin
    c_mask = None
    if f_t is not None:
        c_mask = (pb.f[None, :] <= f_t) & (np.abs(L) < 1.5)
    return s_mask, c_mask


def _violations(pb: _Problem, theta_new, theta_k, s_lin: float) -> np.ndarray:
    """Points where the true sensitivity bound or the stability certificate fails."""
    Kk, Kn = pb.K(theta_k), pb.K(theta_new)
    xk, yk = pb.basis.polys(theta_k)
    xn, yn = pb.basis.polys(theta_new)
    cert = np.real(np.conj(yk + pb.P * xk) * (yn + pb.P * xn))
    s_new = np.abs(1.0 / (1.0 + pb.P * Kn[None, :]))
    del Kk
    return (cert <= 0) | (s_new > s_lin)


def _step(pb: _Problem, st: _State, f_t: float | None, s_hard: float, s_goal: float | None):
    """One convex step with constraint generation; the new parameters and τ, or None."""
    s_lin = 10 ** (s_hard / 20)
    s_mask, c_mask = _masks(pb, st.theta, f_t, s_lin)
    for _ in range(4):
        data = StepData(
            basis=pb.basis,
            P=pb.P,
            theta_k=st.theta,
            w_s=1.0 / s_lin,
            s_mask=s_mask,
            c_mask=c_mask,
            w_obj_s=None if s_goal is None else 10 ** (-s_goal / 20),
            w_t=None if pb.t_max is None else 10 ** (-pb.t_max / 20),
            tr_idx=pb.tr_idx,
            rho=st.rho,
            floor_idx=pb.floor_idx,
            floor_w=pb.floor_w,
        )
        out = solve_step(data, warm=pb.warm)
        if out is None:
            return None
        bad = _violations(pb, out[0], st.theta, s_lin) & ~s_mask
        if not bad.any():
            return out
        s_mask = s_mask | bad
    return out


def _iterate(
    pb: _Problem,
    st: _State,
    *,
    s_max: float,
    max_iter: int,
    delta: float,
    history: list,
    progress: Callable[[dict], None] | None,
    deadline: float,
) -> _State:
    stall = 0
    for it in range(max_iter):
        if time.perf_counter() > deadline:
            break
        phase1 = st.table.worst_s_peak_db > s_max + 1e-9
        s_hard = max(s_max, st.table.worst_s_peak_db)
        f_k = st.table.min_crossover_hz
        f_t = None if phase1 else f_k * (1 + delta)
        out = _step(pb, st, f_t, s_hard, s_max if phase1 else None)
        if out is None:
            st.rho *= 0.5
            if st.rho < 1e-3:
                break
            continue
        ok, tab = pb.ok(out[0], s_hard)
        gain = tab.min_crossover_hz / f_k - 1.0
        better = (
            (tab.worst_s_peak_db < st.table.worst_s_peak_db - 1e-4) if phase1 else (gain > -1e-6)
        )
        if not (ok and better):
            st.rho *= 0.5
            if st.rho < 1e-3:
                break
            continue
        st = _State(out[0], tab, min(st.rho * 2.0, 0.5))
        entry = {
            "iteration": it,
            "phase": 1 if phase1 else 2,
            "tau": out[1],
            "rho": st.rho,
            **tab.summary(),
        }
        history.append(entry)
        if progress is not None:
            progress(entry)
        stall = stall + 1 if (not phase1 and gain < 1e-3) else 0
        if stall >= 4:
            break
    return st


def _one_blas_thread(func: Callable) -> Callable:
    """Run ``func`` with one BLAS thread: its linear algebra is on small or thin matrices.

    With OpenBLAS's default threads (2 on the machine of issue 24) the hdd-loopshape
    design took 5.1 s of CPU instead of 2.7 s: the threads spin for work on the 3000 x 13
    complex products and 14 x 14 eigenproblems instead of doing it.
    """

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1):
            return func(*args, **kwargs)

    return wrapper


#: decades of the plants' low-frequency asymptote put below the first measured point
ASYMPTOTE_DECADES = 2
#: points per decade of that extension
ASYMPTOTE_POINTS = 12


def _with_asymptote(f: np.ndarray, P: np.ndarray, dt: float, m: int):
    """The grid extended ``ASYMPTOTE_DECADES`` below its first point with each plant's
    asymptote ``g / (z - 1)^m`` (``g`` real, the rule of the stability count), and the
    number of points added (module doc, "Below the grid")."""
    n = ASYMPTOTE_DECADES * ASYMPTOTE_POINTS
    low = f[0] * np.logspace(-ASYMPTOTE_DECADES, 0, n + 1)[:-1]
    z0, z = np.exp(2j * np.pi * f[0] * dt), np.exp(2j * np.pi * low * dt)
    g = asymptote_gain(P[:, 0], z0, m)[0]
    P_low = g[:, None] / (z[None, :] - 1.0) ** m
    return np.concatenate([low, f]), np.hstack([P_low, P]), n


@_one_blas_thread
def loopshape(
    freq_hz: Any,
    responses: Any,
    dt: float,
    *,
    s_max_db: float,
    structure: str | Structure = "pid-notch",
    order: int | None = None,
    notches: tuple[tuple[float, float], ...] | None = None,
    lowpass_hz: tuple[float, ...] = (),
    t_max_db: float | None = None,
    initial: control.TransferFunction | None = None,
    plant_integrators_count: int | None = None,
    keep_low_gain: float | None = 0.9,
    max_iter: int = 60,
    time_limit_s: float = 100.0,
    delta: float = 0.03,
    trust: float = 0.3,
    names: tuple[str, ...] | None = None,
    progress: Callable[[dict], None] | None = None,
) -> LoopshapeResult:
    """Maximise the lowest crossover over a set of FRFs under ``‖S‖∞ ≤ s_max`` (module doc).

    Parameters
    ----------
    freq_hz : array_like
        Common grid [Hz], increasing, from well below crossover up to Nyquist ``0.5/dt``.
    responses : array_like
        Plant FRFs on the grid, shape ``(M, n)`` (discrete-time responses at ``dt``).
    dt : float
        Sampling period [s] of the controller.
    s_max_db : float
        Bound on ``‖S‖∞`` on every FRF [dB].
    structure : {"pid-notch", "order"} or Structure
        Controller structure; ``"pid-notch"`` uses ``notches`` and ``lowpass_hz``,
        ``"order"`` uses ``order``.
    order : int, optional
        Number of states of the ``"order"`` structure.
    notches : tuple of (freq_hz, damping), optional
        Notch poles of ``"pid-notch"``; found from the FRF peaks when omitted.
    lowpass_hz : tuple of float
        Low-pass / lead pole corners of ``"pid-notch"`` [Hz].
    t_max_db : float, optional
        Bound on ``‖T‖∞`` [dB].
    initial : control.TransferFunction, optional
        Stabilising initial controller (discrete, ``dt``) whose denominator divides the
        structure's (``"pid-notch"``) or whose order is at most ``order``; a PID gain scan
        otherwise.
    plant_integrators_count : int, optional
        Plant poles at ``z = 1`` (2 for a rigid body); estimated from the low-frequency
        slope when omitted.
    keep_low_gain : float or None
        Keep ``|L| ≥ keep_low_gain |L_0|`` (``L_0`` the initial loop) on 40 frequencies below
        0.7 x the initial lowest crossover, so that disturbance rejection is not traded for
        crossover; None lets the low-frequency gain fall (to 1).
    max_iter : int
        Largest number of convex steps.
    time_limit_s : float
        Wall time after which no further step starts [s]; the best design so far is
        returned.
    delta : float
        Relative crossover target step of the continuation.
    trust : float
        Initial trust radius ``ρ`` (relative change of ``K`` per step).
    names : tuple of str, optional
        Plant names for the table.
    progress : callable, optional
        Called with each accepted step's history entry.

    Returns
    -------
    LoopshapeResult
        Controller, per-plant tables (initial and final), history.
    """
    f, P, h = check_frf_set(freq_hz, responses, dt)
    s_max = float(check_finite("s_max_db", s_max_db))
    if s_max <= 0:
        raise ServokitValueError(f"s_max_db must be > 0 dB (got {s_max:g})")
    if t_max_db is not None and float(check_finite("t_max_db", t_max_db)) <= 0:
        # |T| -> 1 (0 dB) wherever |L| is large: a bound at or below 0 dB admits no loop
        raise ServokitValueError(f"t_max_db must be > 0 dB (got {float(t_max_db):g})")
    iters = check_count("max_iter", max_iter, lo=0, hi=10_000)
    t0 = time.perf_counter()
    n_pi = (
        plant_integrators(f, P, h)
        if plant_integrators_count is None
        else int(plant_integrators_count)
    )
    notches = notches if notches is not None or structure != "pid-notch" else _peaks(f, P, h, n_pi)
    f, P, n_below = _with_asymptote(f, P, h, n_pi)
    st = _resolve_structure(structure, order, h, notches, lowpass_hz)
    pb = _Problem(f, P, h, st, s_max, t_max_db, n_pi, names, n_below)
    theta0, note = initial_parameters(pb, initial)
    ok, tab0 = pb.ok(theta0, np.inf)
    if not ok:
        stable = tab0.all_stable and all(r.resolved for r in tab0.rows)
        if stable:  # stable, but above the ‖T‖∞ bound: say so, not "unstable"
            t_peak = max(r.t_peak_db for r in tab0.rows)
            raise ServokitValueError(
                f"initial controller's ‖T‖∞ {t_peak:.3f} dB is above t_max_db {t_max_db:g}; "
                "give an initial controller within the bound or raise t_max_db"
            )
        raise ServokitValueError(
            "initial controller does not stabilise every FRF (Nyquist count on the grid); "
            "give a stabilising initial controller"
        )
    if keep_low_gain is not None and not 0 < keep_low_gain <= 1:
        raise ServokitValueError(f"keep_low_gain must be in (0, 1] or None (got {keep_low_gain})")
    pb.set_floor(theta0, tab0.min_crossover_hz, keep_low_gain)
    history: list[dict[str, Any]] = [
        {"iteration": -1, "phase": 0, "tau": 0.0, "rho": trust, **tab0.summary()}
    ]
    state = _iterate(
        pb,
        _State(theta0, tab0, trust),
        s_max=s_max,
        max_iter=iters,
        delta=delta,
        history=history,
        progress=progress,
        deadline=t0 + check_positive("time_limit_s", time_limit_s, "s"),
    )
    notes = [note] if note else []
    if state.table.worst_s_peak_db > s_max + 1e-9:
        notes.append(
            f"s_max_db {s_max:g} not reached: worst ‖S‖∞ {state.table.worst_s_peak_db:.3f} dB"
        )
    return LoopshapeResult(
        controller=st.transfer_function(state.theta, h),
        table=state.table,
        initial_table=tab0,
        history=history,
        structure=st,
        theta=state.theta,
        design_time_s=time.perf_counter() - t0,
        initial_controller=st.transfer_function(theta0, h),
        notes=notes,
    )


def _peaks(f: np.ndarray, P: np.ndarray, dt: float, n_pi: int, n: int = 3):
    """The ``n`` most prominent resonance peaks of the set (mean rigid-body-free magnitude)."""
    from scipy.signal import find_peaks

    rigid = np.abs(np.exp(2j * np.pi * f * dt) - 1.0) ** n_pi
    mag = np.log(np.mean(np.abs(P) * rigid[None, :], axis=0))
    idx, props = find_peaks(mag, prominence=np.log(2.0))
    keep = idx[np.argsort(props["prominences"])[::-1][:n]]
    return tuple((float(f[i]), 0.2) for i in sorted(keep))


def certify_models(
    controller: control.TransferFunction, plants: list, gains: tuple[float, ...] = (1.0,)
) -> np.ndarray:
    """Spectral radius of every closed loop of modal models (exact ZOH + delay) and gains.

    Parameters
    ----------
    controller : control.TransferFunction
        Discrete controller.
    plants : list of ModalPlant
        Models; each is discretised exactly at the controller's ``dt``.
    gains : tuple of float
        Loop-gain factors applied to every plant.

    Returns
    -------
    ndarray
        Shape ``(len(gains), len(plants))``: the largest closed-loop pole modulus (< 1 is
        stable).
    """
    banks = modal_banks(plants, float(controller.dt))
    return certify_banks(controller, banks, len(plants), gains)


@_one_blas_thread
def certify_banks(
    controller: control.TransferFunction,
    banks: Iterable[tuple[np.ndarray, Any]],
    n_plants: int,
    gains: tuple[float, ...] = (1.0,),
) -> np.ndarray:
    """:func:`certify_models` of plants already in plant banks (e.g. from modal arrays).

    Parameters
    ----------
    controller : control.TransferFunction
        Discrete controller.
    banks : iterable of (ndarray, PlantBank)
        Indices into the output columns and the bank of those plants at the controller's
        ``dt``, as :func:`~servokit.feedback.loopshape_problem.modal_banks` yields them.
    n_plants : int
        Number of output columns (every index below it).
    gains : tuple of float
        Loop-gain factors applied to every plant.

    Returns
    -------
    ndarray
        Shape ``(len(gains), n_plants)``: the largest closed-loop pole modulus.
    """
    dt = float(controller.dt)
    k_ss = control.tf2ss(controller)
    Ak, Bk, Ck = (np.asarray(m, dtype=float) for m in (k_ss.A, k_ss.B, k_ss.C))
    Dk = float(np.asarray(k_ss.D).ravel()[0])
    out = np.empty((len(gains), n_plants))
    for idx, bank in banks:
        A, B, C = bank.discrete(dt)  # (V, N, N), (V, N), (N,): modal states, delay line
        n, nk = A.shape[1], Ak.shape[0]
        for i, g in enumerate(gains):
            # u = K e, e = -y, y = g C x:  [[A - g D_K B C, g B C_K], [-B_K C, A_K]]
            Acl = np.empty((idx.size, n + nk, n + nk))
            Acl[:, :n, :n] = A - g * Dk * B[:, :, None] * C[None, None, :]
            Acl[:, :n, n:] = g * B[:, :, None] * Ck[None, :, :]
            Acl[:, n:, :n] = -Bk[None, :, :] * C[None, None, :]
            Acl[:, n:, n:] = Ak[None]
            out[i, idx] = np.max(np.abs(np.linalg.eigvals(Acl)), axis=-1)
    return out
