"""The hybrid (sampled-data) simulator: continuous modal plants behind holds, digital
controllers, multirate filters and held feedforward inputs, batched over plant variants.

The loop of the book's Figs. 2.5/2.6 (TDOF), 4.1/4.2 (multirate sampled-data loop) and
4.57 (TDOF seek with a multirate feedforward) is::

    u(t)  = H[ F( up_m( C(z) (r[k] - yd[k]) ) ) ](t) + H_ff[u_ff](t) + d_in(t)
    yc(t) = P(s) e^{-s Td} u(t) + dc(t),         yd[k] = yc(k Ts)

with ``H`` a zero-order hold at ``Ts/m`` (``Ts`` without a multirate filter), ``H_ff`` a
zero-order hold at the feedforward period and ``up_m`` the zero-inserting up-sampler.
The plant is integrated exactly (matrix exponential, delay split into whole and
fractional fine steps) on a fine grid ``h = Ts/substeps``; all holds switch on that grid.

The time loop runs once per sampling period ``Ts`` and is vectorised over variants and
modes; the outputs between samples are then produced for all periods at once from the
stored sample states (free response) and a per-period Toeplitz convolution (forced
response).  ``d_in`` is sampled on the fine grid and held over each fine step; ``dc``
is added exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import control
import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite
from servokit.models.controllers import require_proper
from servokit.models.modal import ModalPlant
from servokit.simulate._bank import PlantBank, as_plant_list

__all__ = ["SimulationResult", "simulate"]

Signal = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class SimulationResult:
    """Output of :func:`simulate`.

    Attributes
    ----------
    t : ndarray (Nt,)
        Fine time grid [s], ``Nt = n_samples * substeps``.
    yc : ndarray (V, Nt)
        Continuous output on the fine grid, one row per plant variant.
    td : ndarray (n_samples,)
        Sampling instants [s].
    yd : ndarray (V, n_samples)
        Output at the sampling instants (what the controller sees).
    u : ndarray (V, Nt)
        Plant input before the delay on the fine grid.
    """

    t: np.ndarray
    yc: np.ndarray
    td: np.ndarray
    yd: np.ndarray
    u: np.ndarray
    substeps: int


def _integer_ratio(name: str, period: float, h: float) -> int:
    q = period / h
    qi = int(round(q))
    if qi < 1 or abs(q - qi) > 1e-6 * max(q, 1.0):
        raise ServokitValueError(
            f"{name} ({period:.6g} s) must be an integer multiple of the fine step "
            f"dt/substeps = {h:.6g} s; choose substeps so that it is"
        )
    return qi


def _eval_signal(name: str, f: Signal | np.ndarray, t: np.ndarray, V: int) -> np.ndarray:
    vals = f(t) if callable(f) else f
    arr = check_finite(name, vals)
    if arr.shape not in ((t.size,), (V, t.size)):
        raise ServokitValueError(
            f"{name} must give one value per fine time step (shape ({t.size},) or ({V}, {t.size})),"
            f" got shape {arr.shape}"
        )
    return np.broadcast_to(arr, (V, t.size))


def _ss(name: str, sys: object, dt: float) -> tuple[np.ndarray, ...]:
    if not isinstance(sys, control.LTI):
        raise ServokitTypeError(f"{name} must be a python-control discrete LTI object")
    if not sys.isdtime() or sys.dt is True or abs(float(sys.dt) - dt) > 1e-9 * dt:
        raise ServokitValueError(
            f"{name} must be discrete with dt = {dt:.6g} s (got dt = {sys.dt}); "
            "discretise it with control.sample_system"
        )
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise ServokitValueError(f"{name} must be single-input single-output")
    require_proper(name, sys)
    s = control.ss(sys)
    if s.ninputs != 1 or s.noutputs != 1:
        raise ServokitValueError(f"{name} must be single-input single-output")
    return (
        np.asarray(s.A, float),
        np.asarray(s.B, float)[:, 0],
        np.asarray(s.C, float)[0],
        float(np.asarray(s.D)[0, 0]),
    )


def _check_closed_loop(
    plants: Sequence[ModalPlant],
    controller: control.LTI,
    dt: float,
    multirate: tuple[int, control.LTI] | None,
) -> None:
    """Raise if the discrete loop (plant with delay behind its holds, controller) is unstable.

    With a multirate path the fast series ``P_d(dt/m) F`` driven by the zero-inserted
    controller output is lifted over one period: ``A^m, A^(m-1) B, C, D``.
    """
    for i, p in enumerate(plants):
        if multirate is None:
            g = control.ss(p.discretize(dt))
        else:
            m, F = multirate
            fast = control.ss(p.discretize(dt / m)) * control.ss(F)
            Am1 = np.linalg.matrix_power(fast.A, m - 1)  # m is a small multirate number
            g = control.ss(Am1 @ fast.A, Am1 @ fast.B, fast.C, fast.D, dt)
        poles = control.poles(control.feedback(g * control.ss(controller), 1))
        rho = float(np.max(np.abs(poles))) if poles.size else 0.0
        if rho >= 1.0 - 1e-10:
            raise ServokitValueError(
                f"the closed loop of controller and plants[{i}] ({p.name or 'plant'}) is unstable "
                f"(largest closed-loop pole |z| = {rho:.4g}); redesign the controller or check "
                "the plant gain and units (check_stability=False simulates it anyway)"
            )


def simulate(
    plants: ModalPlant | Sequence[ModalPlant],
    *,
    dt: float,
    n_samples: int,
    substeps: int = 10,
    feedforward: np.ndarray | Sequence[float] | None = None,
    ff_dt: float | None = None,
    controller: control.LTI | None = None,
    reference: np.ndarray | Sequence[float] | None = None,
    multirate: tuple[int, control.LTI] | None = None,
    output_disturbance: Signal | np.ndarray | None = None,
    input_disturbance: Signal | np.ndarray | None = None,
    x0: np.ndarray | None = None,
    check_stability: bool = True,
) -> SimulationResult:
    """Simulate plant variants under feedforward and/or digital feedback.

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Variants run together (vectorised); they must share one delay.
    dt : float
        Sampling period Ts of the controller (and base period) [s].
    n_samples : int
        Number of sampling periods to simulate.
    substeps : int
        Fine steps per sampling period; ``yc`` is returned on the grid ``dt/substeps``.
    feedforward : array_like, optional
        Feedforward samples, each held for ``ff_dt`` from ``t = 0``; zero afterwards.
    ff_dt : float, optional
        Hold period of the feedforward (default ``dt``), a multiple of ``dt/substeps``
        (multirate feedforward, Fig. 4.57).
    controller : python-control LTI, optional
        Discrete controller with ``dt``: ``u_fb = C(z) (r - yd)``.
    reference : array_like, optional
        Reference ``r[k]`` at the sampling instants (e.g. the TDOF model output);
        padded with its last value.
    multirate : (int, python-control LTI), optional
        ``(m, F)``: controller output up-sampled by ``m`` with zero insertion, filtered by
        ``F`` (discrete, ``dt/m``; include the interpolation filter of eq. 4.67 in it) and
        held at ``dt/m``.  ``m`` must divide ``substeps``.
    output_disturbance, input_disturbance : callable or array, optional
        ``dc(t)`` added to the output (exactly) and ``d(t)`` added to the plant input
        (held on the fine grid), evaluated on the fine grid.
    check_stability : bool
        With a controller, refuse a loop that is unstable for any variant (closed-loop
        poles of the exact discrete loop, lifted over ``dt`` with a multirate path).
    x0 : array_like, optional
        Initial modal state, shape (2M,) or (V, 2M) in ``ModalPlant.to_statespace`` order.

    Returns
    -------
    SimulationResult
    """
    plist = as_plant_list(plants)
    dt = float(check_finite("dt", dt))
    if dt <= 0:
        raise ServokitValueError(f"dt must be > 0 seconds (got {dt})")
    if isinstance(n_samples, bool) or not isinstance(n_samples, int | np.integer):
        raise ServokitTypeError(f"n_samples must be an integer, got {n_samples!r}")
    if isinstance(substeps, bool) or not isinstance(substeps, int | np.integer):
        raise ServokitTypeError(f"substeps must be an integer, got {substeps!r}")
    if int(n_samples) != n_samples or n_samples < 1:
        raise ServokitValueError(f"n_samples must be a positive integer (got {n_samples})")
    if int(substeps) != substeps or substeps < 1:
        raise ServokitValueError(f"substeps must be a positive integer (got {substeps})")
    K, S = int(n_samples), int(substeps)
    h = dt / S
    Nt = K * S
    t = h * np.arange(Nt)
    V = len(plist)

    # Inputs shared by every variant (feedforward, 1-D disturbances) are kept as one row
    # so that the open-loop response is a single large matrix product for all variants.
    Vu = 1 if controller is None else V
    u_open = np.zeros((1, Nt))
    if feedforward is not None:
        ff = check_finite("feedforward", feedforward)
        if ff.ndim != 1:
            raise ServokitValueError("feedforward must be a 1-D array of held samples")
        q = _integer_ratio("ff_dt", dt if ff_dt is None else float(ff_dt), h)
        fine = np.repeat(ff, q)[:Nt]
        u_open[:, : fine.size] += fine
    if input_disturbance is not None:
        d_in = _eval_signal("input_disturbance", input_disturbance, t, V)
        if not np.all(d_in == d_in[:1]):
            Vu = V
        u_open = u_open + (d_in if Vu == V else d_in[:1])
    dc = np.zeros((V, Nt))
    if output_disturbance is not None:
        dc = dc + _eval_signal("output_disturbance", output_disturbance, t, V)

    bank = PlantBank.build(plist, h)
    M = bank.shape[1]
    P = bank.powers(S)  # (V, M, S+1, 2, 2)
    x = np.zeros((V, M, 2))
    if x0 is not None:
        x0a = check_finite("x0", x0)
        if x0a.shape not in ((2 * M,), (V, 2 * M)):
            raise ServokitValueError(f"x0 must have shape ({2 * M},) or ({V}, {2 * M})")
        x = np.broadcast_to(x0a, (V, 2 * M)).reshape(V, M, 2).copy()

    # B2[v, s, :]: contribution of the new (s < S) / old (s >= S) input at fine step s of
    # a block to the modal state (flattened to 2M) at the block's end
    back = P[:, :, S - 1 :: -1] if S > 1 else P[:, :, :1]
    B2 = (
        np.concatenate(
            [back @ bank.Gnew[:, :, None, :, None], back @ bank.Gold[:, :, None, :, None]], axis=2
        )[..., 0]
        .transpose(0, 2, 1, 3)
        .reshape(V, 2 * S, 2 * M)
    )
    PS = P[:, :, S]

    # u_j sits at ubuf[:, j + dd + 1]; the plant sees u[j-dd] (new) and u[j-dd-1] (old)
    dd = bank.dd
    ubuf = np.zeros((Vu, Nt + dd + 1))
    ubuf[:, dd + 1 :] = u_open

    def windows(lo: int, hi: int) -> np.ndarray:
        """Delayed inputs of blocks lo..hi-1 as (Vu, hi-lo, 2S): new then old."""
        w_new = ubuf[:, lo * S + 1 : hi * S + 1].reshape(Vu, hi - lo, S)
        w_old = ubuf[:, lo * S : hi * S].reshape(Vu, hi - lo, S)
        return np.concatenate([w_new, w_old], axis=2)

    def apply(W: np.ndarray, mats: np.ndarray) -> np.ndarray:
        """(Vu, n, 2S) inputs times per-variant (V, 2S, q) maps -> (V, n, q)."""
        if W.shape[0] == 1:  # one shared input: a single GEMM over all variants
            q = mats.shape[2]
            flat = W[0] @ mats.transpose(1, 0, 2).reshape(2 * S, V * q)
            return flat.reshape(W.shape[1], V, q).transpose(1, 0, 2)
        return W @ mats

    xs = np.empty((V, K, M, 2))
    yd = np.empty((V, K))

    loop = False
    if controller is not None:
        Ac, Bc, Cc, Dc = _ss("controller", controller, dt)
        xc = np.zeros((V, Ac.shape[0]))
        r = np.zeros(K)
        if reference is not None:
            ref = check_finite("reference", reference)
            if ref.ndim != 1 or ref.size == 0:
                raise ServokitValueError("reference must be a non-empty 1-D array at dt")
            r[: min(K, ref.size)] = ref[:K]
            r[ref.size :] = ref[-1]
        m = 1
        filt = None
        if multirate is not None:
            m, F = multirate
            if int(m) != m or m < 1 or S % m:
                raise ServokitValueError(
                    f"multirate m = {m} must be a positive integer dividing substeps = {S}"
                )
            m = int(m)
            filt = _ss("multirate filter", F, dt / m)
            xf = np.zeros((V, filt[0].shape[0]))
        loop = True
        if check_stability:
            _check_closed_loop(plist, controller, dt, None if filt is None else (m, F))
    elif reference is not None or multirate is not None:
        raise ServokitValueError("reference and multirate need a controller; pass controller=...")

    # an unstable loop run with check_stability=False overflows: reported below, not warned
    with np.errstate(over="ignore", invalid="ignore"):
        open_drive = None if loop else apply(windows(0, K), B2).reshape(V, K, M, 2)
        for k in range(K):
            xs[:, k] = x
            yk = x[..., 0].sum(axis=-1) + dc[:, k * S]
            yd[:, k] = yk
            if loop:
                e = r[k] - yk
                ufb = xc @ Cc + Dc * e
                xc = xc @ Ac.T + e[:, None] * Bc
                if filt is None:
                    fb = np.repeat(ufb[:, None], S, axis=1)
                else:
                    Af, Bf, Cf, Df = filt
                    sub = np.empty((V, m))
                    inp = ufb  # zero insertion: only the first sub-sample carries the value
                    for i in range(m):
                        sub[:, i] = xf @ Cf + Df * inp
                        xf = xf @ Af.T + inp[:, None] * Bf
                        inp = np.zeros(V)
                    fb = np.repeat(sub, S // m, axis=1)
                ubuf[:, dd + 1 + k * S : dd + 1 + (k + 1) * S] += fb
                inc = (windows(k, k + 1) @ B2).reshape(V, M, 2)
            else:
                inc = open_drive[:, k]
            x = (PS @ x[..., None])[..., 0] + inc

        # outputs between the samples: free response of the stored states + forced response
        CP = P[:, :, :S, 0, :]  # (V, M, S, 2): first row of Phi^i
        y = xs.reshape(V, K, 2 * M) @ CP.transpose(0, 1, 3, 2).reshape(V, 2 * M, S)
        # impulse responses C Phi^l G (l = 0..S-1) summed over modes
        H2 = np.concatenate(
            [np.einsum("vmlc,vmc->vl", CP, bank.Gnew), np.einsum("vmlc,vmc->vl", CP, bank.Gold)],
            axis=1,
        )  # (V, 2S)
        idx = np.arange(S)
        W = np.concatenate([np.zeros((Vu, K, 1)), windows(0, K)], axis=2)  # leading zero pad
        if Vu == 1:
            # shared input: its per-block Toeplitz Wt[l, k, i] = w[k, i-1-l] is built once
            lag = np.clip(idx[None, :] - idx[:, None], 0, None)  # [l, i] -> i - l (0 = pad)
            Wt_new = W[0][:, lag].transpose(1, 0, 2)  # (S, K, S)
            Wt_old = W[0][:, S + lag].transpose(1, 0, 2)
            Wt_old[(lag == 0)[:, None, :].repeat(K, axis=1)] = 0.0
            Wt = np.concatenate([Wt_new, Wt_old], axis=0).reshape(2 * S, K * S)
            y += (H2 @ Wt).reshape(V, K, S)
        else:
            lag = np.clip(idx[:, None] - idx[None, :], 0, None)  # [i, j] -> i - j (0 if i <= j)
            Hp = np.concatenate([np.zeros((V, 1)), H2[:, :S], np.zeros((V, 1)), H2[:, S:]], axis=1)
            T2 = np.concatenate([Hp[:, lag.T], Hp[:, S + 1 + lag.T]], axis=1)  # (V, 2S, S)
            y += W[:, :, 1:] @ T2
        yc = y.reshape(V, Nt) + dc
    if not np.all(np.isfinite(yc)):
        raise ServokitValueError(
            "the simulated output overflowed (an unstable loop or plant); check the controller"
        )
    u = np.broadcast_to(ubuf[:, dd + 1 :], (V, Nt))
    return SimulationResult(t=t, yc=yc, td=t[::S], yd=yd, u=u, substeps=S)
