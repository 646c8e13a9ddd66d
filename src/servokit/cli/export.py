"""``servokit export``: firmware tables of a design as C, CSV or JSON."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import JsonOpt, emit_json, example, sub_app, wrote

export_app = sub_app(
    "export",
    "Firmware export: feedforward tables, controllers (state space / second-order "
    "sections), gain matrices; C header + source (float, double, Q15, Q31), CSV, JSON.",
)

FormatOpt = Annotated[
    str, typer.Option("--format", help="c (header + source), csv or json", metavar="c|csv|json")
]
PrecisionOpt = Annotated[
    str,
    typer.Option(
        "--precision",
        help="number format: float, double, q15 or q31 (fixed point with a power-of-two scale); "
        "export controller also qM.N and fixed-point step functions",
        metavar="float|double|q15|q31|qM.N",
    ),
]
# a str, not a Path: typer turns an empty --out "" into Path("."), the working directory
OutOpt = Annotated[str, typer.Option("--out", help="output directory")]
NameOpt = Annotated[str, typer.Option("--name", help="C prefix and file stem (a C identifier)")]


def _check_common(out: str | Path, name: str, fmt: str, precision: str, qmn: bool = False) -> Path:
    """Refuse bad --out/--name/--format/--precision before any work."""
    import re

    from servokit.errors import ServokitValueError, check_out_dir
    from servokit.export import FILE_FORMATS, FORMATS

    if fmt not in FILE_FORMATS:
        raise ServokitValueError(f"--format {fmt!r}: choose one of {', '.join(FILE_FORMATS)}")
    if precision not in FORMATS and not (qmn and precision.lower().startswith("q")):
        raise ServokitValueError(f"--precision {precision!r}: choose one of {', '.join(FORMATS)}")
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name):
        raise ServokitValueError(f"--name {name!r}: use a C identifier (letters, digits, _)")
    return check_out_dir(out)


def _finish(tables: list, out: Path, name: str, fmt: str, precision: str, step: str | None,
            title: str, json_out: bool) -> None:  # fmt: skip
    """Write the files; report them and each table's quantisation error."""
    from servokit.export import FORMATS, quantize, write_export

    paths = write_export(
        tables, out, name, file_format=fmt, precision=precision, step=step, title=title
    )
    for p in paths:
        wrote(p)
    bits = FORMATS[precision][1]
    rows = []
    for t in tables:
        row = {"table": t.name, "shape": list(t.values.shape)}
        if bits is not None:
            q = quantize(t.values, bits)
            row |= {"scale": q.scale, "error_bound": q.error_bound, "max_error": q.max_error}
        rows.append(row)
    if json_out:
        emit_json({"files": [str(p) for p in paths], "precision": precision, "tables": rows})
        return
    for row in rows:
        extra = (
            f", scale {row['scale']:.6g}, max error {row['max_error']:.3g} "
            f"(bound {row['error_bound']:.3g})"
            if "scale" in row
            else ""
        )
        typer.echo(f"{row['table']}: shape {tuple(row['shape'])}{extra}")


@export_app.command(
    "feedforward",
    epilog=example("servokit export feedforward --design 2 --target 10 --format c --out fw"),
)
def feedforward_cmd(
    design: int = typer.Option(2, "--design", help="1: FSC (2.40)-(2.42); 2: FFSC, Table 2.4"),
    target: float = typer.Option(10.0, "--target", help="seek distance [track]"),
    n_samples: int | None = typer.Option(
        None, "--n-samples", help="steps N (default: the book's N for 1 or 10 tracks)"
    ),
    fmt: FormatOpt = "c",
    precision: PrecisionOpt = "float",
    out: OutOpt = "firmware",
    name: NameOpt = "hdd_ff",
    json_out: JsonOpt = False,
) -> None:
    """HDD benchmark feedforward table u_c[0..N-1] held at Ts = 37.879 us (book §2.4).

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error).
    """
    from servokit.export import feedforward_tables
    from servokit.export.designs import hdd_feedforward

    out_dir = _check_common(out, name, fmt, precision)
    ff = hdd_feedforward(design, target, n_samples)
    tables = feedforward_tables(ff.u, ff.dt, name="u")
    title = f"HDD benchmark Design {design}, {target:g} track(s), N = {ff.N} (book §2.4.2)"
    _finish(tables, out_dir, name, fmt, precision, None, title, json_out)


@export_app.command(
    "controller",
    epilog=example(
        "servokit export controller --controller eq-4.69 --precision q15 --u-max 2 --input-max 1"
    ),
)
def controller_cmd(
    controller: str = typer.Option(
        ...,
        "--controller",
        help="book controller (eq-4.69, fig-4.57, table-5.2, hdd-benchmark) or .toml file",
    ),
    realization: str = typer.Option(
        "ss", "--realization", help="ss (state space; modal in fixed point) or sos (sections)"
    ),
    fmt: FormatOpt = "c",
    precision: PrecisionOpt = "float",
    out: OutOpt = "firmware",
    name: NameOpt = "ctrl",
    u_max: float | None = typer.Option(
        None, "--u-max", help="fixed point: output saturation |u| <= u_max [controller output]"
    ),
    input_max: float = typer.Option(
        1.0, "--input-max", help="fixed point: declared input range |e| <= e_max [input unit]"
    ),
    rounding: str = typer.Option(
        "half-up", "--rounding", help="fixed point: half-up, convergent or truncate"
    ),
    overflow: str = typer.Option(
        "saturate", "--overflow", help="fixed point: stored nodes saturate or wrap"
    ),
    n_samples: int = typer.Option(
        10_000, "--n-samples", help="fixed point: horizon of the stated error bound [count]"
    ),
    json_out: JsonOpt = False,
) -> None:
    """A discrete controller's matrices or sections with a C step function.

    float/double: the tables and a floating-point step. q15, q31, qM.N with --format c:
    fixed-point step functions (L1-scaled, integrator kept apart with anti-windup), the
    formats and the error bound against the float design.

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error);
    fixed point: files, precision, realization, input_format, output_format, word_bits,
    accumulator_bits, rounding, overflow, input_max, u_max, input_lsb, output_lsb,
    n_nodes, node_peak, integrator, error_bound, error_bound_n_samples, error_bound_terms.
    """
    from servokit.errors import ServokitValueError
    from servokit.export import sos_tables, statespace_tables
    from servokit.models.lookup import get_discrete_controller

    out_dir = _check_common(out, name, fmt, precision, qmn=True)
    if realization not in ("ss", "sos"):
        raise ServokitValueError(f"--realization {realization!r}: choose ss or sos")
    fixed = _fixed_request(precision, fmt, u_max, input_max, rounding, overflow, n_samples)
    if controller.strip() in ("", ".") or Path(controller).is_dir():
        raise ServokitValueError(
            f"--controller {controller!r}: give a book name or a .toml controller file"
        )
    try:
        ctrl = get_discrete_controller(controller)
    except ServokitValueError as exc:
        raise ServokitValueError(f"--controller {exc}") from None
    if fixed is not None:
        _finish_fixed(ctrl, realization, fixed, out_dir, name, f"controller {controller}", json_out)
        return
    make = statespace_tables if realization == "ss" else sos_tables
    tables = make(ctrl, "ss" if realization == "ss" else "sos")
    step = realization if fmt == "c" and precision in ("float", "double") else None
    _finish(tables, out_dir, name, fmt, precision, step, f"controller {controller}", json_out)


def _fixed_request(precision: str, fmt: str, u_max: float | None, input_max: float,
                   rounding: str, overflow: str, n_samples: int) -> dict | None:  # fmt: skip
    """Checked fixed-point flags, or None for a float/double (or table-only) export."""
    from servokit.errors import ServokitValueError, check_count
    from servokit.export.fixed_point import parse_qformat

    floating = precision in ("float", "double")
    if floating or (fmt != "c" and precision in ("q15", "q31")):
        given = [f for f, v, d in (("--u-max", u_max, None), ("--input-max", input_max, 1.0),
                 ("--rounding", rounding, "half-up"), ("--overflow", overflow, "saturate"),
                 ("--n-samples", n_samples, 10_000)) if v != d]  # fmt: skip
        if given:
            raise ServokitValueError(
                f"{given[0]}: applies to fixed-point step functions (--precision q15, q31 or "
                "qM.N with --format c)"
            )
        return None
    qfmt = parse_qformat(precision)
    if fmt != "c":
        raise ServokitValueError(f"--format {fmt}: {precision} step functions are C; use c")
    check_count("--n-samples", n_samples, lo=1, hi=10**9)  # the rest: design_fixed_point
    return {"precision": qfmt, "u_max": u_max, "input_max": input_max, "rounding": rounding,
            "overflow": overflow, "n_samples": n_samples}  # fmt: skip


def _finish_fixed(ctrl: object, realization: str, req: dict, out: Path, name: str, title: str,
                  json_out: bool) -> None:  # fmt: skip
    """Design, write and report a fixed-point controller."""
    from servokit.errors import ServokitValueError
    from servokit.export import design_fixed_point, write_fixed_export
    from servokit.export.fixed_point import design_summary

    n = req.pop("n_samples")
    try:
        design = design_fixed_point(ctrl, realization=realization, **req)
    except ServokitValueError as exc:
        msg = str(exc)
        raise ServokitValueError(msg if msg.startswith("--") else f"--controller: {msg}") from None
    paths = write_fixed_export(design, out, name, title=title, n_samples=n)
    for p in paths:
        wrote(p)
    info = {"files": [str(p) for p in paths], "precision": req["precision"].name.lower()}
    info |= design_summary(design, n)
    if json_out:
        emit_json(info)
        return
    typer.echo(
        f"{info['realization']}: {info['n_nodes']} stored node(s), {design.fmt.name} words "
        f"({design.fmt.ctype}), {design.fmt.acc_ctype} accumulators, rounding {design.rounding},"
        f" nodes {design.overflow}{', integrator with anti-windup' if info['integrator'] else ''}"
    )
    typer.echo(
        f"input {info['input_format']} (1.0 = {design.input_max:g}), output "
        f"{info['output_format']} (1.0 = u_max = {design.u_max:.6g}), saturated at u_max"
    )
    parts = info["error_bound_terms"].items()
    terms = ", ".join(f"{k.replace('_', ' ')} {v:.3g}" for k, v in parts)
    typer.echo(f"error bound vs the float design: {info['error_bound']:.3g} over {n} samples")
    typer.echo(f"  terms [output unit]: {terms}")


@export_app.command(
    "ivc",
    epilog=example("servokit export ivc --method pole-zero --precision q15 --format c"),
)
def ivc_cmd(
    method: str = typer.Option(
        "pole-zero", "--method", help="pole-zero (§3.3.2 loop) or jmin (§3.3.1 loop)"
    ),
    velocity_weight: float = typer.Option(
        1.55e-7, "--velocity-weight", help="J-min weight q_v on the velocity [s^2] (jmin)"
    ),
    fmt: FormatOpt = "c",
    precision: PrecisionOpt = "float",
    out: OutOpt = "firmware",
    name: NameOpt = "ivc",
    json_out: JsonOpt = False,
) -> None:
    """IVC gain matrix K of a chapter 3 book loop: load xc[0] = K xp[0] at the switch.

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error).
    """
    from servokit.export import FirmwareTable
    from servokit.export.designs import book_ivc_gain

    out_dir = _check_common(out, name, fmt, precision)
    K, desc = book_ivc_gain(method, velocity_weight)
    tables = [FirmwareTable("K", K, f"xc[0] = K xp[0]: {desc}")]
    _finish(tables, out_dir, name, fmt, precision, None, desc, json_out)


@export_app.command(
    "table",
    epilog=example("servokit export table --input gains.json --precision q15 --format c"),
)
def table_cmd(
    input_file: Path = typer.Option(
        ..., "--input", help='.json {"name": [[...], ...]} or .csv of numbers (one table)'
    ),
    fmt: FormatOpt = "c",
    precision: PrecisionOpt = "float",
    out: OutOpt = "firmware",
    name: NameOpt = "tables",
    json_out: JsonOpt = False,
) -> None:
    """Arrays from a file (IVC gain matrices, filter coefficients...) as firmware tables.

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error).
    """
    out_dir = _check_common(out, name, fmt, precision)
    tables = _read_tables(input_file)
    _finish(tables, out_dir, name, fmt, precision, None, f"tables of {input_file.name}", json_out)


def _read_tables(path: Path) -> list:
    import numpy as np  # here, not at the top: `servokit --help` stays fast

    from servokit.errors import ServokitValueError, check_input_file
    from servokit.export import FirmwareTable

    path = check_input_file(path, "--input")
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except json.JSONDecodeError as exc:
            raise ServokitValueError(f"--input {path}: not valid JSON ({exc.msg})") from None
        if not isinstance(data, dict) or not data:
            raise ServokitValueError(f'--input {path}: give an object {{"name": [numbers]}}')
        items = list(data.items())
    elif path.suffix.lower() == ".csv":
        try:
            items = [(path.stem.replace("-", "_"), np.loadtxt(path, delimiter=",", ndmin=2))]
        except ValueError:
            raise ServokitValueError(f"--input {path}: the CSV must hold numbers only") from None
    else:
        raise ServokitValueError(f"--input {path}: use a .json or .csv file")
    try:
        return [FirmwareTable(k, np.asarray(v, dtype=float)) for k, v in items]
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ServokitValueError):
            raise ServokitValueError(f"--input {path}: {exc}") from None
        raise ServokitValueError(f"--input {path}: tables must be arrays of numbers") from None
