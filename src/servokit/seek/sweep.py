"""Seek-time sweeps over large Monte-Carlo variation sets, in bounded memory (issue 13).

A feedforward design is evaluated on ``n`` plants drawn from a
:class:`~servokit.models.VariationSet` (10^4-10^5 and more).  The relative changes of all
plants are drawn at once (``n x R`` numbers, exactly those of
:meth:`VariationSet.monte_carlo`), and the plants are built and simulated chunk by chunk,
so that memory is set by the chunk size, not by ``n``.  The chunks run in-process by
default or on Dask (optional extra ``servokit[dask]``) when a ``distributed.Client`` is
given; both paths run the same function on the same chunks and give identical numbers.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._heap import keep_freed_arrays
from servokit.errors import ServokitValueError, check_count, check_memory, check_positive
from servokit.models.variation_arrays import modal_arrays_from_draws
from servokit.models.variations import VariationSet
from servokit.simulate.metrics import readout_substeps, seek_time_of_arrays

__all__ = [
    "SweepResult",
    "chunk_bytes",
    "connect_dask",
    "plan_chunks",
    "sweep_seek_times",
]

#: default bytes one chunk may use (the rest of the limit stays free for the caller):
#: ~800 HDD plants, whose arrays stay in glibc's reused heap (below its 32 MB mmap
#: threshold); 200 MB chunks ran 1.5-2x slower per plant (issue 24)
_CHUNK_BUDGET = 50e6
PERCENTILES = (50.0, 90.0, 99.0, 99.9, 100.0)


@dataclass(frozen=True)
class _Held:
    """Held input samples and their period (picklable, for Dask workers)."""

    u: np.ndarray
    dt: float


@dataclass(frozen=True, eq=False)
class SweepResult:
    """Seek times of a Monte-Carlo sweep.

    Attributes
    ----------
    seek_times : ndarray (n,)
        Seek time per plant [s] (inf: not settled within the record).
    draws, gains : ndarray
        Relative changes of the worst plant (one per range) and its relative gain.
    chunk_size : int
        Plants simulated together.
    chunk_mb : float
        Estimated memory of one chunk [MB].
    backend : str
        ``"numpy"`` (in-process) or ``"dask"``.
    """

    seek_times: np.ndarray
    draws: np.ndarray
    gains: np.ndarray
    chunk_size: int
    chunk_mb: float
    backend: str

    @property
    def worst_index(self) -> int:
        """Index of the plant with the longest seek time."""
        return int(np.argmax(self.seek_times))

    @property
    def n_unsettled(self) -> int:
        """Plants that did not settle within the simulated record."""
        return int(np.sum(~np.isfinite(self.seek_times)))

    def percentiles(self, q: tuple[float, ...] = PERCENTILES) -> dict[str, float]:
        """Seek-time percentiles [s] keyed ``p50``, ``p99_9``, ...; ``inf`` when unsettled
        plants reach that rank (nearest-rank on the sorted times, no interpolation)."""
        t = np.sort(self.seek_times)
        ranks = np.clip(np.ceil(np.asarray(q) / 100.0 * t.size).astype(int) - 1, 0, t.size - 1)
        return {f"p{q_:g}".replace(".", "_"): float(t[r]) for q_, r in zip(q, ranks, strict=True)}


def chunk_bytes(n_plants: int, n_modes: int, n_samples: int, substeps: int) -> float:
    """Estimated peak bytes of simulating ``n_plants`` together (the simulator's arrays:
    outputs and their deviation on the fine grid, sample states, block powers).

    Parameters
    ----------
    n_plants : int
        Plants simulated together.
    n_modes : int
        Modes of each plant.
    n_samples : int
        Held-input samples of the simulated record.
    substeps : int
        Read-out points per sample (``dt / grid``).

    Returns
    -------
    float
        Estimated bytes (8-byte floats).
    """
    fine = n_samples * substeps
    per_plant = 8.0 * (5 * fine + 6 * n_samples * n_modes + 12 * n_modes * (substeps + 1))
    return n_plants * per_plant


def _record(ff: _Held, horizon: float | None) -> int:
    """Samples of the simulated record (as :func:`servokit.simulate.seek_response`)."""
    duration = ff.u.size * ff.dt
    horizon = max(3 * duration, duration + 2e-3) if horizon is None else horizon
    return int(np.ceil(horizon / ff.dt)) + 1


def _chunk_seek_times(
    vset: VariationSet,
    draws: np.ndarray,
    gains: np.ndarray,
    ff: _Held,
    target: float,
    band: float,
    grid: float | None,
    horizon: float | None,
) -> np.ndarray:
    """Seek times of the plants of one chunk (runs in-process or on a Dask worker).

    Draws go straight to modal arrays (no plant objects, issue 24); the numbers are
    those of ``seek_time(vset.from_draws(draws, gains), ...)``.
    """
    modal = modal_arrays_from_draws(vset, draws, gains)
    return seek_time_of_arrays(
        modal, vset.nominal.delay, ff, target, band=band, grid=grid, horizon=horizon
    )


def _chunk_on_worker(vset: VariationSet, rows: tuple, args: tuple, chunk_size: int) -> np.ndarray:
    """One Dask task: its plants in chunks of ``chunk_size`` in a worker process (heap
    tuned first), as :func:`_chunk_seek_times` does in-process. ``rows`` is
    ``(n, seed, lo, hi)`` (rows ``lo:hi`` of ``vset.draw(n, seed)``, drawn here) or
    ``(draws, gains)``."""
    keep_freed_arrays()
    draws, gains = vset.draw_rows(*rows) if len(rows) == 4 else rows
    out = np.empty(draws.shape[0])
    for sl in _chunks(draws.shape[0], chunk_size):
        out[sl] = _chunk_seek_times(vset, draws[sl], gains[sl], *args)
    return out


#: Dask settings of the local cluster :func:`connect_dask` starts (batch work, no
#: dashboard): the periodic callbacks an interactive cluster runs for its dashboard and
#: health checks, made rare.  Measured on one worker at 10^5 plants (``/proc`` thread
#: times, three sweeps per setting, twice): the client process (scheduler, nanny) spent
#: 70-100 ms of CPU per 1.5 s sweep and the worker's event-loop thread 40-50 ms, which
#: holds the GIL the task thread needs; with these settings 20-30 ms and 10-20 ms.
LOCAL_CLUSTER_CONFIG: dict[str, object] = {
    # the statistical profiler samples the task thread's stack every 10 ms for the
    # dashboard (about 1 % of a sweep's time on one worker)
    "distributed.worker.profile.enabled": False,
    # event-loop health check, every 20 ms by default; a loop blocked for longer than
    # ``distributed.admin.tick.limit`` (3 s) is still reported
    "distributed.admin.tick.interval": "1s",
    # CPU / memory / network samples for the dashboard, every 500 ms by default
    "distributed.admin.system-monitor.interval": "5s",
    # spill / pause / terminate checks, every 100 ms by default: a sweep's memory is
    # bounded before it starts (:func:`plan_chunks`), so once a second is enough
    "distributed.worker.memory.monitor-interval": "1s",
}


def connect_dask(scheduler: str | None = None, workers: int | None = None) -> Any:
    """A ``distributed.Client``: to ``scheduler`` (an address) or a local cluster.

    Raises a one-line error naming the optional extra when Dask is not installed.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running Dask scheduler (e.g. ``"tcp://host:8786"``, 10 s connection
        timeout); if omitted, a local cluster is started.
    workers : int, optional
        Single-threaded workers of the local cluster (1 to 256, default 1); ignored with
        ``scheduler``.

    Returns
    -------
    distributed.Client
        The client, to pass as ``client`` to :func:`sweep_seek_times`.

    Raises
    ------
    ServokitValueError
        If ``distributed`` is not installed (extra ``servokit[dask]``) or ``workers`` is
        out of range.
    """
    try:
        from distributed import Client
    except ImportError:
        raise ServokitValueError(
            "the Dask backend needs the optional extra: pip install 'servokit[dask]'"
        ) from None
    if scheduler is not None:
        client = Client(scheduler, timeout="10s")
    else:
        import dask

        n = check_count("workers", 1 if workers is None else workers, lo=1, hi=256)
        # the client starts (and on close() stops) its own LocalCluster
        with dask.config.set(LOCAL_CLUSTER_CONFIG):
            client = Client(n_workers=n, threads_per_worker=1, dashboard_address=None)
    client.run(_ready_worker)  # imports and heap set-up now, not in the first chunk
    return client


def _ready_worker() -> None:
    """Import the simulation kernel and tune the heap in a worker (start-up, once)."""
    from threadpoolctl import threadpool_limits

    import servokit.seek.sweep  # noqa: F401

    keep_freed_arrays()
    # one BLAS thread for the worker's life (Dask's nanny sets this for the workers it
    # spawns; a worker started by hand may not): the parallelism is across tasks
    threadpool_limits(limits=1)


def plan_chunks(
    vset: VariationSet,
    ff: Any,
    n: int,
    *,
    grid: float | None = None,
    horizon: float | None = None,
    chunk_size: int | None = None,
    max_memory_mb: float | None = None,
    n_workers: int = 1,
) -> tuple[int, float]:
    """Chunk size and estimated bytes per plant of a sweep; refuses it, before anything
    is allocated, when the draws plus one chunk per worker exceed ``max_memory_mb``.

    Parameters
    ----------
    vset : VariationSet
        Nominal plant (its number of modes) and ranges (the draws' width).
    ff : object with ``u`` (held samples) and ``dt`` [s]
        The feedforward design; its length and ``horizon`` set the record.
    n : int
        Number of plants of the sweep.
    grid, horizon : float, optional
        Read-out step and record length [s], as in :func:`servokit.simulate.seek_time`
        (defaults ``ff.dt / 10`` and ``max(3 T, T + 2 ms)`` for an input of length ``T``).
    chunk_size : int, optional
        Plants per chunk; by default as many as fit in 50 MB and in the limit left after
        the draws, shared by ``n_workers`` (at most ``ceil(n / (4 n_workers))`` with
        several workers, so that each gets a few chunks).
    max_memory_mb : float, optional
        Limit on the draws, gains and seek times of all plants plus one chunk per worker
        [MB]; 2000 by default.
    n_workers : int
        Chunks simulated at the same time.

    Returns
    -------
    chunk_size : int
        Plants per chunk (at least 1).
    per_plant : float
        Estimated bytes of simulating one plant (:func:`chunk_bytes`).

    Raises
    ------
    ServokitValueError
        If the estimate exceeds ``max_memory_mb``.
    """
    dt = check_positive("ff.dt", ff.dt, "s")
    S = readout_substeps(dt, grid)
    K = _record(_Held(np.asarray(ff.u), dt), horizon)
    per_plant = chunk_bytes(1, len(vset.nominal.modes), K, max(S, 1))
    limit = 2000.0 if max_memory_mb is None else float(max_memory_mb)
    fixed = n * (len(vset.ranges) + 3) * 8.0  # draws, gains and seek times of all plants
    if chunk_size is None:
        budget = min(_CHUNK_BUDGET, (limit * 1e6 - fixed) / n_workers)
        chunk_size = int(max(1, min(n, budget // per_plant)))
        if n_workers > 1:  # a few chunks per worker, so that all of them have work
            chunk_size = min(chunk_size, -(-n // (4 * n_workers)))
    chunk_size = check_count("chunk_size", chunk_size, lo=1)
    check_memory(
        fixed + n_workers * chunk_size * per_plant,
        what=f"a sweep of {n} variants in chunks of {chunk_size} ({K * S} grid points each)",
        max_memory_mb=limit,
    )
    return chunk_size, per_plant


def _chunks(n: int, size: int) -> Iterator[slice]:
    for lo in range(0, n, size):
        yield slice(lo, min(n, lo + size))


def sweep_seek_times(
    vset: VariationSet,
    ff: Any,
    target: float,
    *,
    n: int,
    seed: int = 0,
    band: float = 0.1,
    grid: float | None = None,
    horizon: float | None = None,
    chunk_size: int | None = None,
    max_memory_mb: float | None = None,
    client: Any = None,
    progress: Callable[[int], None] | None = None,
    threads: int = 1,
) -> SweepResult:
    """Seek time of ``ff`` on ``n`` Monte-Carlo plants of ``vset``, chunk by chunk.

    Parameters
    ----------
    vset : VariationSet
        Nominal plant and ranges (e.g. ``hdd_benchmark_variation_set()``); its plants are
        exactly those of ``vset.monte_carlo(n, seed)``.
    ff : object with ``u`` (held samples) and ``dt`` [s]
        The feedforward design (a :class:`~servokit.feedforward.FeedforwardInput`).
    target, band : float
        Seek distance and settling band (plant output units).
    n : int
        Number of plants.
    seed : int
        Random seed of the draws.
    grid, horizon : float, optional
        Read-out step and record length [s], as in :func:`servokit.simulate.seek_time`.
    chunk_size : int, optional
        Plants per chunk; default: as many as fit in 50 MB (and in ``max_memory_mb``).
    max_memory_mb : float, optional
        Limit on the estimated memory of the draws plus one chunk per worker [MB].
    client : distributed.Client, optional
        Run the chunks on Dask (see :func:`connect_dask`); default in-process.
    progress : callable, optional
        Called with the number of plants of each finished chunk.
    threads : int
        In-process: chunks simulated at the same time by threads (numpy releases the
        GIL in the kernel's array operations); one chunk per thread in memory.

    Returns
    -------
    SweepResult
    """
    n = check_count("n", n, lo=1)
    band = check_positive("band", band)
    held = _Held(np.asarray(ff.u, dtype=float), check_positive("ff.dt", ff.dt, "s"))
    threads = check_count("threads", threads, lo=1, hi=256)
    n_workers = threads if client is None else max(1, len(client.scheduler_info()["workers"]))
    chunk_size, per_plant = plan_chunks(
        vset,
        held,
        n,
        grid=grid,
        horizon=horizon,
        chunk_size=chunk_size,
        max_memory_mb=max_memory_mb,
        n_workers=n_workers,
    )
    args = (held, float(target), band, grid, horizon)
    times = np.empty(n)
    tick = progress or (lambda k: None)
    if client is None:
        from threadpoolctl import threadpool_limits

        draws, gains = vset.draw(n, seed)
        # the parallelism is across chunks: BLAS threads on top of it oversubscribe the
        # cores and spin (measured at 10^5 variants on 2 cores: 7.4 -> 3.1 CPU s with
        # one sweep thread, 2.7 -> 1.6 s wall with two)
        keep_freed_arrays()  # 2x in-process as in the workers (3.0 -> 1.5 s at 10^5)
        with threadpool_limits(limits=1):
            _run_local(vset, draws, gains, args, chunk_size, times, tick, threads)
        worst = int(np.argmax(times))
        draw, gain, backend = draws[worst], gains[worst], "numpy"
    else:
        _run_dask(client, vset, (n, seed), args, chunk_size, times, tick, n_workers)
        worst = int(np.argmax(times))
        rows = vset.draw_rows(n, seed, worst, worst + 1)  # the workers drew the plants
        draw, gain, backend = rows[0][0], rows[1][0], "dask"
    return SweepResult(times, draw, gain, chunk_size, chunk_size * per_plant / 1e6, backend)


def _run_local(
    vset: VariationSet, draws: np.ndarray, gains: np.ndarray, args: tuple, chunk_size: int,
    out: np.ndarray, tick: Callable[[int], None], threads: int,
) -> None:  # fmt: skip
    """The chunks in this process, ``threads`` at a time; fill ``out`` in order."""
    slices = list(_chunks(draws.shape[0], chunk_size))

    def one(sl: slice) -> np.ndarray:
        return _chunk_seek_times(vset, draws[sl], gains[sl], *args)

    if threads == 1:
        results: Iterator[np.ndarray] = map(one, slices)
    else:
        from concurrent.futures import ThreadPoolExecutor

        pool = ThreadPoolExecutor(threads)
        results = pool.map(one, slices)  # in order; at most `threads` chunks live
    try:
        for sl, res in zip(slices, results, strict=True):
            out[sl] = res
            tick(sl.stop - sl.start)
    finally:
        if threads > 1:
            pool.shutdown(cancel_futures=True)


#: Largest draws (and gains) one Dask task carries [bytes]: Dask warns about graphs over
#: 10 MB (at 10^6 variants on one worker, four tasks of 12 MB each did).
TASK_BYTES = 4_000_000


def _run_dask(
    client: Any,
    vset: VariationSet,
    sample: tuple[int, int],
    args: tuple,
    chunk_size: int,
    out: np.ndarray,
    tick: Callable[[int], None],
    n_workers: int,
) -> None:
    """Submit about four tasks per worker, each simulating its plants chunk by chunk;
    fill ``out`` as they complete.

    A task per chunk (~800 plants, 0.03-0.1 s) made the scheduler round trips a large
    part of the run on a busy machine; a few tasks per worker keep all of them busy to
    the end, and the chunks inside a task keep the working set (and the memory) of an
    in-process chunk. A task draws its own plants where the draws allow it
    (:meth:`~servokit.models.VariationSet.draw_rows`: the rows of ``draw(n, seed)``
    bit for bit) and otherwise carries them in its graph (up to :data:`TASK_BYTES`, so
    that no graph is the size Dask warns about); scattered draws would be lost with a
    worker that dies, and the sweep with them.
    """
    from distributed import as_completed

    n, seed = sample
    per_variant = (len(vset.ranges) + 1) * np.dtype(float).itemsize  # draws and gain
    task = max(chunk_size, -(-n // (4 * n_workers)))
    task = max(1, min(task, TASK_BYTES // per_variant))
    drawn = None if vset.rows_drawable else vset.draw(n, seed)
    futures = {}
    for sl in _chunks(n, task):
        rows = (n, seed, sl.start, sl.stop) if drawn is None else (drawn[0][sl], drawn[1][sl])
        # the variation set travels in the task (about 1 kB): a scatter would cost a
        # round trip to the scheduler before the first task
        fut = client.submit(_chunk_on_worker, vset, rows, args, chunk_size, pure=False)
        futures[fut] = sl
    # results fetched as the tasks finish, while the worker computes the next ones (one
    # fetch after the last task instead of one after each)
    for fut, result in as_completed(futures, with_results=True):
        sl = futures[fut]
        out[sl] = result
        tick(sl.stop - sl.start)
