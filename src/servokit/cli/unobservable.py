"""``servokit unobservable``: unobservable magnitudes of oscillations (book §4.3, §4.5.3)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.sampled.unobservable import (
    required_measurement_time,
    unacceptable_sampling_frequencies,
    unobservable_magnitude,
    unobservable_plot,
)

unobservable_app = typer.Typer(
    help="Unobservable magnitude of oscillations between samples (eqs. 4.39-4.52).",
    no_args_is_help=True,
)
app.add_typer(unobservable_app, name="unobservable")

PlotOpt = Annotated[Path | None, typer.Option("--plot", help="write a figure here (PNG)")]
JsonOpt = Annotated[bool, typer.Option("--json", help="machine-readable output")]
FreqOpt = Annotated[float, typer.Option("--freq", help="damped oscillation frequency [Hz]")]
DampOpt = Annotated[float, typer.Option("--damping", help="damping ratio zeta of (4.46)")]


@unobservable_app.command("magnitude")
def magnitude_cmd(
    freq: FreqOpt,
    dt: Annotated[float, typer.Option("--dt", help="sampling period tau [s]")],
    damping: DampOpt = 0.0,
    ns: Annotated[
        int | None, typer.Option("--ns", help="judgement samples Ns (omit: steady state)")
    ] = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """yu over the sampling phase, worst case yuw (4.42)/(4.51) and RMS index yui (4.52)."""
    r = unobservable_magnitude(freq, dt, damping=damping, n_samples=ns)
    edges, pct = r.histogram(0.1)
    out = {
        "freq_hz": freq,
        "dt": dt,
        "damping": damping,
        "n_samples": ns,
        "worst": float(r.worst),
        "worst_delta_s": float(r.worst_delta_s),
        "minimum": float(r.minimum),
        "minimum_delta_s": float(r.minimum_delta_s),
        "rms": float(r.rms),
        "histogram_edges": edges,
        "histogram_percent": pct,
        "plot": str(plot) if plot else None,
    }
    if plot is not None:
        unobservable_plot(
            r.delta_s,
            {"yu": r.yu},
            xlabel="Sampling phase delta_s [-]",
            ylabel="yu [-]",
            title=f"yu at {freq:g} Hz, tau = {dt:g} s",
            path=plot,
        )
    if json_out:
        emit_json(out)
        return
    console.print(
        f"yuw = {out['worst']:.4g} (delta_s = {out['worst_delta_s']:.4g}), "
        f"min yu = {out['minimum']:.4g} (delta_s = {out['minimum_delta_s']:.4g}), "
        f"yui = {out['rms']:.4g}"
    )


@unobservable_app.command("sampling")
def sampling_cmd(
    freq: FreqOpt,
    damping: DampOpt = 0.01,
    ns: Annotated[int, typer.Option("--ns", help="judgement samples Ns")] = 10,
    level: Annotated[float, typer.Option("--level", help="acceptable yui")] = 0.1,
    fs_min: Annotated[
        float, typer.Option("--fs-min", help="lowest sampling frequency [Hz] (0: freq/5)")
    ] = 0.0,
    fs_max: Annotated[
        float, typer.Option("--fs-max", help="highest sampling frequency [Hz] (0: 4 freq)")
    ] = 0.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Unacceptable sampling frequencies where yui > level (Figs. 4.24, 4.54)."""
    lo = fs_min or freq / 5
    hi = fs_max or freq * 4
    if not 0 < lo < hi:
        raise ServokitValueError(f"need 0 < --fs-min < --fs-max (got {lo}, {hi})")
    iv = unacceptable_sampling_frequencies(freq, damping, ns, level, (lo, hi))
    rows = [
        {"low_hz": i.low_hz, "high_hz": i.high_hz, "peak_hz": i.peak_hz, "peak_rms": i.peak_rms}
        for i in iv
    ]
    if plot is not None:
        fs = np.geomspace(lo, hi, 1500)
        rms = unobservable_magnitude(freq, 1 / fs, damping=damping, n_samples=ns, n_phases=360).rms
        unobservable_plot(
            fs,
            {f"Ns = {ns}": rms},
            xlabel="Sampling frequency [Hz]",
            ylabel="yui [-]",
            title=f"yui vs sampling frequency ({freq:g} Hz)",
            level=level,
            path=plot,
            logx=True,
        )
    if json_out:
        emit_json(
            {
                "freq_hz": freq,
                "damping": damping,
                "n_samples": ns,
                "level": level,
                "fs_range": [lo, hi],
                "intervals": rows,
                "plot": str(plot) if plot else None,
            }
        )
        return
    table = Table(title=f"sampling frequencies with yui > {level:g} ({freq:g} Hz, Ns = {ns})")
    for col in ("from [Hz]", "to [Hz]", "peak at [Hz]", "peak yui"):
        table.add_column(col, justify="right")
    for r in rows:
        table.add_row(*(f"{r[k]:.4g}" for k in ("low_hz", "high_hz", "peak_hz", "peak_rms")))
    console.print(table)


@unobservable_app.command("time")
def time_cmd(
    freq: FreqOpt,
    dt: Annotated[float, typer.Option("--dt", help="sampling period tau [s]")],
    damping: DampOpt = 0.01,
    level: Annotated[float, typer.Option("--level", help="acceptable yui")] = 0.1,
    max_ns: Annotated[int, typer.Option("--max-ns", help="largest Ns examined")] = 100,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Measurement time tau x Ns needed for yui <= level (Figs. 4.25, 4.55)."""
    req = required_measurement_time(freq, dt, damping, level, max_samples=max_ns)
    if plot is not None:
        ns = np.arange(1, req.rms.size + 1)
        unobservable_plot(
            ns * dt * 1e3,
            {f"tau = {dt * 1e6:.4g} us": req.rms},
            xlabel="Measurement time tau x Ns [ms]",
            ylabel="yui [-]",
            title=f"yui vs measurement time ({freq:g} Hz)",
            level=level,
            path=plot,
        )
    out = {
        "freq_hz": freq,
        "dt": dt,
        "damping": damping,
        "level": level,
        "n_samples": req.n_samples,
        "time_s": req.time_s,
        "crossing_time_s": req.crossing_time_s,
        "rms": req.rms,
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json(out)
        return
    if req.n_samples is None:
        console.print(f"yui stays above {level:g} up to Ns = {max_ns}; raise --max-ns")
        return
    console.print(
        f"Ns >= {req.n_samples} (tau x Ns = {req.time_s * 1e3:.4g} ms); "
        f"the yui curve crosses {level:g} at {req.crossing_time_s * 1e3:.4g} ms"
    )
