"""Writing an export to disk: C header + source, CSV or JSON (each file atomically)."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from servokit.errors import ServokitValueError
from servokit.export.c_code import c_files
from servokit.export.tables import FORMATS, FirmwareTable, quantize

if TYPE_CHECKING:
    from servokit.export.fixed_point import FixedPointDesign

__all__ = ["FILE_FORMATS", "tables_csv", "tables_json", "write_export", "write_fixed_export"]

#: ``--format`` choices.
FILE_FORMATS = ("c", "csv", "json")


def _fixed(table: FirmwareTable, fmt: str) -> dict[str, Any]:
    bits = FORMATS[fmt][1]
    if bits is None:
        return {}
    q = quantize(table.values, bits)
    return {
        "frac_bits": bits,
        "scale": q.scale,
        "error_bound": q.error_bound,
        "max_error": q.max_error,
        "integers": q.integers.tolist(),
    }


def tables_json(tables: Sequence[FirmwareTable], module: str, fmt: str) -> dict[str, Any]:
    """The export as a JSON-ready dict (values, and the fixed-point integers and scale).

    Parameters
    ----------
    tables : sequence of FirmwareTable
        The tables.
    module : str
        Export name.
    fmt : str
        ``"float"``, ``"double"``, ``"q15"`` or ``"q31"``.

    Returns
    -------
    dict
        ``module, precision, servokit_version, tables``.
    """
    from servokit import __version__

    return {
        "module": module,
        "precision": fmt,
        "servokit_version": __version__,
        "tables": [
            {
                "name": t.name,
                "description": t.description,
                "unit": t.unit,
                "shape": list(t.values.shape),
                "values": t.values.tolist(),
                **_fixed(t, fmt),
            }
            for t in tables
        ],
    }


def tables_csv(table: FirmwareTable, fmt: str) -> str:
    """One table as CSV in long form: ``row, col, value`` (plus ``q15``/``q31``).

    Parameters
    ----------
    table : FirmwareTable
        The table (a 1-D table has ``col`` 0).
    fmt : str
        Precision; fixed point adds the integer column.

    Returns
    -------
    str
        CSV text.
    """
    values = table.values.reshape(table.values.shape[0], -1)
    bits = FORMATS[fmt][1]
    ints = quantize(values, bits).integers if bits is not None else None
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["row", "col", "value"] + ([fmt] if bits is not None else []))
    for (i, j), v in zip(_indices(values.shape), values.ravel(), strict=True):
        writer.writerow([i, j, repr(float(v))] + ([int(ints[i, j])] if ints is not None else []))
    return buf.getvalue()


def _indices(shape: tuple[int, ...]) -> list[tuple[int, int]]:
    return [(i, j) for i in range(shape[0]) for j in range(shape[1])]


def write_export(
    tables: Sequence[FirmwareTable],
    outdir: Path,
    module: str,
    *,
    file_format: str = "c",
    precision: str = "float",
    step: str | None = None,
    title: str = "",
) -> list[Path]:
    """Write the export files into ``outdir``; return their paths.

    Parameters
    ----------
    tables : sequence of FirmwareTable
        The tables.
    outdir : Path
        Existing or new directory.
    module : str
        File stem and C prefix.
    file_format : str
        ``"c"`` (``module.h`` + ``module.c``), ``"csv"`` (``module_<table>.csv`` each) or
        ``"json"`` (``module.json``).
    precision : str
        ``"float"``, ``"double"``, ``"q15"`` or ``"q31"``.
    step : {None, "ss", "sos"}
        For C: also generate the controller step function.
    title : str
        A line describing the export.

    Returns
    -------
    list of Path
        The files written.
    """
    from servokit.report.results import write_atomic

    if file_format not in FILE_FORMATS:
        raise ServokitValueError(f"--format {file_format!r}: choose one of c, csv, json")
    if precision not in FORMATS:
        raise ServokitValueError(f"--precision {precision!r}: choose one of {', '.join(FORMATS)}")
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    if file_format == "c":
        header, source = c_files(tables, module, precision, step=step, title=title)
        return [
            write_atomic(outdir / f"{module}.h", header),
            write_atomic(outdir / f"{module}.c", source),
        ]
    if file_format == "json":
        text = json.dumps(tables_json(tables, module, precision), indent=2)
        return [write_atomic(outdir / f"{module}.json", text + "\n")]
    return [
        write_atomic(outdir / f"{module}_{t.name}.csv", tables_csv(t, precision)) for t in tables
    ]


def write_fixed_export(
    design: FixedPointDesign, outdir: Path, module: str, *, title: str = "", n_samples: int = 10_000
) -> list[Path]:
    """Write ``module.h`` and ``module.c`` of a fixed-point controller; return their paths.

    Parameters
    ----------
    design : FixedPointDesign
        From :func:`~servokit.export.fixed_point.design_fixed_point`.
    outdir : Path
        Existing or new directory.
    module : str
        File stem and C prefix.
    title : str
        A line describing the controller.
    n_samples : int
        Horizon of the error bound stated in the header.

    Returns
    -------
    list of Path
        The two files.
    """
    from servokit.export.fixed_c import fixed_c_files
    from servokit.report.results import write_atomic

    header, source = fixed_c_files(design, module, title=title, n_samples=n_samples)
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    return [
        write_atomic(outdir / f"{module}.h", header),
        write_atomic(outdir / f"{module}.c", source),
    ]
