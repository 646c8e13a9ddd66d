"""C header + source of a fixed-point controller (:mod:`servokit.export.fixed_point`).

The code is C99 with ``<stdint.h>`` only, free of undefined and implementation-defined
behaviour: products are formed in the accumulator type (``int32_t`` for words up to 16
bits, ``int64_t`` above), right shifts of negative values are written as
``~(~x >> s)`` (a floor, which gcc compiles to an arithmetic shift), remainders are
taken with ``&`` on exact-width (two's-complement) types, left shifts are
multiplications, and wrap-around goes through the unsigned type.  Every literal is an
integer except the documented LSB macros, which must be finite (a non-finite value is
refused, never written).  :func:`~servokit.export.fixed_model.fixed_point_response`
models it bit for bit.
"""

from __future__ import annotations

import math

from servokit.errors import ServokitValueError
from servokit.export.fixed_point import FixedPointDesign, FixedRow

__all__ = ["fixed_c_files"]


def _int(v: int, ctype: str) -> str:
    """An integer literal of ``ctype`` (64-bit through INT64_C; no bare minimum literal)."""
    if ctype == "int64_t":
        return f"INT64_C({v})" if v > -(2**63) else "(-INT64_C(9223372036854775807) - 1)"
    if v == -(2**31):
        return "(-2147483647 - 1)"
    return str(v)


def _double(v: float) -> str:
    if not math.isfinite(v):
        raise ServokitValueError(f"refusing to write the non-finite value {v!r} to C")
    return repr(float(v))


def _rows_text(rows: tuple[FixedRow, ...] | list[FixedRow], ctype: str) -> str:
    return ",\n".join("    {" + ", ".join(_int(c, ctype) for c in r.coefs) + "}" for r in rows)


def _helpers(d: FixedPointDesign, t: str) -> str:
    """``shr`` (rounded shift) and ``store`` (to the word) for this design's modes."""
    acc, word, f = d.fmt.acc_ctype, d.fmt.ctype, d.fmt
    rnd = {
        "half-up": "    if ((x & (((ACC)1 << s) - 1)) >= ((ACC)1 << (s - 1))) f += 1;\n",
        "convergent": (
            "    {\n        ACC rem = x & (((ACC)1 << s) - 1), half = (ACC)1 << (s - 1);\n"
            "        if (rem > half || (rem == half && (f & 1))) f += 1;\n    }\n"
        ),
        "truncate": "",
    }[d.rounding].replace("ACC", acc)
    if d.overflow == "saturate":
        body = f"    return ({word})(x > {t.upper()}_WORD_MAX ? {t.upper()}_WORD_MAX : " \
               f"(x < {t.upper()}_WORD_MIN ? {t.upper()}_WORD_MIN : x));"  # fmt: skip
    else:
        u = "uint32_t" if f.acc_bits == 32 else "uint64_t"
        body = (
            f"    {u} b = ({u})x & ((({u})1 << {f.word_bits}) - 1u);\n"
            f"    return ({word})(b > ({u}){t.upper()}_WORD_MAX ? "
            f"({acc})b - (({acc})1 << {f.word_bits}) : ({acc})b);"
        )
    return f"""
/* floor(x / 2^s) with the selected rounding ({d.rounding}); s <= 0 multiplies exactly */
static {acc} {t}_shr({acc} x, int s)
{{
    {acc} f;
    if (s <= 0) return x * (({acc})1 << -s);
    f = x >= 0 ? x >> s : ~(~x >> s);
{rnd}    return f;
}}

/* accumulator value to a stored word ({d.overflow}) */
static {word} {t}_store({acc} x)
{{
{body}
}}
"""


def _header_doc(d: FixedPointDesign, t: str, n_samples: int) -> str:
    f = d.fmt
    integ = (
        f"   Integrator r/(z-1) kept apart in a {f.acc_ctype} word ({d.integrator.state_frac} "
        f"fractional bits), clamped to +-{t.upper()}_V_MAX;\n   anti-windup: no increment "
        "while the unclamped output is beyond +-u_max in the increment's direction.\n"
        if d.integrator
        else ""
    )
    form = "DF-I second-order sections" if d.realization == "sos" else "modal state space"
    m = t.upper()
    return (
        f"/* {t}: fixed-point {form}, {f.name} words ({f.ctype}), {f.acc_ctype} "
        f"accumulators, dt = {d.dt:.9g} s.\n"
        f"   Input  {f.name}: x_phys = x * {m}_INPUT_LSB  (1.0 = input_max = "
        f"{d.input_max:.9g}).\n"
        f"   Output {f.name}: u_phys = y * {m}_OUTPUT_LSB (1.0 = u_max = {d.u_max:.9g}), "
        f"saturated at +-{m}_OUT_MAX.\n"
        f"   Rounding {d.rounding}, stored nodes {d.overflow}; every node is scaled by its "
        "L1 gain so it\n   cannot overflow for |x| <= input_max.\n"
        f"{integ}"
        f"   |u - u_float| <= {d.error_bound(n_samples):.6g} over {n_samples} samples "
        "while unsaturated.\n"
        f"   Call {t}_init once, then {t}_step once per sample. */\n"
    )


def _macros(d: FixedPointDesign, t: str) -> str:
    f, m = d.fmt, t.upper()
    lines = [
        f"#define {m}_WORD_BITS {f.word_bits}",
        f"#define {m}_FRAC_BITS {f.frac_bits}",
        f"#define {m}_WORD_MAX {_int(f.hi, f.acc_ctype)}",
        f"#define {m}_WORD_MIN (-{m}_WORD_MAX - 1)",
        f"#define {m}_OUT_MAX {_int(d.out_max, f.acc_ctype)}",
        f"#define {m}_INPUT_LSB {_double(d.input_lsb)}",
        f"#define {m}_OUTPUT_LSB {_double(d.output_lsb)}",
    ]
    if d.integrator:
        lines.append(f"#define {m}_V_MAX {_int(d.integrator.limit, f.acc_ctype)}")
    return "\n".join(lines) + "\n"


def _output_code(d: FixedPointDesign, t: str, acc_expr: str) -> str:
    """Statements computing ``ylin`` (unclamped output word) from the output row."""
    acc, n = d.fmt.acc_ctype, d.fmt.frac_bits
    p = n + d.out_row.frac
    if d.integrator is None:
        return f"    ylin = {t}_shr({acc_expr}, {p - n});\n"
    fs = min(p, d.integrator.state_frac)
    a1, a2 = p - fs, d.integrator.state_frac - fs
    floor = "".join(
        f"        {w} = {w} >= 0 ? {w} >> {k} : ~(~{w} >> {k});\n"
        for w, k in (("a", a1), ("v", a2))
        if k > 0
    )
    return (
        f"    {{\n        {acc} a = {acc_expr}, v = s->v;\n{floor}"
        f"        ylin = {t}_shr(a + v, {fs - n});\n    }}\n"
    )


def _integrator_code(d: FixedPointDesign, t: str) -> str:
    it = d.integrator
    if it is None:
        return "    (void)ylin;\n"
    acc, m = d.fmt.acc_ctype, t.upper()
    s = d.fmt.frac_bits + it.gain.frac - it.state_frac
    return (
        f"    {{\n        {acc} inc = {t}_shr(({acc}){_int(it.gain.coefs[0], acc)} * x, {s}), v;\n"
        f"        if ((ylin > {m}_OUT_MAX && inc > 0) || (ylin < -{m}_OUT_MAX && inc < 0))"
        " inc = 0;\n"
        f"        v = s->v + inc;\n"
        f"        s->v = v > {m}_V_MAX ? {m}_V_MAX : (v < -{m}_V_MAX ? -{m}_V_MAX : v);\n    }}\n"
    )  # fmt: skip


def _sos_parts(d: FixedPointDesign, t: str) -> tuple[str, str]:
    f, k = d.fmt, len(d.rows)
    acc, word = f.acc_ctype, f.ctype
    state = f"typedef struct {{ {word} w[{k + 1}][2]; {acc} v; }} {t}_state_t;\n"
    body = f"""
/* per section [b0 b1 b2 -a1 -a2] with {t}_SHIFT[k] fractional bits */
static const {word} {t}_COEF[{k}][5] = {{
{_rows_text(d.rows, word)}
}};
static const int {t}_SHIFT[{k}] = {{{", ".join(str(r.frac) for r in d.rows)}}};

void {t}_init({t}_state_t *s)
{{
    for (int k = 0; k <= {k}; ++k) s->w[k][0] = s->w[k][1] = 0;
    s->v = 0;
}}

{word} {t}_step({t}_state_t *s, {word} x)
{{
    {word} w[{k + 1}];
    {acc} ylin;
    w[0] = x;
    for (int k = 0; k < {k}; ++k) {{
        const {word} *c = {t}_COEF[k];
        {acc} acc = ({acc})c[0] * w[k] + ({acc})c[1] * s->w[k][0] + ({acc})c[2] * s->w[k][1]
                  + ({acc})c[3] * s->w[k + 1][0] + ({acc})c[4] * s->w[k + 1][1];
        w[k + 1] = {t}_store({t}_shr(acc, {t}_SHIFT[k]));
    }}
{_output_code(d, t, f"({acc}){_int(d.out_row.coefs[0], acc)} * w[{k}]")}\
    for (int k = 0; k <= {k}; ++k) {{
        s->w[k][1] = s->w[k][0];
        s->w[k][0] = w[k];
    }}
{_integrator_code(d, t)}\
    return ({word})(ylin > {t.upper()}_OUT_MAX ? {t.upper()}_OUT_MAX
                  : (ylin < -{t.upper()}_OUT_MAX ? -{t.upper()}_OUT_MAX : ylin));
}}
"""
    return state, body


def _ss_parts(d: FixedPointDesign, t: str) -> tuple[str, str]:
    f, nx = d.fmt, len(d.rows)
    acc, word = f.acc_ctype, f.ctype
    state = f"typedef struct {{ {word} x[{nx}]; {acc} v; }} {t}_state_t;\n"
    body = f"""
/* state rows [A_i B_i] with {t}_SHIFT[i] fractional bits; output row [C D] */
static const {word} {t}_COEF[{nx}][{nx + 1}] = {{
{_rows_text(d.rows, word)}
}};
static const int {t}_SHIFT[{nx}] = {{{", ".join(str(r.frac) for r in d.rows)}}};
static const {word} {t}_OUT[{nx + 1}] = {{{", ".join(_int(c, word) for c in d.out_row.coefs)}}};

void {t}_init({t}_state_t *s)
{{
    for (int i = 0; i < {nx}; ++i) s->x[i] = 0;
    s->v = 0;
}}

{word} {t}_step({t}_state_t *s, {word} x)
{{
    {word} next[{nx}];
    {acc} ylin, y = ({acc}){t}_OUT[{nx}] * x;
    for (int j = 0; j < {nx}; ++j) y += ({acc}){t}_OUT[j] * s->x[j];
{_output_code(d, t, "y")}\
    for (int i = 0; i < {nx}; ++i) {{
        {acc} acc = ({acc}){t}_COEF[i][{nx}] * x;
        for (int j = 0; j < {nx}; ++j) acc += ({acc}){t}_COEF[i][j] * s->x[j];
        next[i] = {t}_store({t}_shr(acc, {t}_SHIFT[i]));
    }}
    for (int i = 0; i < {nx}; ++i) s->x[i] = next[i];
{_integrator_code(d, t)}\
    return ({word})(ylin > {t.upper()}_OUT_MAX ? {t.upper()}_OUT_MAX
                  : (ylin < -{t.upper()}_OUT_MAX ? -{t.upper()}_OUT_MAX : ylin));
}}
"""
    return state, body


def fixed_c_files(
    design: FixedPointDesign, module: str, *, title: str = "", n_samples: int = 10_000
) -> tuple[str, str]:
    """Header and source of ``<module>_<sos|ss>_init`` / ``_step`` for a fixed-point design.

    Parameters
    ----------
    design : FixedPointDesign
        The design.
    module : str
        C identifier prefixing every name (files ``module.h`` / ``module.c``).
    title : str
        One line describing the controller.
    n_samples : int
        Horizon of the error bound written in the header.

    Returns
    -------
    header, source : str
        The two files.
    """
    from servokit import __version__

    t = f"{module}_{design.realization}"
    state, body = (_sos_parts if design.realization == "sos" else _ss_parts)(design, t)
    guard = f"{module.upper()}_H"
    word = design.fmt.ctype
    banner = (
        f"/* {module}: {title or 'fixed-point controller'}\n"
        f"   Generated by servokit {__version__}; do not edit. */\n"
    )
    header = (
        banner + f"#ifndef {guard}\n#define {guard}\n\n#include <stdint.h>\n\n"
        + _header_doc(design, t, n_samples) + _macros(design, t) + "\n" + state
        + f"void {t}_init({t}_state_t *s);\n"
        + f"{word} {t}_step({t}_state_t *s, {word} x);\n"
        + f"\n#endif /* {guard} */\n"
    )  # fmt: skip
    source = banner + f'#include "{module}.h"\n' + _helpers(design, t) + body
    return header, source
