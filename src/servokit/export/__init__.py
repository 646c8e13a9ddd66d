"""Firmware export: tables of a design as C (float, double, Q15, Q31), CSV or JSON.

* :class:`FirmwareTable`, :func:`quantize` — named arrays and their fixed-point form;
* :func:`feedforward_tables`, :func:`statespace_tables`, :func:`sos_tables` — the tables
  of a held feedforward input (eqs. 2.40-2.42), a discrete controller's state-space
  matrices, and second-order sections;
* :func:`c_files` — header and source (with a step function for controllers);
* :func:`write_export` — the files on disk (``servokit export``).
"""

from __future__ import annotations

from servokit.export.c_code import c_files, c_literal
from servokit.export.files import FILE_FORMATS, tables_csv, tables_json, write_export
from servokit.export.tables import (
    FORMATS,
    FirmwareTable,
    Quantized,
    feedforward_tables,
    quantize,
    sos_tables,
    statespace_tables,
)

__all__ = [
    "FILE_FORMATS",
    "FORMATS",
    "FirmwareTable",
    "Quantized",
    "c_files",
    "c_literal",
    "feedforward_tables",
    "quantize",
    "sos_tables",
    "statespace_tables",
    "tables_csv",
    "tables_json",
    "write_export",
]
