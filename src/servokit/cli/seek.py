"""``servokit seek``: FSC / FFSC track seek of a plant (set), worst-case seek time (§2.3-§2.4)."""

from __future__ import annotations

from typing import Annotated

import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlantOpt,
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
    plot_target,
    progress,
    variation_corners,
    warn,
    wrote,
)
from servokit.cli._options import refuse_inapplicable
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
)

_FLAGS = {
    "band_weights": "--band-weight",
    "N_range": "--n-samples-max",
    "N_max": "--n-samples-max",
    "N": "--n-samples",
    "dt": "--dt",
    "target": "--target",
    "band": "--settle-band",
    "model": "--model",
}
_SMALLEST_N = 3
# the book's Ts = 37.879 us with 2 ms of settling record: horizon = max(3 T, T + 2 ms)
_SETTLE_RECORD_S = 2e-3
_SUBSTEPS = 10
_JSON_KEYS = (
    "plant, method, target, n_samples, dt_s, seek_time_s, worst_plant, n_plants, seek_times_s, "
    "peak (output), peak_input, u_max, variations, delay_simulated, input, "
    "n_search {n_samples, worst_seek_time_s} (null unless auto), "
    "plot"
)


def _parse_band_weight(spec: str) -> tuple[float, float, float, int]:
    parts = spec.split(":")
    try:
        if len(parts) != 4:
            raise ValueError
        lo, hi, weight = (float(p) for p in parts[:3])
        points = int(parts[3])
    except ValueError:
        raise ServokitValueError(
            f"--band-weight {spec!r} must be F_LOW:F_HIGH:WEIGHT:N_POINTS, e.g. 6860:7070:1e10:60"
        ) from None
    check_finite("--band-weight", [lo, hi, weight])
    if not (0 <= lo < hi and weight >= 0 and points >= 1):
        raise ServokitValueError(
            f"--band-weight {spec!r}: need 0 <= F_LOW < F_HIGH [Hz], WEIGHT >= 0, N_POINTS >= 1"
        )
    return lo, hi, weight, points


def _check_size(
    n_max: int, n_plants: int, n_states: int, dt: float, bands, max_mb: float, flag: str
) -> None:
    """Memory of the largest design (N x N Gram and band matrices) and its simulation."""
    points = sum(b[3] for b in bands)
    design = (8 * n_max * n_max + 4 * points * n_max) * 8
    samples = max(3 * n_max, n_max + _SETTLE_RECORD_S / dt) * _SUBSTEPS
    sim = n_plants * samples * (n_states + 2) * 8
    check_memory(design + sim, what=f"{flag} {n_max}", max_memory_mb=max_mb)


#: Flags of the robust design only: given with another --method they are refused
#: (--u-max applies to every method: a QP constraint for fsc/ffsc, the LP limit for robust).
_ROBUST_ONLY = {
    name: (flag, ("robust",))
    for name, flag in (
        ("margin", "--margin"), ("slew_max", "--slew-max"), ("objective", "--objective"),
    )
}  # fmt: skip


@app.command(
    "seek",
    epilog=example(
        "servokit seek --plant hdd-benchmark --target 1 --method ffsc --json",
        "servokit seek --target 10 --method fsc --n-samples 26 --plot seek.png",
    )
    + f"  JSON: {_JSON_KEYS}.",
)
def seek_cmd(
    plant: PlantOpt = "hdd-benchmark",
    target: Annotated[
        float,
        typer.Option("--target", "--tracks", help="seek distance [output unit; track for HDDs]"),
    ] = 1.0,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="'fsc' (minimum jerk), 'ffsc' (frequency shaped) or 'robust' (LP over the "
            "plant set, needs --u-max)",
        ),
    ] = "fsc",
    n_samples: Annotated[
        str,
        typer.Option(
            "--n-samples",
            help="step number N [count], or 'auto' to minimise the worst-case seek time",
        ),
    ] = "auto",
    dt: Annotated[
        float | None,
        typer.Option(
            "--dt",
            help="hold period [s] (default: Ts of the "
            "HDD benchmark for hdd-benchmark; required otherwise)",
        ),
    ] = None,
    band_weight: Annotated[
        list[str] | None,
        typer.Option(
            "--band-weight",
            help="FFSC band weight F_LOW:F_HIGH:WEIGHT:N_POINTS [Hz:Hz:1:count] "
            "(repeatable; default for hdd-benchmark: Table 2.4, 1-track column up to 3 tracks, "
            "10-track beyond)",
        ),
    ] = None,
    model: Annotated[
        str, typer.Option("--model", help="design model: 'rigid-body' (book) or 'plant'")
    ] = "rigid-body",
    settle_band: SettleBandOpt = 0.1,
    delay: Annotated[
        bool,
        typer.Option(
            "--delay/--no-delay",
            help="simulate the plant's input delay (--no-delay: the book's §2.4 convention)",
        ),
    ] = True,
    n_samples_max: Annotated[
        int, typer.Option("--n-samples-max", help="largest N tried by --n-samples auto [count]")
    ] = 40,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
    u_max: Annotated[
        float | None,
        typer.Option(
            "--u-max",
            help="input limit |u| [plant input unit, A for hdd-benchmark]; fsc/ffsc: a QP "
            "constraint (eq. 2.72)",
        ),
    ] = None,
    variations: VariationsOpt = None,
    margin: Annotated[float, typer.Option("--margin", help="robust: band shrink [fraction]")] = 0.2,
    slew_max: Annotated[
        float | None,
        typer.Option(
            "--slew-max", help="robust: |u[k]-u[k-1]| limit [plant input unit per sample]"
        ),
    ] = None,
    objective: Annotated[
        str, typer.Option("--objective", help="robust: 'peak' or 'energy'")
    ] = "peak",
    n_validation: Annotated[
        int,
        typer.Option(
            "--n-validation",
            help="robust with --variations: Monte-Carlo plants validating the worst case "
            "inside the box [count]",
        ),
    ] = 2000,
) -> None:
    """Design an FSC/FFSC seek input and report the worst-case seek time over the plant set.

    For hdd-benchmark the input is evaluated on the 18 plants of Table 2.3; a plant
    file is evaluated on itself, or with --variations FILE on every corner of the box.
    """
    if method not in ("fsc", "ffsc", "robust"):
        raise ServokitValueError(f"--method must be 'fsc', 'ffsc' or 'robust', got {method!r}")
    if model not in ("rigid-body", "plant"):
        raise ServokitValueError(f"--model must be 'rigid-body' or 'plant', got {model!r}")
    refuse_inapplicable("--method", method, _ROBUST_ONLY)
    target = float(check_finite("--target", target))
    if target == 0:
        raise ServokitValueError("--target must be non-zero (a seek distance)")
    check_positive("--settle-band", settle_band)
    auto = n_samples == "auto"
    n_top = check_count(
        "--n-samples-max" if auto else "--n-samples",
        n_samples_max if auto else _parse_n(n_samples),
        lo=_SMALLEST_N if auto else 1,
    )
    bands = [_parse_band_weight(b) for b in band_weight or []]
    plot = plot_target(plot)

    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark_variants, without_delay

    is_hdd = plant == "hdd-benchmark"
    nominal = load_plant(plant)
    plants = hdd_benchmark_variants() if is_hdd else [nominal]
    vset = None
    if variations is not None:
        if method == "robust":  # validated over the box, not a corner set
            check_count("--n-validation", n_validation, lo=1, hi=1_000_000)
        vset = load_variations(variations, fallback=nominal)
        nominal = vset.nominal
        plants = [nominal] if method == "robust" else variation_corners(vset)
        is_hdd = is_hdd and nominal.name == "hdd-benchmark"
    if u_max is not None:
        check_positive("--u-max", u_max)
    if dt is None:
        if not is_hdd:
            raise ServokitValueError("--dt is required for plants other than hdd-benchmark")
        dt = HDD_BENCHMARK_TS
    check_positive("--dt", dt, "s")
    if method == "ffsc" and not bands:
        if not is_hdd:
            raise ServokitValueError(
                "--method ffsc needs at least one --band-weight for this plant"
            )
        from servokit.seek import table_2_4_weights

        bands = table_2_4_weights(target)
    if method != "ffsc" and bands:
        raise ServokitValueError("--band-weight only applies to --method ffsc")
    _check_size(
        n_top,
        len(plants),
        nominal.order + 4,
        dt,
        bands,
        max_memory_mb,
        "--n-samples-max" if auto else "--n-samples",
    )
    sim_plants = plants if delay else without_delay(plants)
    if method == "robust":  # servokit.cli.robust: design over the set, verify, report
        from servokit.cli.robust import RobustSeekRequest, box_variations, robust_seek

        return robust_seek(
            RobustSeekRequest(
                plant if variations is None else str(variations),
                sim_plants,
                dt,
                target,
                settle_band,
                u_max,
                None if auto else n_top,
                n_samples_max,
                margin,
                slew_max,
                objective,
                plot,
                json_out,
                box_variations(vset, delay),
                n_validation,
            )
        )
    limits: tuple = ()
    if u_max is not None:  # |u| <= u_max as a QP constraint of the FSC/FFSC design
        n_flag = "--n-samples-max" if auto else "--n-samples"
        design_kw = {"band_weights": bands, "model": model}
        limits = _input_limit(nominal, dt, n_top, target, u_max, design_kw, n_flag)
    with flag_names(_FLAGS):
        from servokit.seek import SeekRequest, simulate_seek

        request = SeekRequest(
            sim_plants,
            dt,
            target,
            settle_band,
            method,  # type: ignore[arg-type]
            "auto" if auto else n_top,
            N_max=n_top,
            band_weights=bands,
            model=model,
            limits=limits,
            design_plant=nominal,
        )
        ff, search = _design(request, show=not json_out)

        out = simulate_seek(sim_plants, ff, target, band=settle_band)
    if search is not None and ff.N == n_top:
        warn(
            f"the best N sits at --n-samples-max {n_top}; a larger N may seek faster: "
            "raise --n-samples-max"
        )
    if plot is not None:
        _plot(out, nominal, target, method, plant, ff.N, plot, bands, settle_band, is_hdd)
    data = _result(plant, method, target, ff, dt, out, plants, delay, search, plot)
    data["u_max"] = u_max
    data["variations"] = None if variations is None else str(variations)
    if json_out:
        emit_json(data)
        return
    console.print(
        f"{method.upper()} seek of {target:g} on {plant}: N = {ff.N}, worst-case seek time "
        f"{out.worst * 1e3:.6g} ms ({data['worst_plant']}, {len(plants)} plant(s)"
        f"{'' if delay else ', input delay not simulated'})"
    )


def _input_limit(nominal, dt, n_top, target, u_max, design_kw, n_flag) -> tuple:  # noqa: ANN001
    """``|u| <= u_max`` as a QP constraint, refused naming the limit when the largest N
    tried cannot meet it (more samples only make the limit easier)."""
    from servokit.feedforward.constraints import InfeasibleConstraintsError, InputLimit

    limit = (InputLimit(float(u_max)),)
    try:
        from servokit.feedforward import fsc_input

        fsc_input(nominal, dt, n_top, target, **design_kw, constraints=limit)
    except InfeasibleConstraintsError as exc:
        raise ServokitValueError(
            f"--u-max {u_max:g}: no input of N = {n_top} samples reaches the target within "
            f"|u| <= {u_max:g} ({str(exc).splitlines()[0]}); raise --u-max or {n_flag}"
        ) from None
    return limit


def _parse_n(text: str) -> int | str:
    try:
        return int(text)
    except ValueError:
        raise ServokitValueError(
            f"--n-samples must be an integer or 'auto', got {text!r}"
        ) from None


def _design(request, *, show):  # noqa: ANN001
    """The seek input: fixed N, or the N search of §2.4.2 with a progress bar."""
    from servokit.seek import design_seek

    n_tried = len(request.candidates()) if request.N == "auto" else 0
    with progress(n_tried, "searching N", enabled=show and n_tried > 0) as advance:
        result = design_seek(request, progress=advance)
    return result.ff, result.search


def _plot(out, nominal, target, method, plant, N, path, bands, settle_band, is_hdd) -> None:  # noqa: ANN001
    from servokit.seek import seek_plot

    resonances = nominal.resonances_hz()
    seek_plot(
        out,
        target,
        f"{method.upper()} seek of {target:g} on {plant}, N = {N}",
        path,
        resonances_hz=resonances,
        bands=bands,
        band=settle_band,
        unit="track" if is_hdd else "output unit",
    )
    wrote(path)


def _result(plant, method, target, ff, dt, out, plants, delay, search, plot) -> dict:  # noqa: ANN001
    import numpy as np

    return {
        "plant": plant,
        "method": method,
        "target": target,
        "n_samples": ff.N,
        "dt_s": dt,
        "seek_time_s": out.worst,
        "worst_plant": plants[out.worst_plant].name or str(out.worst_plant),
        "n_plants": len(plants),
        "seek_times_s": out.seek_times,
        "peak": float(np.max(out.y)),
        "peak_input": float(np.max(np.abs(ff.u))),
        "delay_simulated": delay,
        "input": ff.u,
        "n_search": None
        if search is None
        else {"n_samples": search.N_values, "worst_seek_time_s": search.worst_seek_times},
        "plot": str(plot) if plot else None,
    }
