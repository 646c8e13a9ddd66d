"""``servokit sweep``: seek-time distribution of a feedforward design over a large
Monte-Carlo variation set (Table 2.3 ranges), in bounded memory, in-process or on Dask.

Flags -> :func:`sweep_job` (the checked set, design and limits; a design method builds its
:class:`~servokit.seek.SeekRequest` through the seek builder) ->
:func:`servokit.seek.sweep_seek_times` -> :func:`render_sweep`.
"""

from __future__ import annotations

import dataclasses
import math
import time
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlotOpt,
    SettleBandOpt,
    VariationsOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_plant,
    load_variations,
    progress,
    quiet_children,
    wrote,
)
from servokit.cli._options import (
    DelayOpt,
    Output,
    SlewMaxOpt,
    TargetOpt,
    given_on_command_line,
    refuse_inapplicable,
    u_max_option,
)
from servokit.cli._render import ms
from servokit.cli._requests import SEEK_FLAGS, SeekFlags, check_method, check_target, seek_job
from servokit.errors import ServokitValueError, check_count, check_memory, check_positive


@dataclasses.dataclass(frozen=True)
class _Design:
    u: np.ndarray
    dt: float
    source: str
    target: float | None = None  # the distance a --design file's input was designed for


@dataclasses.dataclass(frozen=True)
class SweepFlags:
    """The flags of ``servokit sweep`` as typed."""

    design: Path | None
    plant: str | None
    method: str
    tracks: float
    n_samples: int | None
    u_max: float | None
    slew_max: float | None
    settle_band: float
    n_variants: int
    seed: int | None
    variations: Path | None
    gain_range: bool
    delay: bool
    chunk_size: int | None
    scheduler: str | None
    workers: int | None
    max_memory_mb: float
    plot: Path | None
    json_out: bool


@dataclasses.dataclass(frozen=True)
class SweepJob:
    """A checked sweep: the plant set, the applied input and the run's sizes."""

    vset: Any
    design: _Design
    actuator: Any
    n_clipped: int
    n: int
    seed: int
    target: float
    band: float
    chunk_size: int | None
    max_memory_mb: float
    output: Output
    variations: Path | None


def _from_file(path: Path) -> _Design:
    """Held samples from a ``servokit seek --json`` output (``input`` and ``dt_s``/``dt``),
    with the seek distance it was designed for (``target_out``)."""
    from servokit.export.designs import read_seek_design

    u, dt, target = read_seek_design(path, "--design")
    return _Design(u, dt, str(path), target)


def _seek_distance(f: SweepFlags, d: _Design) -> float:
    """``--target``, else the ``--design`` file's ``target_out``; the two must agree (an
    input designed for one distance never settles at another)."""
    if d.target is None:
        return check_target(f.tracks)
    # relative only: a nanometre seek in metres is as much a distance as a 100 um one
    if given_on_command_line("tracks") and not math.isclose(f.tracks, d.target, rel_tol=1e-9):
        raise ServokitValueError(
            f"--target {f.tracks:g} differs from target_out {d.target:g} of --design "
            f"{f.design} (the input was designed for {d.target:g}); drop --target"
        )
    return check_target(d.target)


def _from_method(f: SweepFlags) -> _Design:
    """Design on the 18 plants of Table 2.3 as ``servokit seek`` does (its request builder),
    searching N over :func:`~servokit.seek.search_range` of the seek distance."""
    from servokit.seek import design_seek, search_range

    robust = f.method == "robust"
    flags = SeekFlags(
        target=f.tracks, method=f.method, settle_band=f.settle_band, delay=f.delay,
        n_samples="auto" if f.n_samples is None else str(f.n_samples),
        max_memory_mb=f.max_memory_mb, u_max=f.u_max if robust else None,
    )  # fmt: skip
    job = seek_job(flags, inapplicable={})
    with flag_names(SEEK_FLAGS):
        request = dataclasses.replace(
            job.request, N_range=search_range(f.tracks), N_max=None, design_plant=None
        )
        ff = design_seek(request).ff
    if robust:
        return _Design(ff.u, ff.dt, f"robust LP (N = {ff.N})")
    return _Design(ff.u, ff.dt, f"{f.method.upper()} (N = {ff.N})")


def _check_design_args(f: SweepFlags) -> None:
    """Refuse bad design flags before the plant set is read or the design starts."""
    if f.design is not None:  # the design comes from the file: its flags would be ignored
        for name, flag in (("method", "--method"), ("n_samples", "--n-samples")):
            if given_on_command_line(name):
                raise ServokitValueError(f"{flag} does not apply with --design FILE; drop it")
        return
    check_method(f.method)
    refuse_inapplicable("--method", f.method, {"u_max": ("--u-max", ("robust",))})
    if f.n_samples is not None:
        n_s = check_count("--n-samples", f.n_samples, lo=1)
        # the design solves for N samples against an N x N (and larger) system
        check_memory(8.0 * 4 * n_s**2, what=f"--n-samples {n_s}", max_memory_mb=f.max_memory_mb)
    if f.method == "robust" and f.u_max is None:
        raise ServokitValueError("--method robust needs --u-max [plant input unit]")


def _histogram(times: np.ndarray, pct: dict[str, float], title: str, path: Path) -> Path:
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    fig, ax = plt.subplots(figsize=(9.5, 4.5))
    finite = times[np.isfinite(times)] * 1e3
    # seek times are read on a grid: one bar per grid step when they span few steps
    steps = np.unique(finite)
    h = float(np.min(np.diff(steps))) if steps.size > 1 else 1.0
    n_bars = (steps[-1] - steps[0]) / h if steps.size > 1 else 1
    bins = np.arange(steps[0] - h / 2, steps[-1] + h, h) if n_bars <= 200 else 60
    ax.hist(finite, bins=bins, color="C0", alpha=0.8, label=f"{finite.size} settled plants")
    for (key, val), color in zip(pct.items(), ("C1", "C2", "C3", "C4", "k"), strict=False):
        if np.isfinite(val):
            label = f"{key.replace('_', '.')} = {val * 1e3:.4f} ms"  # p99_9 -> p99.9
            ax.axvline(val * 1e3, color=color, ls="--", lw=1, label=label)
    ax.set(xlabel="Seek time [ms]", ylabel="Plants", title=title)
    ax.grid(alpha=0.3)
    # beside the axes: the percentile lines cross every height, no corner is free
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    save_figure(fig, path)
    return path


def _client(scheduler: str | None, workers: int | None) -> Any:
    from servokit.seek.sweep import connect_dask

    if scheduler is None and workers is None:
        return None
    if scheduler is not None and workers is not None:
        raise ServokitValueError("give --scheduler ADDRESS or --workers N, not both")
    with quiet_children():
        return connect_dask(
            scheduler, None if workers is None else check_count("--workers", workers)
        )


def _actuator(u_max: float | None, slew_max: float | None) -> Any:
    """The checked --u-max/--slew-max limits, or None without either."""
    from servokit.simulate.saturation import Actuator

    if u_max is None and slew_max is None:
        return None
    if u_max is not None:
        check_positive("--u-max", u_max)
    if slew_max is not None:
        check_positive("--slew-max", slew_max)
    return Actuator(np.inf if u_max is None else u_max, slew_max, anti_windup=False)


def _applied(d: _Design, actuator: Any) -> tuple[_Design, int]:
    """The design's input as the actuator applies it, and the count of changed samples."""
    from servokit.simulate.saturation import limit_input

    if actuator is None:
        return d, 0
    u, n_clipped = limit_input(d.u, actuator)
    return (_Design(u, d.dt, f"{d.source}, limited", d.target) if n_clipped else d), n_clipped


def _design_info(d: _Design, actuator: Any, n_clipped: int) -> dict[str, Any]:
    """The JSON ``design`` object: the applied input and the limits that made it."""
    slew = None if actuator is None else actuator.slew_max
    u_max = None if actuator is None or np.isinf(actuator.u_max) else actuator.u_max
    return {"source": d.source, "n_samples": int(d.u.size), "dt_s": d.dt,
            "peak_input": float(np.abs(d.u).max()), "u_max": u_max, "slew_max": slew,
            "n_clipped": n_clipped}  # fmt: skip


def _plant_set(f: SweepFlags) -> tuple[Any, int]:
    """The variation set drawn from (Table 2.3 box or ``--variations``) and the seed."""
    from servokit.models import hdd_benchmark_variation_set, without_delay

    if f.plant is not None and f.variations is None:
        raise ServokitValueError("--plant applies only with --variations FILE; drop it")
    if f.variations is not None:
        nominal = None if f.plant is None else load_plant(f.plant)
        vset = load_variations(f.variations, fallback=nominal)
        if f.design is None and vset.nominal.name != "hdd-benchmark":
            raise ServokitValueError(
                f"--variations {f.variations}: the design methods use the HDD benchmark; for "
                f"plant {vset.nominal.name!r} give --design FILE (from servokit seek --json)"
            )
    else:
        vset = hdd_benchmark_variation_set()
        if not f.gain_range:
            vset = dataclasses.replace(vset, gain=(0.0, 0.0))
    seed = vset.seed if f.seed is None else f.seed
    if not f.delay:
        vset = dataclasses.replace(vset, nominal=without_delay(vset.nominal)[0])
    return vset, seed


def sweep_job(f: SweepFlags) -> SweepJob:
    """``servokit sweep``'s flags -> the checked plant set, applied input and sizes.

    Parameters
    ----------
    f : SweepFlags
        The flags as typed.

    Returns
    -------
    SweepJob
        Everything :func:`~servokit.seek.sweep_seek_times` needs; the chunk plan is
        checked against ``--max-memory-mb`` before any plant is simulated.
    """
    from servokit.seek.sweep import plan_chunks

    output = Output.checked(f.plot, f.json_out)
    n = check_count("--n-variants", f.n_variants, lo=1)
    band = check_positive("--settle-band", f.settle_band)
    if f.chunk_size is not None:
        check_count("--chunk-size", f.chunk_size, lo=1)
    if f.design is None:
        check_target(f.tracks)
    _check_design_args(f)
    actuator = _actuator(f.u_max, f.slew_max)  # clips any design, the file's too
    if f.seed is not None and f.seed < 0:
        raise ServokitValueError(f"--seed must be >= 0 (got {f.seed})")
    vset, seed = _plant_set(f)
    d, n_clipped = _applied(_from_file(f.design) if f.design else _from_method(f), actuator)
    target = _seek_distance(f, d)
    chunks = f"--n-variants {n}, --chunk-size {f.chunk_size if f.chunk_size else 'auto'}: "
    with flag_names({}, prefix=chunks):  # refuse early, naming the flags that set the size
        plan_chunks(vset, d, n, chunk_size=f.chunk_size, max_memory_mb=f.max_memory_mb)
    return SweepJob(vset, d, actuator, n_clipped, n, seed, target, band, f.chunk_size,
                    f.max_memory_mb, output, f.variations)  # fmt: skip


UMaxOpt = u_max_option(
    "the robust design respects it; any other design is clipped at it before the sweep"
)
SweepPlantOpt = Annotated[
    str | None,
    typer.Option(
        "--plant",
        help="nominal plant of a --variations file that names none (catalogue name or .toml)",
        metavar="NAME_OR_TOML",
    ),
]
DesignOpt = Annotated[
    Path | None,
    typer.Option(
        "--design", help="JSON of `servokit seek --json` (input, dt_s) to evaluate", metavar="FILE"
    ),
]
MethodOpt = Annotated[
    str,
    typer.Option(
        "--method",
        help="without --design: 'fsc', 'ffsc' (Table 2.4) or 'robust' design on the 18 plants "
        "of Table 2.3",
    ),
]
NSamplesOpt = Annotated[
    int | None,
    typer.Option("--n-samples", help="step number N of the design [count] (default: searched)"),
]
NVariantsOpt = Annotated[
    int, typer.Option("--n-variants", help="Monte-Carlo plants drawn from Table 2.3 [count]")
]
SeedOpt = Annotated[
    int | None,
    typer.Option("--seed", help="random seed (default: the variation file's seed, else 0)"),
]
GainRangeOpt = Annotated[
    bool,
    typer.Option(
        "--gain-range/--no-gain-range",
        help="Table 2.3 box: also draw the +-10 % loop gain (an open-loop seek cannot absorb "
        "it); a --variations file's gain_rel is always drawn",
    ),
]
ChunkSizeOpt = Annotated[
    int | None,
    typer.Option("--chunk-size", help="plants simulated together [count] (default: fits 50 MB)"),
]
SchedulerOpt = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        help="run the chunks on this Dask scheduler (needs servokit[dask])",
        metavar="ADDRESS",
    ),
]
WorkersOpt = Annotated[
    int | None,
    typer.Option("--workers", help="run the chunks on a local Dask cluster of N workers [count]"),
]


@app.command(
    "sweep",
    epilog=example(
        "servokit sweep --method ffsc --tracks 1 --n-variants 100000 --plot sweep.png",
        "servokit seek --json > d.json; servokit sweep --design d.json --workers 2 --json",
    ),
)
def sweep_cmd(
    design: DesignOpt = None,
    plant: SweepPlantOpt = None,
    method: MethodOpt = "ffsc",
    tracks: TargetOpt = 1.0,
    n_samples: NSamplesOpt = None,
    u_max: UMaxOpt = None,
    slew_max: SlewMaxOpt = None,
    settle_band: SettleBandOpt = 0.1,
    n_variants: NVariantsOpt = 10_000,
    seed: SeedOpt = None,
    variations: VariationsOpt = None,
    gain_range: GainRangeOpt = False,
    delay: DelayOpt = True,
    chunk_size: ChunkSizeOpt = None,
    scheduler: SchedulerOpt = None,
    workers: WorkersOpt = None,
    max_memory_mb: MaxMemoryOpt = 2000.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Seek-time distribution of a feedforward design over a Monte-Carlo set of HDD
    benchmark plants (Table 2.3 ranges), chunk by chunk in bounded memory.

    Percentiles are nearest-rank over all plants; unsettled plants count as inf.

    --variations FILE draws the plants from a variation file instead of the Table 2.3 box;
    its nominal is the file's plant, else --plant.

    --design FILE: the seek distance is the file's target_out (a --target must agree).

    --u-max / --slew-max: the held input is clipped (then rate-limited) as the actuator
    would apply it, and the sweep runs on the applied input; design.n_clipped counts the
    samples changed.

    JSON keys: n_variants, seed, variations, backend, chunk_size, chunk_memory_mb (estimate),
    design {source, n_samples, dt_s, peak_input, u_max, slew_max, n_clipped}, target_out,
    settle_band_out, mean_s, percentiles_s {p50, p90, p99, p99_9, p100}, worst_index,
    worst_seek_time_s, worst_plant (name), worst_plant_detail {modes [{freq_hz, damping,
    residue}], gain}, n_unsettled, elapsed_s, plot.
    """
    job = sweep_job(SweepFlags(**locals()))  # first: locals() are the flags
    from servokit.seek.sweep import sweep_seek_times

    client = _client(scheduler, workers)
    t0 = time.perf_counter()
    try:
        with progress(job.n, f"sweep of {job.n} plants", enabled=job.n > 2000) as tick:
            res = sweep_seek_times(
                job.vset, job.design, job.target, n=job.n, seed=job.seed, band=job.band,
                chunk_size=job.chunk_size, max_memory_mb=job.max_memory_mb, client=client,
                progress=tick,
            )  # fmt: skip
    finally:
        if client is not None:
            client.close()
    render_sweep(job, res, time.perf_counter() - t0)


def render_sweep(job: SweepJob, res: Any, elapsed: float) -> None:
    """Plot, print or emit the JSON of a sweep.

    Parameters
    ----------
    job : SweepJob
        The checked sweep.
    res : servokit.seek.SweepResult
        Its seek times.
    elapsed : float
        Wall time of the sweep [s].
    """
    d, vset, n, plot = job.design, job.vset, job.n, job.output.plot
    pct = res.percentiles()
    if plot is not None:
        _histogram(
            res.seek_times,
            pct,
            f"{d.source}: seek times of {n} Monte-Carlo plants\n({vset.name or 'variation set'}"
            f"{'; beyond the book, cf. Figs. 2.18-2.21' if job.variations is None else ''})",
            plot,
        )
        wrote(plot)
    data = _result(job, res, pct, elapsed)
    if job.output.json_out:
        emit_json(data)
        return
    console.print(
        f"{d.source}: {n} plants ({res.backend}, chunks of {res.chunk_size}, ~"
        f"{res.chunk_mb:.0f} MB each) in {elapsed:.1f} s; seek time p50 {ms(pct['p50'], 5)}"
        f", p99 {ms(pct['p99'], 5)}, worst {ms(data['worst_seek_time_s'], 5)} "
        f"(plant {res.worst_index}); {res.n_unsettled} unsettled"
        + (f"; input limited at {job.n_clipped} sample(s)" if job.actuator is not None else "")
    )


def _result(job: SweepJob, res: Any, pct: dict, elapsed: float) -> dict:
    """The JSON of a sweep (keys in the command's help)."""
    vset = job.vset
    worst = vset.from_draws(res.draws, res.gains)[0]  # draws: the worst plant's
    return {
        "n_variants": job.n,
        "seed": job.seed,
        "variations": vset.name,
        "backend": res.backend,
        "chunk_size": res.chunk_size,
        "chunk_memory_mb": res.chunk_mb,
        "design": _design_info(job.design, job.actuator, job.n_clipped),
        "target_out": job.target,
        "settle_band_out": job.band,
        "mean_s": float(np.mean(res.seek_times)),
        "percentiles_s": pct,
        "worst_index": res.worst_index,
        "worst_seek_time_s": float(res.seek_times[res.worst_index]),
        # one name per concept: the worst plant is a name (as in seek), its data beside it
        "worst_plant": f"{vset.name or vset.nominal.name} #{res.worst_index}",
        "worst_plant_detail": {
            "modes": [dataclasses.asdict(m) for m in worst.modes],
            "gain": worst.gain,
        },
        "n_unsettled": res.n_unsettled,
        "elapsed_s": elapsed,
        "plot": str(plot) if (plot := job.output.plot) else None,
    }
