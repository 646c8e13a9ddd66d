"""C header + source for firmware tables, and step functions of discrete controllers.

Float tables are written with the shortest decimal that converts back to the same
``float`` (or ``double``) under C's correctly rounded conversion, so the C values equal
``numpy.float32(value)`` (or the Python float) exactly.  Q15 / Q31 tables are written as
``int16_t`` / ``int32_t`` with ``NAME_SCALE`` (value of one unit), the stated rounding
bound ``NAME_ERROR_BOUND`` (half a unit) and the measured ``NAME_MAX_ERROR``.

Controllers additionally get a step function (floating point only): ``<m>_step`` for a
state-space realisation (SISO, ``y = C x + D u`` then ``x <- A x + B u``) and
``<m>_sos_step`` for second-order sections in transposed direct form II, the form of
``scipy.signal.sosfilt``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit.errors import ServokitValueError
from servokit.export.tables import FORMATS, FirmwareTable, quantize

__all__ = ["c_files", "c_literal"]


def c_literal(value: float, fmt: str) -> str:
    """A C literal of ``value`` that converts back exactly (``float``/``double``).

    Parameters
    ----------
    value : float
        The value.
    fmt : str
        ``"float"`` or ``"double"``.

    Returns
    -------
    str
        E.g. ``"1.2345678e-05f"`` for float.

    Raises
    ------
    ServokitValueError
        For a non-finite value or one that overflows ``float``: never written to C.
    """
    too_big = fmt == "float" and abs(value) > float(np.finfo(np.float32).max)
    if not np.isfinite(value) or too_big:
        raise ServokitValueError(f"refusing to write the non-finite {fmt} value {value!r} to C")
    if fmt == "float":
        return np.format_float_scientific(np.float32(value), unique=True, trim="0") + "f"
    return repr(float(value))


def _values_text(values: np.ndarray, fmt: str) -> str:
    def row(r: np.ndarray) -> str:
        return ", ".join(
            c_literal(v, fmt) if fmt in ("float", "double") else str(int(v)) for v in r
        )

    if values.ndim == 1:
        return "{\n    " + row(values) + "\n}"
    return "{\n" + ",\n".join("    {" + row(r) + "}" for r in values) + "\n}"


def _table_parts(module: str, table: FirmwareTable, fmt: str) -> tuple[list[str], str]:
    """Header lines and source definition of one table."""
    ctype, bits = FORMATS[fmt]
    cname = f"{module}_{table.name}"
    macro = cname.upper()
    dims = f"[{macro}_LEN]" if table.values.ndim == 1 else f"[{macro}_ROWS][{macro}_COLS]"
    head = [f"/* {table.name}: {table.description}" + (f" [{table.unit}]" if table.unit else "")]
    if table.values.ndim == 1:
        defines = [f"#define {macro}_LEN {table.values.size}"]
    else:
        rows, cols = table.values.shape
        defines = [f"#define {macro}_ROWS {rows}", f"#define {macro}_COLS {cols}"]
    data = table.values
    if bits is not None:
        q = quantize(table.values, bits)
        head.append(
            f"   Q{bits}: value = {cname}[i] * {macro}_SCALE (2^{q.exponent - bits}); "
            f"rounding error <= {macro}_ERROR_BOUND, worst {macro}_MAX_ERROR"
        )
        defines += [
            f"#define {macro}_SCALE {c_literal(q.scale, 'double')}",
            f"#define {macro}_ERROR_BOUND {c_literal(q.error_bound, 'double')}",
            f"#define {macro}_MAX_ERROR {c_literal(q.max_error, 'double')}",
        ]
        data = q.integers
    head[-1] += " */"
    header = head + defines + [f"extern const {ctype} {cname}{dims};", ""]
    source = f"const {ctype} {cname}{dims} = {_values_text(data, fmt)};\n"
    return header, source


def _ss_step(module: str, prefix: str, nx: int, ctype: str) -> tuple[str, str]:
    """Prototype and body of the state-space step of a SISO controller ``prefix``."""
    t = f"{module}_{prefix}"
    n = max(nx, 1)  # C has no zero-length arrays; a static gain keeps one unused state
    proto = (
        f"typedef struct {{ {ctype} x[{n}]; }} {t}_state_t;\n"
        f"void {t}_reset({t}_state_t *s);\n"
        f"{ctype} {t}_step({t}_state_t *s, {ctype} u);\n"
    )
    body = f"""
void {t}_reset({t}_state_t *s)
{{
    for (int i = 0; i < {n}; ++i) s->x[i] = 0;
}}

{ctype} {t}_step({t}_state_t *s, {ctype} u)
{{
    {ctype} y = {t}_D[0][0] * u;
    {ctype} next[{n}] = {{0}};
    for (int i = 0; i < {nx}; ++i) y += {t}_C[0][i] * s->x[i];
    for (int i = 0; i < {nx}; ++i) {{
        next[i] = {t}_B[i][0] * u;
        for (int j = 0; j < {nx}; ++j) next[i] += {t}_A[i][j] * s->x[j];
    }}
    for (int i = 0; i < {nx}; ++i) s->x[i] = next[i];
    return y;
}}
"""
    return proto, body


def _sos_step(module: str, name: str, n_sections: int, ctype: str) -> tuple[str, str]:
    """Prototype and body of the transposed-direct-form-II cascade ``name``."""
    t = f"{module}_{name}"
    proto = (
        f"typedef struct {{ {ctype} z[{n_sections}][2]; }} {t}_state_t;\n"
        f"void {t}_reset({t}_state_t *s);\n"
        f"{ctype} {t}_step({t}_state_t *s, {ctype} x);\n"
    )
    body = f"""
void {t}_reset({t}_state_t *s)
{{
    for (int k = 0; k < {n_sections}; ++k) s->z[k][0] = s->z[k][1] = 0;
}}

{ctype} {t}_step({t}_state_t *s, {ctype} x)
{{
    for (int k = 0; k < {n_sections}; ++k) {{
        const {ctype} *c = {t}[k];
        {ctype} y = c[0] * x + s->z[k][0];
        s->z[k][0] = c[1] * x - c[4] * y + s->z[k][1];
        s->z[k][1] = c[2] * x - c[5] * y;
        x = y;
    }}
    return x;
}}
"""
    return proto, body


def _steps(
    module: str, tables: Sequence[FirmwareTable], step: str | None, fmt: str
) -> tuple[str, str]:
    if step is None:
        return "", ""
    ctype, bits = FORMATS[fmt]
    if bits is not None:
        raise ServokitValueError(
            f"a {step} step function is generated in float or double only; "
            "use --precision float or double (or export the tables alone)"
        )
    if step == "sos":
        return _sos_step(module, tables[0].name, tables[0].values.shape[0], ctype)
    prefix = tables[0].name.removesuffix("_A")
    a, b, c, _ = (t.values for t in tables)
    if b.shape[1] != 1 or c.shape[0] != 1:
        raise ServokitValueError("a state-space step function needs a SISO controller")
    return _ss_step(module, prefix, a.shape[0], ctype)


def c_files(
    tables: Sequence[FirmwareTable],
    module: str,
    fmt: str = "float",
    *,
    step: str | None = None,
    title: str = "",
) -> tuple[str, str]:
    """C header and source of ``tables`` (and a step function), as text.

    Parameters
    ----------
    tables : sequence of FirmwareTable
        The tables; for ``step="ss"`` the four tables of
        :func:`~servokit.export.tables.statespace_tables`, for ``step="sos"`` the table of
        :func:`~servokit.export.tables.sos_tables`.
    module : str
        C identifier prefixing every name; the files are ``module.h`` / ``module.c``.
    fmt : str
        ``"float"``, ``"double"``, ``"q15"`` or ``"q31"``.
    step : {None, "ss", "sos"}
        Also generate the controller's step function.
    title : str
        One line describing the content (a comment at the top).

    Returns
    -------
    header, source : str
        The two files.
    """
    if fmt not in FORMATS:
        raise ServokitValueError(f"--precision {fmt!r}: choose one of {', '.join(FORMATS)}")
    if step not in (None, "ss", "sos"):
        raise ServokitValueError(f"step {step!r}: choose 'ss' or 'sos'")
    from servokit import __version__

    guard = f"{module.upper()}_H"
    parts = [_table_parts(module, t, fmt) for t in tables]
    proto, body = _steps(module, tables, step, fmt)
    banner = (
        f"/* {module}: {title or 'firmware tables'}\n"
        f"   Generated by servokit {__version__}; do not edit. */\n"
    )
    header = (
        banner
        + f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n"
        + "\n".join(line for h, _ in parts for line in h)
        + ("\n" + proto if proto else "")
        + f"\n#endif /* {guard} */\n"
    )
    source = banner + f'#include "{module}.h"\n\n' + "\n".join(s for _, s in parts) + body
    return header, source
