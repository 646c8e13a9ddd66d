"""``servokit report``: an HTML design report for a user's actuator (issue 22 item 6)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from servokit.cli._app import (
    app,
    console,
    example,
    load_plant,
    started,
    wrote,
)
from servokit.cli._options import load_controller_data
from servokit.errors import ServokitValueError, check_count

#: largest ``--seek`` JSON read [bytes] (a seek result with 10^6 seek times is ~20 MB)
_SEEK_MAX_BYTES = 64 * 1024 * 1024


def _out_path(out: str) -> Path:
    """``--out DIR``: the directory that receives report.html (created if missing)."""
    from servokit.errors import check_out_dir

    return check_out_dir(out) / "report.html"


def _seek_section(path: Path) -> Any:
    """A seek-time section from the JSON of ``servokit seek --json``."""
    from servokit._io import check_data_file, read_input_text
    from servokit.report.design import SeekSection

    check_data_file(
        path,
        max_bytes=_SEEK_MAX_BYTES,
        what="--seek (a seek --json file)",
        error=ServokitValueError,
    )
    text = read_input_text(path, "--seek", max_bytes=_SEEK_MAX_BYTES)
    try:
        data = json.loads(text)
        times = [float(t) for t in data["seek_times_s"]]
        worst = float(data["seek_time_s"])
    except (ValueError, KeyError, TypeError, UnicodeDecodeError):
        raise ServokitValueError(
            f"--seek {path}: not the JSON of `servokit seek --json` (needs seek_times_s and "
            "seek_time_s)"
        ) from None
    guarantee = data.get("guaranteed_seek_time_s")
    return SeekSection(times, worst, None if guarantee is None else float(guarantee))


def _plant_set(nominal: Any, variations: Path | None, n_plants: int) -> list[Any]:
    """The nominal plant and ``n_plants`` Monte-Carlo plants of the ``--variations`` box."""
    if variations is None:
        return [nominal]
    from servokit.cli._app import load_variations

    box = load_variations(variations, fallback=nominal)
    # each plant named in the report's tables (the samples carry the nominal's name)
    name = box.name or "box"
    samples = box.monte_carlo(n_plants)
    return [box.nominal, *(p.replace(name=f"{name} sample {i}") for i, p in enumerate(samples, 1))]


def _read_inputs(
    plant: str, frf: Path | None, controller: str | None, variations: Path | None,
    n_plants: int, seek: Path | None,
) -> tuple[list[Any], Any, Any, list[str]]:  # fmt: skip
    """The fit section, the loop ``(controller, plants)``, the seek section and the notes:
    every file read and checked, nothing slow computed yet."""
    from servokit.report.design import FitSection

    nominal = load_plant(plant)
    fit: list[Any] = []
    notes = [f"Plant: {plant}."]
    if frf is not None:
        from servokit.models import read_frf

        fit.append(FitSection(*read_frf(frf), nominal))
        notes.append(f"Measured frequency response: {frf}.")
    loop = None
    if controller is not None:
        # numpy coefficients: python-control left unloaded (issue 23)
        loop = load_controller_data(controller), _plant_set(nominal, variations, n_plants)
        notes.append(
            f"Controller: {controller}; plant set: nominal"
            + (f" and {n_plants} Monte-Carlo plants of {variations}." if variations else ".")
        )
    seek_section = None if seek is None else _seek_section(seek)
    if seek is not None:
        notes.append(f"Seek times: {seek}.")
    return fit, loop, seek_section, notes


def _loop_sections(loop: Any) -> list[Any]:
    """Margins and sensitivity over the plant set (after the start line: the slow part)."""
    if loop is None:
        return []
    from servokit.report.design import MarginsSection, SensitivitySection

    ctrl, plants = loop
    return [MarginsSection(plants, ctrl), SensitivitySection(plants, ctrl)]


@app.command(
    "report",
    epilog=example(
        "servokit report --plant stage.toml --frf stage_frf.csv --out design",
        "servokit report --plant stage.toml --controller ctrl.toml --variations box.toml "
        "--seek seek.json --out design",
    ),
)
def report_cmd(
    plant: Annotated[
        str, typer.Option("--plant", help="design plant: catalogue name or .toml plant file")
    ],
    out: Annotated[
        str, typer.Option("--out", help="directory to write report.html into", metavar="DIR")
    ] = ".",
    frf: Annotated[
        Path | None,
        typer.Option("--frf", help="measured FRF (CSV/NPZ/MAT): fit section", metavar="FILE"),
    ] = None,
    controller: Annotated[
        str | None,
        typer.Option("--controller", help="controller file or name: margins and sensitivity"),
    ] = None,
    variations: Annotated[
        Path | None,
        typer.Option("--variations", help="variation file (TOML): the plant set", metavar="FILE"),
    ] = None,
    n_plants: Annotated[
        int,
        typer.Option("--n-plants", help="Monte-Carlo plants of --variations [count]"),
    ] = 50,
    seek: Annotated[
        Path | None,
        typer.Option("--seek", help="JSON of `servokit seek --json`: histogram", metavar="FILE"),
    ] = None,
    title: Annotated[str, typer.Option("--title", help="page title")] = "Design report",
) -> None:
    """Build report.html for a design: fit, margins per plant, seek times, sensitivity."""
    out = _out_path(out)
    check_count("--n-plants", n_plants, lo=1, hi=10_000)
    if frf is None and controller is None and seek is None:
        raise ServokitValueError("give at least one of --frf, --controller, --seek to report on")
    # every input read and checked first (a user's mistake fails before the start line),
    # the margins, sensitivities and figures computed after it
    fit, loop, seek_section, notes = _read_inputs(plant, frf, controller, variations,
                                                  n_plants, seek)  # fmt: skip
    n_sections = len(fit) + 2 * (loop is not None) + (seek_section is not None)
    started("report", f"{n_sections} section(s) -> {out}")
    sections = [*fit, *_loop_sections(loop), *([seek_section] if seek_section else [])]
    out.parent.mkdir(parents=True, exist_ok=True)
    from servokit.report.design import design_report

    design_report(out, sections, title=title, notes=notes)
    console.print(f"{len(sections)} section(s)")
    wrote(out)
