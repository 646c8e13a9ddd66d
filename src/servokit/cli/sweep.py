"""``servokit sweep``: seek-time distribution of a feedforward design over a large
Monte-Carlo variation set (Table 2.3 ranges), in bounded memory, in-process or on Dask."""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlotOpt,
    VariationsOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_variations,
    plot_target,
    progress,
    quiet_children,
    wrote,
)
from servokit.cli._options import given_on_command_line, refuse_inapplicable
from servokit.errors import (
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
)


@dataclasses.dataclass(frozen=True)
class _Design:
    u: np.ndarray
    dt: float
    source: str


def _from_file(path: Path) -> _Design:
    """Held samples from a ``servokit seek --json`` output (``input`` and ``dt_s``/``dt``)."""
    from servokit.export.designs import read_seek_json

    u, dt = read_seek_json(path, "--design")
    return _Design(u, dt, str(path))


def _from_method(
    method: str,
    tracks: float,
    n_samples: int | None,
    u_max: float | None,
    band: float,
    delay: bool,
) -> _Design:
    """Design on the 18 plants of Table 2.3 as ``servokit seek`` does."""
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark_variants
    from servokit.seek import SeekRequest, design_seek, search_range, table_2_4_weights

    if method == "robust" and u_max is None:
        raise ServokitValueError("--method robust needs --u-max [plant input unit]")
    if method not in ("fsc", "ffsc", "robust"):
        raise ServokitValueError(f"--method must be 'fsc', 'ffsc' or 'robust', got {method!r}")
    with flag_names({"u_max": "--u-max", "N": "--n-samples", "band": "--settle-band"}):
        request = SeekRequest(
            hdd_benchmark_variants(),
            HDD_BENCHMARK_TS,
            tracks,
            band,
            method,  # type: ignore[arg-type]
            "auto" if n_samples is None else n_samples,
            N_range=search_range(tracks),
            band_weights=table_2_4_weights(tracks) if method == "ffsc" else (),
            u_max=u_max,
            simulate_delay=delay,
        )
        ff = design_seek(request).ff
    if method == "robust":
        return _Design(ff.u, ff.dt, f"robust LP (N = {ff.N})")
    return _Design(ff.u, ff.dt, f"{method.upper()} (N = {ff.N})")


def _check_design_args(
    method: str, n_samples: int | None, u_max: float | None, max_memory_mb: float
) -> None:
    """Refuse bad design flags before the design (minutes for a huge --n-samples) starts."""
    if method not in ("fsc", "ffsc", "robust"):
        raise ServokitValueError(f"--method must be 'fsc', 'ffsc' or 'robust', got {method!r}")
    refuse_inapplicable("--method", method, {"u_max": ("--u-max", ("robust",))})
    if n_samples is not None:
        n_s = check_count("--n-samples", n_samples, lo=1)
        # the design solves for N samples against an N x N (and larger) system
        check_memory(8.0 * 4 * n_s**2, what=f"--n-samples {n_s}", max_memory_mb=max_memory_mb)
    if method == "robust":
        if u_max is None:
            raise ServokitValueError("--method robust needs --u-max [plant input unit]")
        check_positive("--u-max", u_max)


def _histogram(times: np.ndarray, pct: dict[str, float], title: str, path: Path) -> Path:
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    fig, ax = plt.subplots(figsize=(8, 4.5))
    finite = times[np.isfinite(times)] * 1e3
    # seek times are read on a grid: one bar per grid step when they span few steps
    steps = np.unique(finite)
    h = float(np.min(np.diff(steps))) if steps.size > 1 else 1.0
    n_bars = (steps[-1] - steps[0]) / h if steps.size > 1 else 1
    bins = np.arange(steps[0] - h / 2, steps[-1] + h, h) if n_bars <= 200 else 60
    ax.hist(finite, bins=bins, color="C0", alpha=0.8, label=f"{finite.size} settled plants")
    for (key, val), color in zip(pct.items(), ("C1", "C2", "C3", "C4", "k"), strict=False):
        if np.isfinite(val):
            ax.axvline(val * 1e3, color=color, ls="--", lw=1, label=f"{key} = {val * 1e3:.4f} ms")
    ax.set(xlabel="Seek time [ms]", ylabel="Plants", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
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
    return (_Design(u, d.dt, f"{d.source}, limited") if n_clipped else d), n_clipped


def _design_info(d: _Design, actuator: Any, n_clipped: int) -> dict[str, Any]:
    """The JSON ``design`` object: the applied input and the limits that made it."""
    slew = None if actuator is None else actuator.slew_max
    u_max = None if actuator is None or np.isinf(actuator.u_max) else actuator.u_max
    return {"source": d.source, "n_samples": int(d.u.size), "dt_s": d.dt,
            "peak_input": float(np.abs(d.u).max()), "u_max": u_max, "slew_max": slew,
            "n_clipped": n_clipped}  # fmt: skip


@app.command(
    "sweep",
    epilog=example(
        "servokit sweep --method ffsc --tracks 1 --n-variants 100000 --plot sweep.png",
        "servokit seek --json > d.json; servokit sweep --design d.json --workers 2 --json",
    ),
)
def sweep_cmd(
    design: Annotated[
        Path | None,
        typer.Option(
            "--design",
            help="JSON of `servokit seek --json` (input, dt_s) to evaluate",
            metavar="FILE",
        ),
    ] = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="without --design: 'fsc', 'ffsc' (Table 2.4) or 'robust' design on "
            "the 18 plants of Table 2.3",
        ),
    ] = "ffsc",
    tracks: Annotated[
        float, typer.Option("--target", "--tracks", help="seek distance [track]")
    ] = 1.0,
    n_samples: Annotated[
        int | None,
        typer.Option("--n-samples", help="step number N of the design [count] (default: searched)"),
    ] = None,
    u_max: Annotated[
        float | None,
        typer.Option(
            "--u-max",
            help="actuator input limit [plant input unit]: the robust design respects it; "
            "any other design is clipped at it before the sweep",
        ),
    ] = None,
    slew_max: Annotated[
        float | None,
        typer.Option(
            "--slew-max", help="actuator slew limit |u[k] - u[k-1]| [plant input unit per sample]"
        ),
    ] = None,
    settle_band: Annotated[
        float, typer.Option("--settle-band", help="settling band half-width [track]")
    ] = 0.1,
    n_variants: Annotated[
        int, typer.Option("--n-variants", help="Monte-Carlo plants drawn from Table 2.3 [count]")
    ] = 10_000,
    seed: Annotated[
        int | None,
        typer.Option("--seed", help="random seed (default: the variation file's seed, else 0)"),
    ] = None,
    variations: VariationsOpt = None,
    gain_range: Annotated[
        bool,
        typer.Option(
            "--gain-range/--no-gain-range",
            help="Table 2.3 box: also draw the +-10 % loop gain (an open-loop seek cannot "
            "absorb it); a --variations file's gain_rel is always drawn",
        ),
    ] = False,
    delay: Annotated[
        bool, typer.Option("--delay/--no-delay", help="simulate the 10 us input delay")
    ] = True,
    chunk_size: Annotated[
        int | None,
        typer.Option(
            "--chunk-size", help="plants simulated together [count] (default: fits 200 MB)"
        ),
    ] = None,
    scheduler: Annotated[
        str | None,
        typer.Option(
            "--scheduler",
            help="run the chunks on this Dask scheduler (needs servokit[dask])",
            metavar="ADDRESS",
        ),
    ] = None,
    workers: Annotated[
        int | None,
        typer.Option(
            "--workers", help="run the chunks on a local Dask cluster of N workers [count]"
        ),
    ] = None,
    max_memory_mb: MaxMemoryOpt = 2000.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Seek-time distribution of a feedforward design over a Monte-Carlo set of HDD
    benchmark plants (Table 2.3 ranges), chunk by chunk in bounded memory.

    Percentiles are nearest-rank over all plants; unsettled plants count as inf.

    --variations FILE draws the plants from a variation file instead of the Table 2.3 box.

    --u-max / --slew-max: the held input is clipped (then rate-limited) as the actuator
    would apply it, and the sweep runs on the applied input; design.n_clipped counts the
    samples changed.

    JSON keys: n_variants, seed, variations, backend, chunk_size, chunk_memory_mb (estimate),
    design {source, n_samples, dt_s, peak_input, u_max, slew_max, n_clipped}, target,
    settle_band, mean_s, percentiles_s {p50, p90, p99, p99_9, p100}, worst_index,
    worst_seek_time_s, worst_plant {modes, gain}, n_unsettled, elapsed_s, plot.
    """
    from servokit.models import hdd_benchmark_variation_set, without_delay
    from servokit.seek.sweep import plan_chunks, sweep_seek_times

    plot = plot_target(plot)
    n = check_count("--n-variants", n_variants, lo=1)
    band = check_positive("--settle-band", settle_band)
    if chunk_size is not None:
        check_count("--chunk-size", chunk_size, lo=1)
    if float(check_finite("--target", tracks)) == 0:
        raise ServokitValueError("--target must be non-zero (a seek distance)")
    if design is None:
        _check_design_args(method, n_samples, u_max, max_memory_mb)
    else:  # the design comes from the file: the design flags would be silently ignored
        for name, flag in (("method", "--method"), ("n_samples", "--n-samples")):
            if given_on_command_line(name):
                raise ServokitValueError(f"{flag} does not apply with --design FILE; drop it")
    actuator = _actuator(u_max, slew_max)  # clips any design, the file's too
    if seed is not None and seed < 0:
        raise ServokitValueError(f"--seed must be >= 0 (got {seed})")
    if variations is not None:
        vset = load_variations(variations)
        if design is None and vset.nominal.name != "hdd-benchmark":
            raise ServokitValueError(
                f"--variations {variations}: the design methods use the HDD benchmark; for "
                f"plant {vset.nominal.name!r} give --design FILE (from servokit seek --json)"
            )
    else:
        vset = hdd_benchmark_variation_set()
        if not gain_range:
            vset = dataclasses.replace(vset, gain=(0.0, 0.0))
    seed = vset.seed if seed is None else seed
    if not delay:
        vset = dataclasses.replace(vset, nominal=without_delay(vset.nominal)[0])
    d = (
        _from_file(design)
        if design is not None
        else _from_method(method, tracks, n_samples, u_max, band, delay)
    )
    d, n_clipped = _applied(d, actuator)
    chunks = f"--n-variants {n}, --chunk-size {chunk_size if chunk_size else 'auto'}: "
    with flag_names({}, prefix=chunks):  # refuse early, naming the flags that set the size
        plan_chunks(vset, d, n, chunk_size=chunk_size, max_memory_mb=max_memory_mb)
    client = _client(scheduler, workers)
    t0 = time.perf_counter()
    try:
        with progress(n, f"sweep of {n} plants", enabled=n > 2000) as tick:
            res = sweep_seek_times(
                vset,
                d,
                tracks,
                n=n,
                seed=seed,
                band=band,
                chunk_size=chunk_size,
                max_memory_mb=max_memory_mb,
                client=client,
                progress=tick,
            )
    finally:
        if client is not None:
            client.close()
    elapsed = time.perf_counter() - t0
    pct = res.percentiles()
    worst = vset.from_draws(res.draws, res.gains)[0]
    if plot is not None:
        _histogram(
            res.seek_times,
            pct,
            f"{d.source}: seek times of {n} Monte-Carlo plants\n({vset.name or 'variation set'}"
            f"{'; beyond the book, cf. Figs. 2.18-2.21' if variations is None else ''})",
            plot,
        )
        wrote(plot)
    data = {
        "n_variants": n,
        "seed": seed,
        "variations": vset.name,
        "backend": res.backend,
        "chunk_size": res.chunk_size,
        "chunk_memory_mb": res.chunk_mb,
        "design": _design_info(d, actuator, n_clipped),
        "target": tracks,
        "settle_band": band,
        "mean_s": float(np.mean(res.seek_times)),
        "percentiles_s": pct,
        "worst_index": res.worst_index,
        "worst_seek_time_s": float(res.seek_times[res.worst_index]),
        "worst_plant": {"modes": [dataclasses.asdict(m) for m in worst.modes], "gain": worst.gain},
        "n_unsettled": res.n_unsettled,
        "elapsed_s": elapsed,
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"{d.source}: {n} plants ({res.backend}, chunks of {res.chunk_size}, ~"
        f"{res.chunk_mb:.0f} MB each) in {elapsed:.1f} s; seek time p50 {pct['p50'] * 1e3:.4f} "
        f"ms, p99 {pct['p99'] * 1e3:.4f} ms, worst {data['worst_seek_time_s'] * 1e3:.4f} ms "
        f"(plant {res.worst_index}); {res.n_unsettled} unsettled"
        + (f"; input limited at {n_clipped} sample(s)" if actuator is not None else "")
    )
