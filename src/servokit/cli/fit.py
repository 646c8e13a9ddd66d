"""``servokit fit``: fit a modal plant with delay to a measured FRF file."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import (
    JsonOpt,
    PlotOpt,
    app,
    console,
    emit_json,
    example,
    plot_target,
    started,
    wrote,
)
from servokit.errors import ServokitValueError, check_count, check_input_file, check_out_dir

PLANT_FILE = "plant.toml"


def _modes(value: str) -> int | str:
    if value.strip().lower() == "auto":
        return "auto"
    return check_count("--modes", value.strip(), lo=0, hi=20)


def _band(value: str | None) -> tuple[float, float] | None:
    if value is None:
        return None
    from servokit.errors import check_range

    parts = value.split(":")
    if len(parts) != 2:
        raise ServokitValueError(f"--band {value!r}: give F_LOW:F_HIGH in Hz, e.g. 100:20000")
    try:
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ServokitValueError(f"--band {value!r}: F_LOW and F_HIGH must be numbers") from None
    return check_range(lo, hi, ("--band F_LOW", "--band F_HIGH"))


def _summary(fit, plant_path: Path) -> dict:  # noqa: ANN001
    p = fit.plant
    modes = [
        {
            "freq_hz": m.freq_hz,
            "damping": m.damping,
            "residue": m.residue,
            "gain_residue_out_per_in_s2": p.gain * m.residue,
            "freq_std_hz": fs,
            "damping_std": zs,
            "gain_residue_std_out_per_in_s2": bs,
        }
        for m, fs, zs, bs in zip(
            p.modes, fit.freq_std_hz, fit.damping_std, fit.gain_residue_std, strict=True
        )
    ]
    return {
        "plant_file": str(plant_path),
        "n_points": int(fit.freq_hz.size),
        "n_modes": fit.n_modes,
        "gain": p.gain,
        "delay_s": p.delay,
        "delay_std_s": fit.delay_std_s,
        "modes": modes,
        "median_error": fit.median_error,
        "max_error": float(fit.rel_error.max()),
        "noise_rel": fit.noise_rel,
        "bands": [
            {
                "f_low_hz": b.f_low_hz,
                "f_high_hz": b.f_high_hz,
                "n_points": b.n_points,
                "median_error": b.median,
                "rms_error": b.rms,
                "max_error": b.max,
            }
            for b in fit.bands
        ],
        "bic": {str(k): v for k, v in fit.bic.items()},
    }


def _print(data: dict) -> None:
    from rich.markup import escape
    from rich.table import Table

    table = Table(
        title=escape(
            f"fitted plant: gain {data['gain']:.6g}, delay {data['delay_s'] * 1e6:.4g} "
            f"+- {data['delay_std_s'] * 1e6:.2g} us"
        )
    )
    for col in (
        "i",
        "freq [Hz]",
        "damping",
        "residue",
        "gain*residue",
        "+- freq [Hz]",
        "+- damping",
        "+- gain*residue",
    ):
        table.add_column(col, justify="right")
    for i, m in enumerate(data["modes"], start=1):
        table.add_row(
            str(i),
            f"{m['freq_hz']:.6g}",
            f"{m['damping']:.4g}",
            f"{m['residue']:.4g}",
            f"{m['gain_residue_out_per_in_s2']:.4g}",
            f"{m['freq_std_hz']:.2g}",
            f"{m['damping_std']:.2g}",
            f"{m['gain_residue_std_out_per_in_s2']:.2g}",
        )
    console.print(table)
    console.print(
        f"fit error over {data['n_points']} points: median {100 * data['median_error']:.3g} %, "
        f"max {100 * data['max_error']:.3g} %, noise estimate {100 * data['noise_rel']:.3g} %"
    )


@app.command(
    "fit",
    epilog=example("servokit fit examples/data/stage_frf.csv --out fitted --plot fit.png")
    + "\n\nWrites OUT/plant.toml (read by every --plant).  JSON: plant_file, n_points, n_modes, "
    "gain, delay_s, delay_std_s, modes [{freq_hz, damping, residue, "
    "gain_residue_out_per_in_s2 (output unit per input unit per s^2), freq_std_hz, "
    "damping_std, gain_residue_std_out_per_in_s2}], median_error, max_error, noise_rel, "
    "bands [{f_low_hz, "
    "f_high_hz, n_points, median_error, rms_error, max_error}], bic {n_modes: value}, plot.",
)
def fit_cmd(
    frf_file: Annotated[
        str,
        typer.Argument(
            help="measured FRF: .csv (freq_hz + re,im | mag_db,phase_deg | "
            "mag,phase_rad), .npz or .mat",
            metavar="FRF_FILE",
        ),
    ],
    out: Annotated[
        str, typer.Option("--out", help="directory to write plant.toml into", metavar="DIR")
    ],
    modes: Annotated[
        str, typer.Option("--modes", help="number of resonances [count] or auto (BIC)")
    ] = "auto",
    band: Annotated[
        str | None,
        typer.Option("--band", help="fit only F_LOW:F_HIGH [Hz]", metavar="F_LOW:F_HIGH"),
    ] = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Fit a modal plant with delay (rigid body + resonances) to a measured FRF."""
    from servokit.models import fit_modal, read_frf, save_plant

    src = check_input_file(frf_file, "FRF_FILE")
    n_modes = _modes(modes)
    f_band = _band(band)
    out_dir = check_out_dir(out)
    plot = plot_target(plot)
    try:
        freq, resp = read_frf(src)
    except ServokitValueError as exc:
        raise ServokitValueError(f"FRF_FILE {exc}") from None
    try:
        fit = fit_modal(
            freq, resp, n_modes=n_modes, band=f_band, name=Path(src).stem,
            started=lambda what: started("fit", f"{what} -> {out_dir / PLANT_FILE}"),
        )  # fmt: skip
    except ServokitValueError as exc:
        flag = "--modes" if "n_modes" in str(exc) else "--band" if f_band else "FRF_FILE"
        raise ServokitValueError(f"{flag}: {str(exc).replace('n_modes', '--modes')}") from None
    out_dir.mkdir(parents=True, exist_ok=True)
    plant_path = out_dir / PLANT_FILE
    save_plant(fit.plant, plant_path)
    data = _summary(fit, plant_path)
    if plot is not None:
        from servokit.models.plots import fit_plot

        fit_plot(fit, path=plot)
    data["plot"] = str(plot) if plot is not None else None
    if json_out:
        emit_json(data)
        return
    _print(data)
    wrote(plant_path)
    if plot is not None:
        wrote(plot)
