"""``servokit srs``: shock response spectrum of an acceleration input (book §4.4)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.sampled.srs import (
    half_sine,
    polynomial_wave,
    shock_response_spectrum,
    spectrum_peaks,
    srs_plot,
)


def _read_samples(path: str) -> np.ndarray:
    p = Path(path)
    if not p.is_file():
        raise ServokitValueError(
            f"--input {path!r} is neither 'half-sine', 'polynomial' nor an existing file"
        )
    try:
        data = np.loadtxt(p, delimiter="," if p.suffix == ".csv" else None, ndmin=1)
    except ValueError as exc:
        raise ServokitValueError(f"--input {path}: not a column of numbers ({exc})") from None
    return np.ravel(data)


@app.command("srs")
def srs_cmd(
    input_: Annotated[
        str,
        typer.Option(
            "--input", help="'half-sine', 'polynomial' (eq. 4.60) or a file of held samples"
        ),
    ] = "half-sine",
    hold: Annotated[
        float | None,
        typer.Option("--hold", help="hold period Tzoh [s] (omit for a continuous half-sine)"),
    ] = None,
    duration: Annotated[
        float, typer.Option("--duration", help="half-sine width Tsrs [s]")
    ] = 0.5e-3,
    n: Annotated[int, typer.Option("--n", help="polynomial length N [samples]")] = 40,
    target: Annotated[float, typer.Option("--target", help="polynomial move Pt")] = 1.0,
    damping: Annotated[float, typer.Option("--damping", help="zeta_srs of (4.54)")] = 0.0,
    kind: Annotated[
        str, typer.Option("--kind", help="'residual' (4.57) or 'initial' (4.56)")
    ] = "residual",
    fmin: Annotated[float, typer.Option("--fmin", help="lowest oscillator frequency [Hz]")] = 100.0,
    fmax: Annotated[
        float, typer.Option("--fmax", help="highest oscillator frequency [Hz]")
    ] = 100e3,
    n_freq: Annotated[int, typer.Option("--n-freq", help="number of frequencies")] = 5000,
    at: Annotated[list[float] | None, typer.Option("--at", help="report gsrs at this [Hz]")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="write the SRS here (PNG)")] = None,
    json_out: Annotated[bool, typer.Option("--json", help="machine-readable output")] = False,
) -> None:
    """Shock response spectrum on the relative-acceleration model (eqs. 4.53-4.61)."""
    if not 0 < fmin < fmax:
        raise ServokitValueError(f"need 0 < --fmin < --fmax (got {fmin}, {fmax})")
    if n_freq < 2:
        raise ServokitValueError(f"--n-freq must be >= 2 (got {n_freq})")
    freq = np.linspace(fmin, fmax, n_freq)
    if input_ == "half-sine":
        accel, dur = half_sine(duration), duration
    else:
        u = None if input_ == "polynomial" else _read_samples(input_)
        if hold is None:
            raise ServokitValueError("--hold is required for held samples (the hold period [s])")
        accel, dur = (polynomial_wave(n, hold, target) if u is None else u), None

    def spectrum(f: np.ndarray):
        return shock_response_spectrum(accel, hold, f, damping, kind=kind, duration=dur)

    spec = spectrum(freq)
    peaks = spectrum_peaks(freq, spec.magnitude)
    # Exact values at the requested frequencies, not interpolated from the grid.
    values: dict[str, float] = {}
    if at:
        exact = spectrum(np.asarray(at, dtype=float)).magnitude
        values = {f"{f:g}": float(m) for f, m in zip(at, exact, strict=True)}
    if plot is not None:
        srs_plot(spec, [f"{input_}, zeta = {damping:g}"], path=plot, marks_hz=at or ())
    if json_out:
        emit_json(
            {
                "input": input_,
                "hold": hold,
                "duration": spec.duration,
                "damping": damping,
                "kind": kind,
                "freq_hz": freq,
                "magnitude": spec.magnitude,
                "peaks_hz": peaks,
                "at": values,
                "plot": str(plot) if plot else None,
            }
        )
        return
    table = Table(title=f"{kind} SRS of {input_} (Tsrs = {spec.duration * 1e3:.4g} ms)")
    table.add_column("peak at [Hz]", justify="right")
    table.add_column("gsrs", justify="right")
    for f in peaks:
        table.add_row(f"{f:.5g}", f"{spec.at(f):.4g}")
    console.print(table)
    for f, v in values.items():
        console.print(f"gsrs({f} Hz) = {v:.4g}")
