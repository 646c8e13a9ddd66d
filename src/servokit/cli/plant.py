"""``servokit plant show|bode``: inspect catalogue plants and plant files."""

from __future__ import annotations

from typing import Annotated

import typer

from servokit.cli._app import (
    FmaxOpt,
    FminOpt,
    JsonOpt,
    MaxMemoryOpt,
    NFreqOpt,
    PlotOpt,
    console,
    emit_json,
    example,
    load_plant,
    plot_target,
    sub_app,
    wrote,
)
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    check_count,
    check_memory,
    check_range,
)

plant_app = sub_app("plant", "Inspect plants: catalogue names or TOML plant files.")

PlantArg = Annotated[
    str,
    typer.Argument(
        help="catalogue name (see: servokit plant list) or a .toml plant file", metavar="PLANT"
    ),
]
_ARRAYS_PER_FREQ = 6  # complex response, magnitude, phase and the per-mode terms' temporaries


@plant_app.command("list", epilog=example("servokit plant list"))
def list_cmd(json_out: JsonOpt = False) -> None:
    """List the catalogue plants (names usable wherever a plant is asked for)."""
    from servokit.models import CATALOGUE

    if json_out:
        emit_json(list(CATALOGUE))
        return
    for name in CATALOGUE:
        console.print(name)


@plant_app.command(
    "show",
    epilog=example("servokit plant show hdd-benchmark --json")
    + "\n\nJSON: name, gain, delay_s, source, modes [{freq_hz, damping, residue}].",
)
def show(plant: PlantArg, json_out: JsonOpt = False) -> None:
    """Print the plant's gain, delay and mode table."""
    p = load_plant(plant, "PLANT")
    data = {
        "name": p.name,
        "gain": p.gain,
        "delay_s": p.delay,
        "source": p.source,
        "modes": [
            {"freq_hz": m.freq_hz, "damping": m.damping, "residue": m.residue} for m in p.modes
        ],
    }
    if json_out:
        emit_json(data)
        return
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(f"{p.name}: gain {p.gain:.6g}, delay {p.delay * 1e6:.4g} us"))
    for col in ("i", "freq [Hz]", "damping", "residue"):
        table.add_column(col, justify="right")
    for i, m in enumerate(p.modes, start=1):
        table.add_row(str(i), f"{m.freq_hz:g}", f"{m.damping:g}", f"{m.residue:g}")
    console.print(table)
    console.print(f"source: {escape(p.source)}")


@plant_app.command(
    "bode",
    epilog=example("servokit plant bode hdd-sampled-data --plot bode.png")
    + "\n\nJSON: freq_hz, magnitude_db, phase_deg, plot.",
)
def bode(
    plant: PlantArg,
    fmin: FminOpt = 10.0,
    fmax: FmaxOpt = 5e4,
    n_freq: NFreqOpt = 400,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Exact frequency response (delay included); optional Bode plot."""
    fmin, fmax = check_range(fmin, fmax)
    n = check_count("--n-freq", n_freq, lo=2)
    plot = plot_target(plot)
    p = load_plant(plant, "PLANT")
    check_memory(
        n * (len(p.modes) + _ARRAYS_PER_FREQ) * 16,
        what=f"--n-freq {n}",
        max_memory_mb=max_memory_mb,
    )
    import numpy as np

    f = np.logspace(np.log10(fmin), np.log10(fmax), n)
    H = p.freqresp(f)
    if plot is not None:
        from servokit.models.plots import bode_plot

        bode_plot(p, f, path=plot)
        wrote(plot)
    if json_out:
        emit_json(
            {
                "freq_hz": f,
                "magnitude_db": 20 * np.log10(np.abs(H)),
                "phase_deg": np.degrees(np.angle(H)),
                "plot": str(plot) if plot else None,
            }
        )
        return
    peak = int(np.argmax(np.abs(H) * f**2))
    console.print(
        f"{p.name}: {n} points {fmin:g}-{fmax:g} Hz; strongest resonance near {f[peak]:.0f} Hz"
    )
