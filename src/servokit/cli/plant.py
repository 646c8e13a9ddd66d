"""``servokit plant show|bode``: inspect catalogue plants and plant files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.models import CATALOGUE, get_plant
from servokit.models.plots import bode_plot

plant_app = typer.Typer(
    help="Inspect plants: catalogue names or TOML plant files.", no_args_is_help=True
)
app.add_typer(plant_app, name="plant")

_PLANT_HELP = f"catalogue name ({', '.join(CATALOGUE)}) or a .toml plant file"


@plant_app.command("show")
def show(
    plant: str = typer.Argument(..., help=_PLANT_HELP),
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
) -> None:
    """Print the plant's gain, delay and mode table."""
    p = get_plant(plant)
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
    table = Table(title=f"{p.name}: gain {p.gain:.6g}, delay {p.delay * 1e6:.4g} us")
    for col in ("i", "freq [Hz]", "damping", "residue"):
        table.add_column(col, justify="right")
    for i, m in enumerate(p.modes, start=1):
        table.add_row(str(i), f"{m.freq_hz:g}", f"{m.damping:g}", f"{m.residue:g}")
    console.print(table)
    console.print(f"source: {p.source}")


@plant_app.command("bode")
def bode(
    plant: str = typer.Argument(..., help=_PLANT_HELP),
    fmin: float = typer.Option(10.0, help="lowest frequency [Hz]"),
    fmax: float = typer.Option(5e4, help="highest frequency [Hz]"),
    n: int = typer.Option(400, help="number of frequency points"),
    plot: Path | None = typer.Option(None, "--plot", help="write the Bode plot to this PNG/SVG"),
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
) -> None:
    """Exact frequency response (delay included); optional Bode plot."""
    if not 0 < fmin < fmax:
        raise ServokitValueError("need 0 < --fmin < --fmax")
    if n < 2:
        raise ServokitValueError("--n must be at least 2")
    p = get_plant(plant)
    f = np.logspace(np.log10(fmin), np.log10(fmax), n)
    H = p.freqresp(f)
    if plot is not None:
        bode_plot(p, f, path=plot)
    if json_out:
        emit_json(
            {
                "freq_hz": f,
                "mag_db": 20 * np.log10(np.abs(H)),
                "phase_deg": np.degrees(np.angle(H)),
                "plot": str(plot) if plot else None,
            }
        )
        return
    peak = int(np.argmax(np.abs(H) * f**2))
    console.print(
        f"{p.name}: {n} points {fmin:g}-{fmax:g} Hz; strongest resonance near {f[peak]:.0f} Hz"
    )
    if plot is not None:
        console.print(f"wrote {plot}")
