"""``servokit export``: firmware tables of a design as C, CSV or JSON."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    OutDirOpt,
    emit_json,
    example,
    flag_names,
    sub_app,
    wrote,
)
from servokit.cli._options import given_on_command_line, old_name, refuse_inapplicable, renamed
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_memory,
)

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


def _check_representable(tables: list, precision: str) -> None:
    """Refuse a table the chosen number format cannot hold: C would get ``inff``/``nan``,
    which no compiler accepts as a constant (and firmware must not run on)."""
    import numpy as np

    for t in tables:
        values = np.asarray(t.values, dtype=float)
        if not np.all(np.isfinite(values)):
            raise ServokitValueError(f"table {t.name!r} holds NaN or inf; nothing to export")
        biggest = float(np.max(np.abs(values))) if values.size else 0.0
        if precision == "float" and biggest > float(np.finfo(np.float32).max):
            raise ServokitValueError(
                f"--precision float: table {t.name!r} holds {biggest:.3g}, beyond single "
                "precision (3.4e38); use --precision double or rescale"
            )


def _finish(tables: list, out: Path, name: str, fmt: str, precision: str, step: str | None,
            title: str, json_out: bool, u_max: float | None = None) -> None:  # fmt: skip
    """Write the files; report them and each table's quantisation error."""
    from servokit.export import FORMATS, quantize, write_export

    _check_representable(tables, precision)
    paths = write_export(
        tables, out, name, file_format=fmt, precision=precision, step=step, title=title, u_max=u_max
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


def _design_number(method: str, design_old: int | None) -> int:
    """Book design number (1: FSC, 2: FFSC) from --method, or the deprecated --design."""
    methods = {"fsc": 1, "ffsc": 2}
    if method not in methods:
        raise ServokitValueError(f"--method {method!r}: use fsc or ffsc")
    if design_old is None:
        return methods[method]
    if design_old not in (1, 2):
        raise ServokitValueError(f"--design {design_old}: use --method fsc or --method ffsc")
    return renamed(methods[method], design_old, new_flag="--method", old_flag="--design", default=2)


@export_app.command(
    "feedforward",
    epilog=example(
        "servokit export feedforward --method ffsc --target 10 --format c --out fw",
        "servokit seek --plant p.toml --variations box.toml --json > s.json; "
        "servokit export feedforward --seek s.json --out fw",
    ),
)
def feedforward_cmd(
    method: str = typer.Option(
        "ffsc", "--method", help="fsc (Design 1, (2.40)-(2.42)) or ffsc (Design 2, Table 2.4)"
    ),
    design_old: old_name("--design", int) = None,
    target: float = typer.Option(10.0, "--target", help="seek distance [track]"),
    n_samples: int | None = typer.Option(
        None, "--n-samples", help="steps N (default: the book's N for 1 or 10 tracks)"
    ),
    seek: Path | None = typer.Option(
        None,
        "--seek",
        help="export this `servokit seek --json` output (input, dt_s) instead of a book design",
        metavar="FILE",
    ),
    fmt: FormatOpt = "c",
    precision: PrecisionOpt = "float",
    out: OutDirOpt = "firmware",
    name: NameOpt = "hdd_ff",
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    json_out: JsonOpt = False,
) -> None:
    """HDD benchmark feedforward table u_c[0..N-1] held at Ts = 37.879 us (book §2.4),
    or any seek input designed by `servokit seek` (--seek FILE: e.g. your plant over your
    variation box, `seek --plant P --variations V --json`).

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error).
    """
    from servokit.export import feedforward_tables
    from servokit.export.designs import hdd_feedforward, read_seek_json

    design = _design_number(method, design_old)
    out_dir = _check_common(out, name, fmt, precision)
    if seek is not None:
        for param, flag in (("method", "--method"), ("design_old", "--design"),
                            ("target", "--target"), ("n_samples", "--n-samples")):  # fmt: skip
            if given_on_command_line(param):
                raise ServokitValueError(f"{flag} picks a book design; drop it with --seek FILE")
        u, dt = read_seek_json(seek, "--seek")
        title = f"seek input of {seek.name}, N = {u.size}, dt = {dt:.9g} s"
        _finish(feedforward_tables(u, dt, name="u"), out_dir, name, fmt, precision, None, title,
                json_out)  # fmt: skip
        return
    if n_samples is not None:
        n_samples = check_count("--n-samples", n_samples, lo=2)
        # the FSC/FFSC least squares hold a few N x N matrices
        check_memory(
            4 * 8.0 * n_samples**2, what=f"--n-samples {n_samples}", max_memory_mb=max_memory_mb
        )
    with flag_names({"design": "--method", "N": "--n-samples"}):
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
    out: OutDirOpt = "firmware",
    name: NameOpt = "ctrl",
    u_max: float | None = typer.Option(
        None,
        "--u-max",
        help="output saturation |u| <= u_max [controller output] (float/double: clamped ss "
        "step with anti-windup)",
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

    float/double: the tables and a floating-point step; with --u-max (--realization ss,
    --format c) the step clamps its output and corrects the state by the observer
    anti-windup of `simulate --anti-windup` (table <name>_ss_L). q15, q31, qM.N with --format c:
    fixed-point step functions (L1-scaled, integrator kept apart with anti-windup), the
    formats and the error bound against the float design.

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error);
    fixed point: files, precision, realization, input_format, output_format, word_bits,
    accumulator_bits, rounding, overflow, input_max_out, u_max, input_lsb_out, output_lsb_in,
    n_nodes, node_peak, integrator, error_bound, error_bound_n_samples, error_bound_terms_in.
    """
    from servokit.errors import ServokitValueError
    from servokit.export import sos_tables, statespace_tables
    from servokit.models.lookup import get_discrete_rational

    out_dir = _check_common(out, name, fmt, precision, qmn=True)
    if realization not in ("ss", "sos"):
        raise ServokitValueError(f"--realization {realization!r}: choose ss or sos")
    fixed = _fixed_request(precision, fmt, u_max, input_max, rounding, overflow, n_samples)
    if controller.strip() in ("", ".") or Path(controller).is_dir():
        raise ServokitValueError(
            f"--controller {controller!r}: give a book name or a .toml controller file"
        )
    try:
        ctrl = get_discrete_rational(controller)  # numpy coefficients: python-control unloaded
    except ServokitValueError as exc:
        raise ServokitValueError(f"--controller {exc}") from None
    if fixed is not None:
        _finish_fixed(ctrl, realization, fixed, out_dir, name, f"controller {controller}", json_out)
        return
    make = statespace_tables if realization == "ss" else sos_tables
    # python-control's realisation (the float tables as they always were)
    tables = make(ctrl.to_control(), "ss" if realization == "ss" else "sos")
    step = realization if fmt == "c" and precision in ("float", "double") else None
    if u_max is not None:
        tables.append(_antiwindup_table(tables, realization, fmt))
    title = f"controller {controller}" + (f", output clamped at +-{u_max:g}" if u_max else "")
    _finish(tables, out_dir, name, fmt, precision, step, title, json_out, u_max)


def _antiwindup_table(tables: list, realization: str, fmt: str) -> object:
    """The observer anti-windup gain ``L`` of a clamped float/double state-space step."""
    import numpy as np

    from servokit.errors import ServokitValueError
    from servokit.export import FirmwareTable
    from servokit.simulate.saturation import antiwindup_gain

    if realization != "ss" or fmt != "c":
        raise ServokitValueError(
            "--u-max: the clamped float/double step is C state space; use --realization ss "
            "--format c"
        )
    a, c = tables[0].values, tables[2].values[0]
    L = antiwindup_gain(a, c) if a.shape[0] else np.zeros(1)  # a static gain: no state
    return FirmwareTable("ss_L", L.reshape(-1, 1), "anti-windup x += L (u_clamped - u_linear)")


def _fixed_request(precision: str, fmt: str, u_max: float | None, input_max: float,
                   rounding: str, overflow: str, n_samples: int) -> dict | None:  # fmt: skip
    """Checked fixed-point flags, or None for a float/double (or table-only) export."""
    from servokit.errors import ServokitValueError, check_count, check_positive
    from servokit.export.fixed_point import parse_qformat

    floating = precision in ("float", "double")
    if floating and u_max is not None:
        check_positive("--u-max", u_max)
    if floating or (fmt != "c" and precision in ("q15", "q31")):
        unused = None if floating else u_max
        given = [f for f, v, d in (("--u-max", unused, None), ("--input-max", input_max, 1.0),
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
    parts = info["error_bound_terms_in"].items()
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
    out: OutDirOpt = "firmware",
    name: NameOpt = "ivc",
    json_out: JsonOpt = False,
) -> None:
    """IVC gain matrix K of a chapter 3 book loop: load xc[0] = K xp[0] at the switch.

    JSON keys: files, precision, tables (table, shape, scale, error_bound, max_error).
    """
    from servokit.export import FirmwareTable
    from servokit.export.designs import book_ivc_gain

    out_dir = _check_common(out, name, fmt, precision)
    refuse_inapplicable("--method", method, {"velocity_weight": ("--velocity-weight", ("jmin",))})
    if method == "pole-zero":  # the §3.3.2 loop's delay fit (scipy.optimize) comes next
        from servokit.cli._render import started

        started("export ivc", f"pole-zero IVC of the §3.3.2 loop -> {out_dir}")
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
    out: OutDirOpt = "firmware",
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

    from servokit._io import read_input_text
    from servokit.errors import ServokitValueError, check_input_file
    from servokit.export import FirmwareTable

    path = check_input_file(path, "--input")
    # size cap, encoding and nesting depth are checked before parsing
    text = read_input_text(path, "--input")
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ServokitValueError(f"--input {path}: not valid JSON ({exc.msg})") from None
        if not isinstance(data, dict) or not data:
            raise ServokitValueError(f'--input {path}: give an object {{"name": [numbers]}}')
        items = list(data.items())
    elif path.suffix.lower() == ".csv":
        try:
            table = np.loadtxt(io.StringIO(text), delimiter=",", ndmin=2)
            items = [(path.stem.replace("-", "_"), table)]
        except ValueError:
            raise ServokitValueError(f"--input {path}: the CSV must hold numbers only") from None
    else:
        raise ServokitValueError(f"--input {path}: use a .json or .csv file")
    from servokit._io import number_array

    try:
        tables = [FirmwareTable(k, number_array(v, f"table {k!r}")) for k, v in items]
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ServokitValueError):
            raise ServokitValueError(f"--input {path}: {exc}") from None
        raise ServokitValueError(f"--input {path}: tables must be arrays of numbers") from None
    for t in tables:
        if not np.all(np.isfinite(t.values)):
            raise ServokitValueError(f"--input {path}: table {t.name!r} holds NaN or inf")
    return tables
