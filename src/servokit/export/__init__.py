"""Firmware export: tables of a design as C (float, double, Q15, Q31), CSV or JSON.

* :class:`FirmwareTable`, :func:`quantize` — named arrays and their fixed-point form;
* :func:`feedforward_tables`, :func:`statespace_tables`, :func:`sos_tables` — the tables
  of a held feedforward input (eqs. 2.40-2.42), a discrete controller's state-space
  matrices, and second-order sections;
* :func:`c_files` — header and source (with a step function for controllers);
* :func:`write_export` — the files on disk (``servokit export``);
* :func:`design_fixed_point`, :func:`fixed_point_response`, :func:`fixed_c_files`,
  :func:`write_fixed_export` — fixed-point controllers (Q15, Q31, Qm.n): L1-scaled
  DF-I sections or modal state space, their bit-true model, C code and error bound.
"""

from __future__ import annotations

from servokit.export.c_code import c_files, c_literal
from servokit.export.files import (
    FILE_FORMATS,
    tables_csv,
    tables_json,
    write_export,
    write_fixed_export,
)
from servokit.export.fixed_c import fixed_c_files
from servokit.export.fixed_model import fixed_point_response, quantize_input
from servokit.export.fixed_point import (
    FixedPointDesign,
    QFormat,
    design_fixed_point,
    node_impulse_responses,
    parse_qformat,
)
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
    "FixedPointDesign",
    "QFormat",
    "Quantized",
    "c_files",
    "c_literal",
    "design_fixed_point",
    "feedforward_tables",
    "fixed_c_files",
    "fixed_point_response",
    "node_impulse_responses",
    "parse_qformat",
    "quantize",
    "quantize_input",
    "sos_tables",
    "statespace_tables",
    "tables_csv",
    "tables_json",
    "write_export",
    "write_fixed_export",
]
