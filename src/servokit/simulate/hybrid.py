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
response), see :mod:`servokit.simulate._core`.  ``d_in`` is sampled on the fine grid and
held over each fine step; ``dc`` is added exactly.

Variants are processed in chunks sized from a memory budget (``max_memory_mb``), so the
working set stays bounded for 10^5-10^6 variants; :func:`iter_simulate` yields the
chunks and :func:`simulate_metrics` keeps only per-variant metrics, never all
trajectories.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitTypeError,
    ServokitValueError,
    check_finite,
    check_memory,
)
from servokit.models.modal import ModalPlant
from servokit.models.rational import RationalTF, StateSpaceData, as_state_space_data
from servokit.models.tf import require_proper
from servokit.simulate._bank import as_plant_list, bank_for
from servokit.simulate._closed import Loop, run_closed
from servokit.simulate._core import run_chunk
from servokit.simulate.stability import closed_loop, unstable

__all__ = ["SimulationResult", "iter_simulate", "simulate", "simulate_metrics"]

#: Working memory of one chunk of variants [MB] (the outputs of :func:`simulate` come on top).
CHUNK_MEMORY_MB = 256.0

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
    if isinstance(sys, RationalTF | StateSpaceData):  # numpy coefficients: control unloaded
        if sys.dt and abs(sys.dt - dt) <= 1e-9 * dt and sys.ninputs == sys.noutputs == 1:
            return _convert(name, sys)
    elif not isinstance(sys, control.LTI):
        raise ServokitTypeError(f"{name} must be a python-control discrete LTI object")
    if not sys.isdtime() or sys.dt is True or abs(float(sys.dt) - dt) > 1e-9 * dt:
        raise ServokitValueError(
            f"{name} must be discrete with dt = {dt:.6g} s (got dt = {sys.dt}); "
            "discretise it with control.sample_system"
        )
    if sys.ninputs != 1 or sys.noutputs != 1:
        raise ServokitValueError(f"{name} must be single-input single-output")
    key = _content_key(name, sys)
    if key is not None and key in _SS_CACHE:
        return _SS_CACHE[key]
    out = _convert(name, sys)
    if key is not None:
        if len(_SS_CACHE) >= 64:
            _SS_CACHE.clear()
        _SS_CACHE[key] = out
    return out


#: state-space arrays of controllers and filters already converted, by content (issue 24:
#: ``control.ss(tf)`` and the properness check were 17 % of a one-plant closed loop)
_SS_CACHE: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray, float]] = {}


def _content_key(name: str, sys: control.LTI) -> tuple | None:
    """A hashable key of everything the conversion reads, or None (then no caching)."""
    if isinstance(sys, control.TransferFunction):
        parts = (np.asarray(sys.num[0][0], float), np.asarray(sys.den[0][0], float))
    elif isinstance(sys, control.StateSpace):
        parts = tuple(np.asarray(m, float) for m in (sys.A, sys.B, sys.C, sys.D))
    else:
        return None
    return (name, type(sys).__name__, float(sys.dt),
            *((a.shape, a.tobytes()) for a in parts))  # fmt: skip


def _convert(name: str, sys: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Proper SISO ``sys`` as read-only ``(A, B, C, D)`` arrays."""
    require_proper(name, sys)
    # a RationalTF's companion form is scipy's tf2ss, which python-control's ss(tf) uses
    numpy_only = isinstance(sys, RationalTF | StateSpaceData)
    s = as_state_space_data(sys) if numpy_only else control.ss(sys)
    if s.ninputs != 1 or s.noutputs != 1:
        raise ServokitValueError(f"{name} must be single-input single-output")
    arrays = (
        np.array(s.A, float),
        np.array(s.B, float)[:, 0],
        np.array(s.C, float)[0],
    )
    for a in arrays:
        a.flags.writeable = False  # shared through the cache
    return (*arrays, float(np.asarray(s.D)[0, 0]))


@dataclass(frozen=True)
class _Job:
    """A validated simulation request: everything but the plant chunks."""

    plants: list[ModalPlant]
    dt: float
    K: int
    S: int
    u_open: np.ndarray  # (1 or V, Nt)
    dc: np.ndarray | None  # (1 or V, Nt)
    x0: np.ndarray | None  # (1 or V, 2M)
    loop: Loop | None

    @property
    def t(self) -> np.ndarray:
        return self.dt / self.S * np.arange(self.K * self.S)

    def per_variant_bytes(self, n_modes: int) -> float:
        """Working bytes of one variant in :func:`run_chunk` (states, maps, output temps)."""
        S, K, Nt = self.S, self.K, self.K * self.S
        per = n_modes * (S + 1) * 4 + 8 * S * n_modes + 6 * K * n_modes + 3 * Nt
        per += 2 * Nt if self.loop is not None or self.u_open.shape[0] > 1 else 0
        if self.loop is not None:
            # closed-loop states (K x N) and a few stacked N x N matrices; N is the modal
            # order plus the delay line, the filter and the controller (about 2M + 8)
            n = 2 * n_modes + 8 + self.loop.controller[0].shape[0]
            per += 3 * K * n + 4 * n * n
        return 8.0 * per

    def rows(self, arr: np.ndarray | None, lo: int, hi: int) -> np.ndarray | None:
        """Rows lo..hi of a per-variant array, or the shared row itself."""
        if arr is None or arr.shape[0] == 1:
            return arr
        return arr[lo:hi]


def _loop_spec(
    controller: control.LTI | None,
    reference: np.ndarray | Sequence[float] | None,
    multirate: tuple[int, control.LTI] | None,
    dt: float,
    K: int,
    S: int,
) -> Loop | None:
    if controller is None:
        if reference is not None or multirate is not None:
            raise ServokitValueError(
                "reference and multirate need a controller; pass controller=..."
            )
        return None
    ctrl = _ss("controller", controller, dt)
    r = np.zeros(K)
    if reference is not None:
        ref = check_finite("reference", reference)
        if ref.ndim != 1 or ref.size == 0:
            raise ServokitValueError("reference must be a non-empty 1-D array at dt")
        r[: min(K, ref.size)] = ref[:K]
        r[ref.size :] = ref[-1]
    if multirate is None:
        return Loop(ctrl, r)
    m, F = multirate
    if int(m) != m or m < 1 or S % m:
        raise ServokitValueError(
            f"multirate m = {m} must be a positive integer dividing substeps = {S}"
        )
    return Loop(ctrl, r, int(m), _ss("multirate filter", F, dt / int(m)))


#: optional arguments of :func:`simulate` and their defaults (``dt`` and ``n_samples`` are required)
_OPTIONAL = {
    "substeps": 10,
    "feedforward": None,
    "ff_dt": None,
    "controller": None,
    "reference": None,
    "multirate": None,
    "output_disturbance": None,
    "input_disturbance": None,
    "x0": None,
}


def _prepare(plants: ModalPlant | Sequence[ModalPlant], request: dict[str, Any]) -> _Job:
    """Validate a request of :func:`simulate` (its keyword arguments as a dict)."""
    unknown = sorted(set(request) - set(_OPTIONAL) - {"dt", "n_samples"})
    if unknown:
        raise ServokitTypeError(f"simulate got unexpected argument(s) {unknown}")
    for name in ("dt", "n_samples"):
        if name not in request:
            raise ServokitTypeError(f"simulate needs {name}=...")
    r = {**_OPTIONAL, **request}
    dt, n_samples, substeps, x0 = r["dt"], r["n_samples"], r["substeps"], r["x0"]
    feedforward, ff_dt = r["feedforward"], r["ff_dt"]
    input_disturbance, output_disturbance = r["input_disturbance"], r["output_disturbance"]
    plist = as_plant_list(plants)
    dt = float(check_finite("dt", dt))
    if dt <= 0:
        raise ServokitValueError(f"dt must be > 0 seconds (got {dt})")
    for name, val in (("n_samples", n_samples), ("substeps", substeps)):
        if isinstance(val, bool) or not isinstance(val, int | np.integer):
            raise ServokitTypeError(f"{name} must be an integer, got {val!r}")
        if val < 1:
            raise ServokitValueError(f"{name} must be a positive integer (got {val})")
    K, S = int(n_samples), int(substeps)
    h = dt / S
    Nt = K * S
    t = h * np.arange(Nt)
    V = len(plist)
    # Inputs shared by every variant (feedforward, 1-D disturbances) are kept as one row
    # so that the open-loop response is a single large matrix product for all variants.
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
        u_open = u_open + (d_in[:1] if np.all(d_in == d_in[:1]) else d_in)
    dc = None
    if output_disturbance is not None:
        dcv = _eval_signal("output_disturbance", output_disturbance, t, V)
        dc = np.array(dcv[:1] if np.all(dcv == dcv[:1]) else dcv)
    x0a = None
    if x0 is not None:
        n = 2 * max(len(p.modes) for p in plist)
        x0a = check_finite("x0", x0)
        if x0a.shape not in ((n,), (V, n)):
            raise ServokitValueError(f"x0 must have shape ({n},) or ({V}, {n})")
        x0a = x0a.reshape(-1, n)
    loop = _loop_spec(r["controller"], r["reference"], r["multirate"], dt, K, S)
    return _Job(plist, dt, K, S, u_open, dc, x0a, loop)


def _check_stability(job: _Job, A: np.ndarray, offset: int) -> None:
    """Raise if the discrete loop is unstable for any variant of the chunk."""
    bad, rho = unstable(A)
    if bad.size:
        i = int(bad[0])
        name = job.plants[offset + i].name or "plant"
        raise ServokitValueError(
            f"the closed loop of controller and plants[{offset + i}] ({name}) is unstable "
            f"(largest closed-loop pole |z| = {rho[0]:.4g}); redesign the controller or check "
            "the plant gain and units (check_stability=False simulates it anyway)"
        )


def _chunks(job: _Job, budget_mb: float) -> Iterator[tuple[int, int]]:
    """Variant ranges whose working set fits in ``budget_mb`` (at least one variant each)."""
    V = len(job.plants)
    n_modes = max(len(p.modes) for p in job.plants)
    size = max(1, int(budget_mb * 1e6 // job.per_variant_bytes(n_modes)))
    for lo in range(0, V, size):
        yield lo, min(V, lo + size)


def _run(
    job: _Job, lo: int, hi: int, check_stability: bool, samples_only: bool = False
) -> SimulationResult:
    """Simulate variants lo..hi-1 of the job (only at the samples with ``samples_only``)."""
    bank = bank_for(job.plants[lo:hi], job.dt / job.S)
    V, M = bank.shape
    x0 = job.rows(job.x0, lo, hi)
    if x0 is not None:
        x0 = np.broadcast_to(x0, (V, x0.shape[1])).reshape(V, -1, 2)
        x0 = np.pad(x0, ((0, 0), (0, M - x0.shape[1]), (0, 0)))
    dc = job.rows(job.dc, lo, hi)
    S = job.S
    # an unstable loop run with check_stability=False overflows: reported below, not warned
    with np.errstate(over="ignore", invalid="ignore"):
        u_open = job.rows(job.u_open, lo, hi)
        dcs = None if dc is None else dc[:, ::S]
        if job.loop is None:
            y, yd = run_chunk(bank, S, job.K, u_open, x0, dcs, fine=not samples_only)
            u = np.broadcast_to(u_open, (V, job.K * S))
        else:
            cl = closed_loop(bank, job.loop.controller, job.dt, job.loop.multirate)
            if check_stability:
                _check_stability(job, cl.A, lo)
            y, yd, u = run_closed(
                bank, S, job.K, job.loop, cl, u_open, x0, dcs, fine=not samples_only
            )
        yc = yd if samples_only else y if dc is None else y + dc
    if not np.isfinite(yc.sum()):  # a sum is finite iff all terms are (barring ~1e308)
        raise ServokitValueError(
            "the simulated output overflowed (an unstable loop or plant); check the controller"
        )
    t = job.t
    if samples_only:
        return SimulationResult(t=t[::S], yc=yc, td=t[::S], yd=yd, u=u[:, ::S], substeps=1)
    return SimulationResult(t=t, yc=yc, td=t[::S], yd=yd, u=u, substeps=S)


def iter_simulate(
    plants: ModalPlant | Sequence[ModalPlant],
    *,
    check_stability: bool = True,
    max_memory_mb: float | None = None,
    **kwargs: object,
) -> Iterator[tuple[slice, SimulationResult]]:
    """Simulate plant variants chunk by chunk; yields ``(variants, result)`` per chunk.

    Only one chunk's trajectories live at a time, so the memory stays within
    ``max_memory_mb`` (default 256 MB: half for the working set, half for the chunk's
    result) for any number of variants.

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
    check_stability, max_memory_mb
        As in :func:`simulate`.
    **kwargs
        The other arguments of :func:`simulate`.

    Yields
    ------
    (slice, SimulationResult)
        The slice of ``plants`` the chunk holds and its result.
    """
    job = _prepare(plants, kwargs)
    budget = CHUNK_MEMORY_MB if max_memory_mb is None else float(max_memory_mb)
    for lo, hi in _chunks(job, budget / 2):  # half for the working set, half for results
        yield slice(lo, hi), _run(job, lo, hi, check_stability)


def simulate_metrics(
    plants: ModalPlant | Sequence[ModalPlant],
    metric: Callable[[SimulationResult], np.ndarray],
    **kwargs: object,
) -> np.ndarray:
    """Per-variant metrics of a simulation too large to keep: ``metric`` runs on each chunk.

    Parameters
    ----------
    plants : ModalPlant or sequence of ModalPlant
        Variants (any number; they must share one delay).
    metric : callable
        ``metric(result)`` returns an array whose first axis has one entry per variant
        of the chunk ``result`` (a seek time, a peak error...).
    **kwargs
        Arguments of :func:`simulate`, and ``max_memory_mb`` (default 256 MB).

    Returns
    -------
    ndarray
        The chunks' metric arrays concatenated along the first axis (one row per plant).
    """
    parts = []
    for sl, res in iter_simulate(plants, **kwargs):  # type: ignore[arg-type]
        part = np.asarray(metric(res))
        if part.shape[:1] != (sl.stop - sl.start,):
            raise ServokitValueError(
                f"metric must return one value per variant (first axis {sl.stop - sl.start}), "
                f"got shape {part.shape}"
            )
        parts.append(part)
    return np.concatenate(parts, axis=0)


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
    max_memory_mb: float | None = None,
    samples_only: bool = False,
) -> SimulationResult:
    """Simulate plant variants under feedforward and/or digital feedback.

    The whole result is kept: its size (``yc`` and ``u``, ``V x n_samples x substeps``
    doubles) must fit in ``max_memory_mb`` (default 2000 MB); use
    :func:`simulate_metrics` or :func:`iter_simulate` for larger sets.

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
    x0 : array_like, optional
        Initial modal state, shape (2M,) or (V, 2M) in ``ModalPlant.to_statespace`` order.
    check_stability : bool
        With a controller, refuse a loop that is unstable for any variant (closed-loop
        poles of the exact discrete loop, lifted over ``dt`` with a multirate path;
        certified for all variants at once by repeated squaring, eigenvalues only for
        the uncertified ones, see :mod:`servokit.simulate.stability`).  ``False``
        skips the check.
    max_memory_mb : float, optional
        Memory budget [MB] (default 2000): the result must fit in it, and variants are
        simulated in chunks whose working set fits in what remains (at most 256 MB).
    samples_only : bool
        Return the response at the sampling instants only: ``t``, ``yc`` and ``u`` on
        the grid ``td`` (``yc`` is then ``yd``, ``substeps`` of the result 1).  The
        plant is still integrated on the fine grid, but the outputs between the
        samples (a per-period convolution, most of the work after the time loop) are
        not formed; ``yd`` and ``u`` are the same numbers as those of the full result.

    Returns
    -------
    SimulationResult
    """
    request = {k: v for k, v in locals().items() if k in _OPTIONAL or k in ("dt", "n_samples")}
    job = _prepare(plants, request)
    V, Nt = len(job.plants), job.K * job.S
    per_u = job.loop is not None or job.u_open.shape[0] > 1
    out_bytes = 8.0 * V * (Nt * (2 if per_u else 1) + job.K)
    limit = DEFAULT_MAX_MEMORY_MB if max_memory_mb is None else float(max_memory_mb)
    check_memory(
        out_bytes,
        what=f"simulating {V} variants x {Nt} fine steps",
        flag="max_memory_mb (or use simulate_metrics)",
        max_memory_mb=limit,
    )
    budget = min(CHUNK_MEMORY_MB, max(limit - out_bytes / 1e6, 1.0))
    ranges = list(_chunks(job, budget))
    if len(ranges) == 1:
        return _run(job, 0, V, check_stability, samples_only)
    stride = job.S if samples_only else 1  # fine steps between the result's points
    yc, yd = np.empty((V, Nt // stride)), np.empty((V, job.K))
    u = np.empty((V, Nt // stride)) if per_u else None
    for lo, hi in ranges:
        res = _run(job, lo, hi, check_stability, samples_only)
        yc[lo:hi], yd[lo:hi] = res.yc, res.yd
        if u is not None:
            u[lo:hi] = res.u
    u_out = np.broadcast_to(job.u_open[:, ::stride], (V, Nt // stride)) if u is None else u
    t = job.t
    return SimulationResult(
        t=t[::stride], yc=yc, td=t[:: job.S], yd=yd, u=u_out, substeps=job.S // stride
    )
