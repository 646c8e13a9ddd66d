"""``servokit sensitivity``: sampled-data |Ssd|, |Tsd| and discrete |Sd|, |Td| (book §4.2)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.models import get_discrete_controller, get_plant
from servokit.sampled import sampled_data_sensitivity, sensitivity_plot


@app.command("sensitivity")
def sensitivity_cmd(
    plant: str = typer.Option("hdd-sampled-data", help="catalogue name or .toml plant file"),
    controller: str = typer.Option("eq-4.69", help="'eq-4.69' or a discrete controller .toml"),
    multirate: bool = typer.Option(
        True, help="use the §4.5.2 multirate path: Ip (4.67), Fm (4.68) at 3.6 kHz, ZOH at Ts/m"
    ),
    m: int = typer.Option(4, help="multirate number (with --multirate)"),
    fmin: float = typer.Option(10.0, help="lowest frequency [Hz]"),
    fmax: float = typer.Option(10000.0, help="highest frequency [Hz]"),
    n: int = typer.Option(1000, help="number of frequencies (linear grid)"),
    tol: float = typer.Option(1e-6, help="relative truncation tolerance of the alias sums"),
    band_limit: float | None = typer.Option(
        None, help="band limit of eq. (4.62) [Hz]: plant response set to 0 above it"
    ),
    plot: Annotated[
        Path | None, typer.Option("--plot", help="write |Ssd|, |Tsd|, |Sd| here (PNG)")
    ] = None,
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
) -> None:
    """Sensitivity of a digital loop including the intersample response (eqs. 4.13-4.38)."""
    if not 0 < fmin < fmax:
        raise ServokitValueError(f"need 0 < --fmin < --fmax (got {fmin}, {fmax})")
    if n < 2:
        raise ServokitValueError(f"--n must be >= 2 (got {n})")
    p = get_plant(plant)
    ctrl = get_discrete_controller(controller)
    dt = float(ctrl.dt)
    mr = None
    if multirate:
        from servokit.cases.hdd_sensitivity import hdd_multirate

        if m < 1:
            raise ServokitValueError(f"--m must be >= 1 (got {m})")
        mr = hdd_multirate(dt, m)
    freq = np.linspace(fmin, fmax, n)
    res = sampled_data_sensitivity(
        p, ctrl, dt, freq, multirate=mr, tol=tol, band_limit_hz=band_limit
    )
    if plot is not None:
        sensitivity_plot(res, quantities=("Ssd", "Tsd", "Sd"), filename=str(plot))
    i_s, i_t = int(np.argmax(res.Ssd)), int(np.argmax(res.Tsd))
    summary = {
        "plant": p.name,
        "controller": controller,
        "dt": dt,
        "m": res.m,
        "peak_Ssd": float(res.Ssd[i_s]),
        "peak_Ssd_freq_hz": float(freq[i_s]),
        "peak_Tsd": float(res.Tsd[i_t]),
        "peak_Tsd_freq_hz": float(freq[i_t]),
        "peak_Sd": float(np.abs(res.Sd).max()),
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json({**summary, **res.to_dict()})
        return
    table = Table(title=f"{p.name}: Ts = {dt * 1e6:.4g} us, m = {res.m}")
    for col in ("f [Hz]", "|Ssd|", "|Tsd|", "|Sd|", "|Td|"):
        table.add_column(col, justify="right")
    for i in np.unique(np.linspace(0, n - 1, min(n, 12)).astype(int)):
        table.add_row(
            *(f"{v:.4g}" for v in (freq[i], res.Ssd[i], res.Tsd[i], abs(res.Sd[i]), abs(res.Td[i])))
        )
    console.print(table)
    console.print(
        f"peak |Ssd| = {summary['peak_Ssd']:.4g} at {summary['peak_Ssd_freq_hz']:.4g} Hz; "
        f"peak |Tsd| = {summary['peak_Tsd']:.4g} at {summary['peak_Tsd_freq_hz']:.4g} Hz"
    )
