"""``servokit seek``: FSC / FFSC track seek of a plant (set), worst-case seek time (§2.3-§2.4)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.models import HDD_BENCHMARK_TS, get_plant, hdd_benchmark_variants


def _parse_band(spec: str) -> tuple[float, float, float, int]:
    parts = spec.split(":")
    try:
        if len(parts) != 4:
            raise ValueError
        return float(parts[0]), float(parts[1]), float(parts[2]), int(parts[3])
    except ValueError:
        raise ServokitValueError(
            f"--band {spec!r} must be F_LOW_HZ:F_HIGH_HZ:WEIGHT:N_POINTS, e.g. 6860:7070:1e10:60"
        ) from None


def _int_steps(n_steps: str) -> int:
    try:
        return int(n_steps)
    except ValueError:
        raise ServokitValueError(f"--N must be an integer or 'auto', got {n_steps!r}") from None


@app.command("seek")
def seek_cmd(
    plant: str = typer.Option("hdd-benchmark", help="catalogue name or .toml plant file"),
    tracks: float = typer.Option(1.0, help="seek distance (plant output units, tracks for HDDs)"),
    method: str = typer.Option(
        "fsc",
        help="'fsc' (minimum jerk), 'ffsc' (frequency shaped) "
        "or 'robust' (LP over the plant set, needs --u-max)",
    ),
    n_steps: str = typer.Option(
        "auto", "--N", help="step number, or 'auto' to minimise the worst-case seek time"
    ),
    dt: float | None = typer.Option(
        None,
        help="hold period in seconds (default: Ts of the HDD "
        "benchmark for hdd-benchmark; required otherwise)",
    ),
    band: Annotated[
        list[str] | None,
        typer.Option(
            "--band",
            help="FFSC band F_LOW:F_HIGH:WEIGHT:N_POINTS (repeatable; default for "
            "hdd-benchmark: Table 2.4, 1-track column up to 3 tracks, 10-track beyond)",
        ),
    ] = None,
    model: str = typer.Option("rigid-body", help="design model: 'rigid-body' (book) or 'plant'"),
    settle_band: float = typer.Option(0.1, "--settle-band", help="settling band half-width"),
    delay: bool = typer.Option(
        True,
        "--delay/--no-delay",
        help="simulate the plant's input delay (--no-delay: the book's §2.4 convention)",
    ),
    n_max: int = typer.Option(40, "--n-max", help="largest N tried by --N auto"),
    plot: Annotated[
        Path | None, typer.Option("--plot", help="write the input/response plot here")
    ] = None,
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
    u_max: float | None = typer.Option(
        None, "--u-max", help="robust: input limit |u| [plant input unit, A for hdd-benchmark]"
    ),
    margin: float = typer.Option(0.2, "--margin", help="robust: band shrink [fraction]"),
    slew_max: float | None = typer.Option(
        None, "--slew-max", help="robust: |u[k]-u[k-1]| limit [plant input unit per sample]"
    ),
    objective: str = typer.Option("peak", "--objective", help="robust: 'peak' or 'energy'"),
) -> None:
    """Design an FSC/FFSC seek input and report the worst-case seek time over the plant set.

    For ``hdd-benchmark`` the input is evaluated on the 18 plants of Table 2.3; a plant
    file is evaluated on itself.
    """
    from servokit.cases.hdd_seek import seek_plot, simulate_seek, table_2_4_weights
    from servokit.feedforward import fsc_input
    from servokit.simulate import choose_N

    if method not in ("fsc", "ffsc", "robust"):
        raise ServokitValueError(f"--method must be 'fsc', 'ffsc' or 'robust', got {method!r}")
    if model not in ("rigid-body", "plant"):
        raise ServokitValueError(f"--model must be 'rigid-body' or 'plant', got {model!r}")
    is_hdd = plant == "hdd-benchmark"
    nominal = get_plant(plant)
    plants = hdd_benchmark_variants() if is_hdd else [nominal]
    if dt is None:
        if not is_hdd:
            raise ServokitValueError("--dt is required for plants other than hdd-benchmark")
        dt = HDD_BENCHMARK_TS
    if dt <= 0:
        raise ServokitValueError(f"--dt must be > 0 seconds, got {dt}")
    if tracks == 0:
        raise ServokitValueError("--tracks must be non-zero")
    bands = [_parse_band(b) for b in band or []]
    if method == "ffsc" and not bands:
        if not is_hdd:
            raise ServokitValueError("--method ffsc needs at least one --band for this plant")
        bands = table_2_4_weights(tracks)
    if method != "ffsc" and bands:
        raise ServokitValueError("--band only applies to --method ffsc")
    sim_plants = plants if delay else [p.replace(delay=0.0) for p in plants]
    if method == "robust":  # servokit.cli.robust: design over the set, verify, report
        from servokit.cli.robust import RobustSeekRequest, robust_seek

        N_fixed = None if n_steps == "auto" else _int_steps(n_steps)
        return robust_seek(
            RobustSeekRequest(
                plant,
                sim_plants,
                dt,
                tracks,
                settle_band,
                u_max,
                N_fixed,
                n_max,
                margin,
                slew_max,
                objective,
                plot,
                json_out,
            )
        )
    design_kw = {"band_weights": bands, "model": model}

    search = None
    if n_steps == "auto":
        search = choose_N(
            sim_plants,
            dt,
            tracks,
            range(3, n_max + 1),
            design_plant=nominal,
            band=settle_band,
            **design_kw,
        )
        ff = search.ff
    else:
        N = _int_steps(n_steps)
        ff = fsc_input(nominal, dt, N, tracks, **design_kw)
    out = simulate_seek(sim_plants, ff, tracks, band=settle_band)
    if plot is not None:
        resonances = [m.freq_hz for m in nominal.modes if m.freq_hz > 0]
        seek_plot(
            out,
            tracks,
            f"{method.upper()} seek of {tracks:g} on {plant}, N = {ff.N}",
            plot,
            resonances_hz=resonances,
            bands=bands,
            band=settle_band,
            unit="track" if is_hdd else "output unit",
        )
    data = {
        "plant": plant,
        "method": method,
        "tracks": tracks,
        "N": ff.N,
        "dt": dt,
        "seek_time_s": out.worst,
        "worst_plant": plants[out.worst_plant].name or str(out.worst_plant),
        "n_plants": len(plants),
        "seek_times_s": out.seek_times,
        "peak": float(np.max(out.y)),
        "delay_simulated": delay,
        "input": ff.u,
        "N_search": None
        if search is None
        else {"N": search.N_values, "worst_seek_time_s": search.worst_seek_times},
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"{method.upper()} seek of {tracks:g} on {plant}: N = {ff.N}, worst-case seek time "
        f"{out.worst * 1e3:.6g} ms ({data['worst_plant']}, {len(plants)} plant(s)"
        f"{'' if delay else ', input delay not simulated'})"
    )
