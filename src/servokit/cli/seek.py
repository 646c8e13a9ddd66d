"""``servokit seek``: FSC / FFSC track seek of a plant (set), worst-case seek time (§2.3-§2.4).

Flags -> :func:`servokit.cli._requests.seek_job` (the checked
:class:`~servokit.seek.SeekRequest`) -> :func:`servokit.seek.run_seek` -> :func:`render_seek`;
``--method robust`` renders through :mod:`servokit.cli.robust`.
"""

from __future__ import annotations

from typing import Annotated, Any

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
    progress,
    warn,
    wrote,
)
from servokit.cli._options import (
    DelayOpt,
    NSamplesMaxOpt,
    SlewMaxOpt,
    TargetOpt,
    u_max_option,
)
from servokit.cli._render import ms
from servokit.cli._requests import SEEK_FLAGS, SeekFlags, SeekJob, seek_job
from servokit.cli.robust import JSON_KEYS as ROBUST_JSON_KEYS
from servokit.errors import DEFAULT_MAX_MEMORY_MB

_JSON_KEYS = (
    "plant, method, target_out, n_samples, dt_s, seek_time_s, worst_plant, n_plants, "
    "seek_times_s, peak_out, peak_input, u_max, variations, delay_simulated, input, "
    "n_search {n_samples, worst_seek_time_s} (null unless auto), "
    "plot"
)
UMaxOpt = u_max_option("fsc/ffsc: a QP constraint (eq. 2.72)")
MethodOpt = Annotated[
    str,
    typer.Option(
        "--method",
        help="'fsc' (minimum jerk), 'ffsc' (frequency shaped) or 'robust' (LP over the "
        "plant set, needs --u-max)",
    ),
]
NSamplesOpt = Annotated[
    str,
    typer.Option(
        "--n-samples", help="step number N [count], or 'auto' to minimise the worst-case seek time"
    ),
]
DtOpt = Annotated[
    float | None,
    typer.Option(
        "--dt",
        help="hold period [s] (default: Ts of the HDD benchmark for hdd-benchmark; required "
        "otherwise)",
    ),
]
BandWeightOpt = Annotated[
    list[str] | None,
    typer.Option(
        "--band-weight",
        help="FFSC band weight F_LOW:F_HIGH:WEIGHT:N_POINTS [Hz:Hz:1:count] (repeatable; default "
        "for hdd-benchmark: Table 2.4, 1-track column up to 3 tracks, 10-track beyond)",
    ),
]
ModelOpt = Annotated[
    str, typer.Option("--model", help="design model: 'rigid-body' (book) or 'plant'")
]
MarginOpt = Annotated[float, typer.Option("--margin", help="robust: band shrink [fraction]")]
ObjectiveOpt = Annotated[str, typer.Option("--objective", help="robust: 'peak' or 'energy'")]
NValidationOpt = Annotated[
    int,
    typer.Option(
        "--n-validation",
        help="robust with --variations: Monte-Carlo plants validating the worst case inside "
        "the box [count]",
    ),
]


@app.command(
    "seek",
    epilog=example(
        "servokit seek --plant hdd-benchmark --target 1 --method ffsc --json",
        "servokit seek --target 10 --method fsc --n-samples 26 --plot seek.png",
    )
    + f"\n\nJSON (fsc, ffsc): {_JSON_KEYS}.  JSON (robust): {ROBUST_JSON_KEYS}.",
)
def seek_cmd(
    plant: PlantOpt = "hdd-benchmark",
    target: TargetOpt = 1.0,
    method: MethodOpt = "fsc",
    n_samples: NSamplesOpt = "auto",
    dt: DtOpt = None,
    band_weight: BandWeightOpt = None,
    model: ModelOpt = "rigid-body",
    settle_band: SettleBandOpt = 0.1,
    delay: DelayOpt = True,
    n_samples_max: NSamplesMaxOpt = 40,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
    u_max: UMaxOpt = None,
    variations: VariationsOpt = None,
    margin: MarginOpt = 0.2,
    slew_max: SlewMaxOpt = None,
    objective: ObjectiveOpt = "peak",
    n_validation: NValidationOpt = 2000,
) -> None:
    """Design an FSC/FFSC seek input and report the worst-case seek time over the plant set.

    For hdd-benchmark the input is evaluated on the 18 plants of Table 2.3; a plant
    file is evaluated on itself, or with --variations FILE on every corner of the box.
    """
    job = seek_job(SeekFlags(**locals()))
    if job.request.method == "robust":  # servokit.cli.robust: LP design, verify, report
        from servokit.cli.robust import robust_seek

        return robust_seek(job)
    from servokit.seek import run_seek

    n_tried = len(job.request.candidates()) if job.request.N == "auto" else 0
    show = not json_out and n_tried > 0
    with flag_names(SEEK_FLAGS), progress(n_tried, "searching N", enabled=show) as advance:
        run = run_seek(job.request, progress=advance)
    render_seek(job, run)


def render_seek(job: SeekJob, run: Any) -> None:
    """Warn at the edge of the N search, plot, print or emit the JSON of an FSC/FFSC seek.

    Parameters
    ----------
    job : SeekJob
        The request and output flags.
    run : servokit.seek.SeekRun
        The design and its simulated seek.
    """
    req, ff, out = job.request, run.ff, run.outcome
    if run.design.search is not None and ff.N == req.N_max:
        warn(
            f"the best N sits at --n-samples-max {ff.N}; a larger N may seek faster: "
            "raise --n-samples-max"
        )
    if job.output.plot is not None:
        _plot(job, run)
    data = _result(job, run)
    if job.output.json_out:
        emit_json(data)
        return
    console.print(
        f"{req.method.upper()} seek of {req.target:g} on {job.label}: N = {ff.N}, worst-case "
        f"seek time {ms(out.worst)} ({data['worst_plant']}, {len(req.plants)} plant(s)"
        f"{'' if req.simulate_delay else ', input delay not simulated'})"
    )


def _plot(job: SeekJob, run: Any) -> None:
    from servokit.seek import seek_plot

    req, path = job.request, job.output.plot
    seek_plot(
        run.outcome,
        req.target,
        f"{req.method.upper()} seek of {req.target:g} on {job.label}, N = {run.ff.N}",
        path,
        resonances_hz=req.design_plant.resonances_hz(),
        bands=list(req.band_weights),
        band=req.band,
        unit=job.unit,
    )
    wrote(path)


def _result(job: SeekJob, run: Any) -> dict:
    import numpy as np

    req, ff, out, search = job.request, run.ff, run.outcome, run.design.search
    plot = job.output.plot
    return {
        "plant": job.label,
        "method": req.method,
        "target_out": req.target,
        "n_samples": ff.N,
        "dt_s": req.dt,
        "seek_time_s": out.worst,
        "worst_plant": req.plants[out.worst_plant].name or str(out.worst_plant),
        "n_plants": len(req.plants),
        "seek_times_s": out.seek_times,
        "peak_out": float(np.max(out.y)),
        "peak_input": float(np.max(np.abs(ff.u))),
        "u_max": req.limits[0].max_abs if req.limits else None,
        "variations": job.variations,
        "delay_simulated": req.simulate_delay,
        "input": ff.u,
        "n_search": None
        if search is None
        else {"n_samples": search.N_values, "worst_seek_time_s": search.worst_seek_times},
        "plot": str(plot) if plot else None,
    }
