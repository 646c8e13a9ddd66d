"""Fixed-point controllers (Q15, Q31, Qm.n): structure, L1 scaling, quantisation, error bound.

Structure
---------
A discrete controller ``C(z)`` is split as ``C(z) = C_r(z) + r / (z - 1)``: a stable,
proper remainder ``C_r`` and at most one integrator (a pole at ``z = 1``, found by
deflating the denominator).  The integrator has an unbounded L1 gain, so no scaling can
hold it; it is kept apart, in a wide accumulator word (``int32`` for words up to 16
bits, ``int64`` above), scaled by the declared output limit ``u_max`` and clamped by
anti-windup (:mod:`servokit.export.fixed_model`).  ``C_r`` is realised either as

* ``"sos"``: a cascade of second-order sections in **direct form I**.  Each section
  computes ``w_k[n] = b0 w_{k-1}[n] + b1 w_{k-1}[n-1] + b2 w_{k-1}[n-2]
  - a1 w_k[n-1] - a2 w_k[n-2]`` in one wide accumulator and rounds once, so the only
  stored (overflow-prone, noisy) node of a section is its output.  Direct form II
  (and its transpose) store internal nodes whose gain from the input can be far above
  the section's (a notch's poles near the unit circle), so they need extra scaling and
  add rounding points; that is why DF-I is the usual fixed-point choice.  Consecutive
  sections share the history words (the output history of section k is the input
  history of section k+1).
* ``"ss"``: a real modal (block-diagonal) state-space form, ``2x2`` blocks
  ``[[s, w], [-w, s]]`` per complex pole pair: low coefficient sensitivity, one
  rounding per state update.

Scaling
-------
Signals are normalised: the input word value 1.0 is ``input_max`` (``|x| <= input_max``
is the declared range), the output word value 1.0 is ``u_max``.  In the word format
``Qm.n`` (``1 + m + n`` bits, ``n`` fractional) the stored value is ``k 2**-n``; Q15 is
Q0.15, Q31 is Q0.31.  Every stored node ``w_j`` (section output, state) is divided by
``S_j = L1_j / (P (1 - eta_j))`` where ``L1_j = sum_k |h_j[k]|`` is the L1 norm of the
impulse response from the input to the node (its worst-case peak for ``|input| <= 1``)
and ``P`` is the word's largest value; the scales fold into the coefficients.  The
choice is then *verified* on the quantised realisation: the peak of each node is at
most ``L1_q(input -> j) + sum_i d_i L1_q(rounding i -> j)`` (quantised coefficients,
every rounding error ``|e_i| <= d_i``); ``eta_j`` is doubled until it fits.  So no
stored node overflows for inputs in the declared range.

Coefficients of one accumulation (one section, one state row, the output row) share
``cf`` fractional bits, the largest for which every integer fits the word and
``sum |c_i| 2**(W-1)`` (every source word at full scale) fits the accumulator: no
accumulator can overflow, whatever the input word.

Error bound (output units, over ``N`` samples, while the output does not saturate)
---------------------------------------------------------------------------------
``u_max * [ ||h_q - h||_1  +  sum_i d_i ||g_i||_1  +  d_out  +  d_align
+ N (|r_q - r| + d_inc) ]``: the exact response of the quantised remainder against the
float one (coefficient quantisation), each rounding point's bound times the L1 norm from
that point to the output (signal quantisation), the output rounding, the alignment of the
integrator word to the output sum, and the integrator, whose gain error and increment
rounding add up once per sample.  ``d = q/2`` for round-half-up and convergent rounding,
``d = q`` for truncation (``q`` the unit of the word being rounded to).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_positive
from servokit.export.fixed_format import (
    FixedRow,
    QFormat,
    parse_qformat,
    quantize_row,
    rounding_bound,
)
from servokit.export.fixed_network import (
    L1_RADIUS_LIMIT,
    l1_matrix,
    modal_realization,
    node_impulse_responses,
    sos_network,
    sos_sections,
    split_integrator,
    ss_network,
)

__all__ = [
    "OVERFLOWS",
    "REALIZATIONS",
    "ROUNDINGS",
    "FixedPointDesign",
    "FixedRow",
    "Integrator",
    "QFormat",
    "design_fixed_point",
    "design_summary",
    "node_impulse_responses",
    "parse_qformat",
]

ROUNDINGS = ("half-up", "convergent", "truncate")
OVERFLOWS = ("saturate", "wrap")
REALIZATIONS = ("sos", "ss")
_ETA0 = 2.0**-12  # first headroom of a node below full scale (float L1 -> quantised peak)


@dataclass(frozen=True)
class Integrator:
    """The separated integrator ``r / (z - 1)`` in output-normalised units.

    Attributes
    ----------
    gain : FixedRow
        ``r`` per unit normalised input (one coefficient).
    state_frac : int
        Fractional bits of the accumulator-wide integrator word.
    limit : int
        Clamp of the integrator word (anti-windup bound ``V_max``).
    exact_gain : float
        The float design's ``r`` in the same units.
    """

    gain: FixedRow
    state_frac: int
    limit: int
    exact_gain: float


@dataclass(frozen=True)
class FixedPointDesign:
    """A controller in fixed point: everything the C code and the bit-true model need.

    Attributes
    ----------
    realization : str
        ``"sos"`` (DF-I cascade) or ``"ss"`` (modal state space).
    fmt : QFormat
        Word format of input, output and every stored node.
    rounding, overflow : str
        Rounding mode at each requantisation; ``"saturate"`` or ``"wrap"`` at stored nodes.
    input_max, u_max : float
        Physical values of the input and output words' 1.0 (output saturates at ``u_max``).
    rows : tuple of FixedRow
        ``sos``: per section ``[b0, b1, b2, -a1, -a2]``; ``ss``: per state ``[A_i, B_i]``.
    out_row : FixedRow
        ``sos``: ``[g]`` on the last section's output; ``ss``: ``[C, D]``.
    integrator : Integrator or None
        The separated integrator, if the controller has one.
    dt : float
        Sampling period [s].
    node_peak : ndarray
        Proven bound of each stored node's magnitude (value units) for inputs in range.
    bound_terms : dict
        Error-bound terms in output-normalised units (module docstring).
    """

    realization: str
    fmt: QFormat
    rounding: str
    overflow: str
    input_max: float
    u_max: float
    rows: tuple[FixedRow, ...]
    out_row: FixedRow
    integrator: Integrator | None
    dt: float
    node_peak: np.ndarray = field(repr=False)
    bound_terms: dict[str, float] = field(default_factory=dict)

    @property
    def out_max(self) -> int:
        """Output clamp: the integer of ``u_max`` (value 1.0), inside the word."""
        return min(2**self.fmt.frac_bits, self.fmt.hi)

    @property
    def input_lsb(self) -> float:
        """Physical value of one input integer."""
        return math.ldexp(self.input_max, -self.fmt.frac_bits)

    @property
    def output_lsb(self) -> float:
        """Physical value of one output integer."""
        return math.ldexp(self.u_max, -self.fmt.frac_bits)

    def error_bound(self, n_samples: int) -> float:
        """Bound of ``|y_fixed - y_float|`` over ``n_samples`` samples [output unit].

        Parameters
        ----------
        n_samples : int
            Horizon (the integrator's errors grow by one term per sample).

        Returns
        -------
        float
            The bound, valid while the fixed-point output does not saturate.
        """
        t = self.bound_terms
        per_sample = t["integrator_per_sample"]
        fixed = t["coefficient"] + t["signal"] + t["output_rounding"]
        return self.u_max * (fixed + n_samples * per_sample)


# ---------------------------------------------------------------- the design
@dataclass
class _Plan:
    """Unscaled float realisation of ``C_r`` in normalised units (input 1.0 = input_max)."""

    kind: str
    unscaled: np.ndarray  # sos: (K, 6) sections; ss: rows [A | B]
    out: np.ndarray  # ss: [C, D] of y_r per normalised input
    node_l1: np.ndarray  # float L1 from the input to each stored node (unscaled)
    y_l1: float  # float L1 of C_r per normalised input

    def scaled(self, s: np.ndarray, g_out: float) -> tuple[np.ndarray, np.ndarray]:
        """Scaled float rows and out row for node scales ``s`` (``y_norm = g_out y_r``)."""
        if self.kind == "sos":
            prev = np.concatenate([[1.0], s[:-1]])
            sec = self.unscaled
            rows = np.column_stack([sec[:, :3] * (prev / s)[:, None], -sec[:, 4:6]])
            return rows, np.array([s[-1] * g_out])
        nx = s.size
        a = self.unscaled[:, :nx] * s[None, :] / s[:, None]
        b = self.unscaled[:, nx:] / s[:, None]
        out = np.concatenate([self.out[:nx] * s, self.out[nx:]]) * g_out
        return np.hstack([a, b]), out

    def network(self, rows: np.ndarray, out: np.ndarray) -> tuple[np.ndarray, ...]:
        """The network with these (scaled or quantised) coefficient values."""
        if self.kind == "sos":
            return sos_network(rows, float(out[0]))
        return ss_network(rows, out)


def _plan(kind: str, num: np.ndarray, den: np.ndarray, input_max: float) -> _Plan:
    n, d = num * input_max, den  # per normalised input, physical output
    if kind == "sos":
        sos = sos_sections(n, d)
        plan = _Plan(kind, sos, np.zeros(0), np.zeros(0), 0.0)
        a, b, c, dd = plan.network(plan.scaled(np.ones(sos.shape[0]), 1.0)[0], np.ones(1))
    else:
        am, bm, cm, dm = modal_realization(n, d)
        plan = _Plan(kind, np.hstack([am, bm]), np.concatenate([cm[0], dm[0]]), np.zeros(0), 0.0)
        a, b, c, dd = plan.network(plan.unscaled, plan.out)
    l1 = l1_matrix(a, b, c, dd)
    plan.node_l1, plan.y_l1 = l1[:-1, 0], float(l1[-1, 0])
    return plan


def _quantized(plan: _Plan, fmt: QFormat, eta: np.ndarray, g_out: float, integ_extra: int,
               state_frac: int | None) -> tuple[list[FixedRow], FixedRow]:  # fmt: skip
    peak_word = math.ldexp(fmt.hi, -fmt.frac_bits)
    s = np.maximum(plan.node_l1, 1e-300) / (peak_word * (1.0 - eta))
    s[plan.node_l1 == 0] = 1.0
    rows_f, out_f = plan.scaled(s, g_out)
    rows = [quantize_row(r, fmt) for r in rows_f]
    return rows, _quantize_out_row(out_f, fmt, integ_extra, state_frac)


def _quantize_out_row(values: np.ndarray, fmt: QFormat, v_limit: int, state_frac: int | None
                      ) -> FixedRow:  # fmt: skip
    """Output row; with an integrator the aligned integrator word must fit beside it."""
    row = quantize_row(values, fmt)
    if state_frac is None:
        return row
    for cf in range(row.frac, -1, -1):
        ints = np.rint(np.ldexp(values, cf)).astype(np.int64)
        f_sum = min(fmt.frac_bits + cf, state_frac)
        prod = int(np.sum(np.abs(ints))) * 2 ** (fmt.word_bits - 1)
        need = (prod >> (fmt.frac_bits + cf - f_sum)) + (v_limit >> (state_frac - f_sum))
        if need + 1 <= fmt.acc_max:
            return FixedRow(tuple(int(v) for v in ints), cf)
    raise ServokitValueError(f"the output sum does not fit the {fmt.name} accumulator")


def _integrator(r_norm: float, fmt: QFormat, v_max: float) -> Integrator:
    """Integrator gain with a full mantissa and the widest state word that holds ``v_max``."""
    gain = quantize_row(np.array([r_norm]), fmt)
    inc_max = abs(gain.values()[0]) * math.ldexp(2 ** (fmt.word_bits - 1), -fmt.frac_bits)
    state_frac = fmt.acc_bits - 2 - math.frexp(v_max + inc_max)[1]
    if state_frac < fmt.frac_bits:
        raise ServokitValueError(
            f"the integrator does not fit the {fmt.name} accumulator; raise --u-max"
        )
    limit = math.ceil(math.ldexp(v_max, state_frac))
    return Integrator(gain, state_frac, limit, r_norm)


def design_fixed_point(
    ctrl: control.LTI,
    precision: str | QFormat = "q15",
    *,
    realization: str = "sos",
    input_max: float = 1.0,
    u_max: float | None = None,
    rounding: str = "half-up",
    overflow: str = "saturate",
) -> FixedPointDesign:
    """Fixed-point realisation of a discrete SISO controller (module docstring).

    Parameters
    ----------
    ctrl : control.TransferFunction, control.StateSpace or RationalTF
        Discrete SISO controller: stable poles and at most one pole at ``z = 1``.
    precision : str or QFormat
        ``"q15"``, ``"q31"`` or ``"qM.N"``.
    realization : {"sos", "ss"}
        Direct-form-I second-order sections or modal state space.
    input_max : float
        Declared input range ``|x| <= input_max`` (the input word's 1.0).
    u_max : float, optional
        Output saturation (the output word's 1.0); required with an integrator, else
        defaults to the worst-case output ``||c||_1 input_max``.
    rounding : {"half-up", "convergent", "truncate"}
        Rounding at every requantisation.
    overflow : {"saturate", "wrap"}
        Behaviour of a stored node beyond the word (never reached in range).

    Returns
    -------
    FixedPointDesign
        Coefficients, shifts, node bounds and error-bound terms.
    """
    fmt = precision if isinstance(precision, QFormat) else parse_qformat(precision)
    _check_choices(realization, rounding, overflow)
    x_max = check_positive("--input-max", input_max)
    from servokit.models.rational import RationalTF

    # coefficients only: a RationalTF as it is (python-control left unloaded)
    tf = ctrl if isinstance(ctrl, RationalTF) else control.tf(ctrl)
    if tf.ninputs != 1 or tf.noutputs != 1 or not (tf.dt and tf.dt is not True):
        raise ServokitValueError("fixed-point export needs a discrete SISO controller")
    r, num_r, den_r = split_integrator(np.asarray(tf.num[0][0], float),
                                       np.asarray(tf.den[0][0], float))  # fmt: skip
    plan = _plan(realization, num_r, den_r, x_max)
    if u_max is None and r != 0.0:
        raise ServokitValueError(
            "--u-max: the controller has an integrator (pole at z = 1); give the output limit"
        )
    if u_max is None and plan.y_l1 == 0.0:
        raise ServokitValueError("--controller: the controller is zero; nothing to export")
    y_max = check_positive("--u-max", u_max) if u_max is not None else plan.y_l1 * (1 + 2**-10)
    integ = None
    if r != 0.0:
        integ = _integrator(r * x_max / y_max, fmt, 1.0 + plan.y_l1 / y_max)
    design = _scale_and_verify(plan, fmt, rounding, 1.0 / y_max, integ)
    return FixedPointDesign(
        realization, fmt, rounding, overflow, x_max, y_max, *design[:2], integ,
        float(tf.dt), *design[2:],
    )  # fmt: skip


def _check_choices(realization: str, rounding: str, overflow: str) -> None:
    for flag, value, choices in (
        ("--realization", realization, REALIZATIONS),
        ("--rounding", rounding, ROUNDINGS),
        ("--overflow", overflow, OVERFLOWS),
    ):
        if value not in choices:
            raise ServokitValueError(f"{flag} {value!r}: choose one of {', '.join(choices)}")


def _scale_and_verify(plan: _Plan, fmt: QFormat, rounding: str, g_out: float,
                      integ: Integrator | None) -> tuple:  # fmt: skip
    """Scale, quantise, prove the node bounds (doubling headroom where needed), bound errors."""
    eta = np.full(plan.node_l1.size, _ETA0)
    peak_word = math.ldexp(fmt.hi, -fmt.frac_bits)
    v_limit = integ.limit if integ else 0
    state_frac = integ.state_frac if integ else None
    for _ in range(40):
        rows, out_row = _quantized(plan, fmt, eta, g_out, v_limit, state_frac)
        q_rows = np.array([r.values() for r in rows])
        a, b, c, d = plan.network(q_rows, out_row.values())
        _check_quantized_poles(a, fmt, plan.kind)
        l1 = l1_matrix(a, b, c, d)
        deltas = np.array([rounding_bound(fmt, rounding, r.frac) for r in rows])
        peaks = (l1[:-1, 0] + l1[:-1, 1:] @ deltas) * (1 + 1e-9)
        bad = peaks > peak_word
        if not bad.any():
            terms = _bound_terms(plan, fmt, rounding, g_out, (a, b, c, d), l1, deltas,
                                 out_row, integ)  # fmt: skip
            return tuple(rows), out_row, peaks, terms
        eta[bad] = np.minimum(2 * eta[bad] + (peaks[bad] / peak_word - 1), 0.9)
    raise ServokitValueError(f"no scaling keeps every node of the controller within {fmt.name}")


def _check_quantized_poles(a: np.ndarray, fmt: QFormat, kind: str) -> None:
    """Refuse a word whose coefficient rounding moves a pole onto or outside the unit circle
    (or within 1e-5 of it, :data:`~servokit.export.fixed_network.L1_RADIUS_LIMIT`).

    Repeated poles near z = 1 move by about the square root of the coefficient step, so a
    filter stable in float can become unstable in a short word (a double pole at 0.992
    in q15 sections).
    """
    radius = float(np.max(np.abs(np.linalg.eigvals(a)))) if a.size else 0.0
    # the limit of the L1 sums that scale the network: a rounded pole on the circle reads
    # 1 - 3e-14, and one just inside it has no L1 norm that can be summed either
    if radius >= L1_RADIUS_LIMIT:
        other = "ss" if kind == "sos" else "sos"
        raise ServokitValueError(
            f"rounding the coefficients to {fmt.name} moves a pole to radius {radius:.6f} "
            f"(the controller's poles are too close to the unit circle for this word): use "
            f"a longer word (q31) or --realization {other}"
        )


def _bound_terms(plan: _Plan, fmt: QFormat, rounding: str, g_out: float, net: tuple,
                 l1: np.ndarray, deltas: np.ndarray, out_row: FixedRow,
                 integ: Integrator | None) -> dict[str, float]:  # fmt: skip
    """Error-bound terms in output-normalised units (module docstring)."""
    fa, fb, fc, fd = plan.network(*plan.scaled(np.ones(plan.node_l1.size), g_out))
    a, b, c, d = net
    # exact quantised response against the float one: one difference system
    diff = l1_matrix(
        np.block([[a, np.zeros((a.shape[0], fa.shape[1]))],
                  [np.zeros((fa.shape[0], a.shape[1])), fa]]),
        np.vstack([b[:, :1], fb[:, :1]]),
        np.hstack([c[-1:], -fc[-1:]]),
        d[-1:, :1] - fd[-1:, :1],
    )  # fmt: skip
    p = fmt.frac_bits + out_row.frac
    out_shift = p - fmt.frac_bits
    align = 0.0
    per_sample = 0.0
    if integ is not None:
        f_sum = min(p, integ.state_frac)
        out_shift = f_sum - fmt.frac_bits
        align = math.ldexp(1.0, -f_sum)  # one floor shift of the product sum or the state
        inc_shift = fmt.frac_bits + integ.gain.frac - integ.state_frac
        d_inc = math.ldexp(1.0, -integ.state_frac) * (
            0.0 if inc_shift <= 0 else (1.0 if rounding == "truncate" else 0.5)
        )
        per_sample = abs(integ.gain.values()[0] - integ.exact_gain) + d_inc
    return {
        "coefficient": float(diff[0, 0]),
        "signal": float(l1[-1, 1:] @ deltas),
        "output_rounding": rounding_bound(fmt, rounding, out_shift) + align,
        "integrator_per_sample": per_sample,
    }


def design_summary(design: FixedPointDesign, n_samples: int) -> dict[str, object]:
    """JSON-ready facts of a design: formats, scales, node bounds and the error bound.

    Parameters
    ----------
    design : FixedPointDesign
        The design.
    n_samples : int
        Horizon of the error bound.

    Returns
    -------
    dict
        ``realization, input_format, output_format, word_bits, accumulator_bits,
        rounding, overflow, input_max_out, u_max, input_lsb_out, output_lsb_in, n_nodes,
        node_peak, integrator, error_bound, error_bound_n_samples, error_bound_terms_in``
        (the controller's input is in the plant's output unit, ``_out``; its output in
        the plant's input unit, ``_in``, as ``u_max`` and ``error_bound``; the terms in
        that unit, the integrator's per sample; ``node_peak`` in word values, 1.0 = the
        word's one).
    """
    f = design.fmt
    return {
        "realization": design.realization,
        "input_format": f.name,
        "output_format": f.name,
        "word_bits": f.word_bits,
        "accumulator_bits": f.acc_bits,
        "rounding": design.rounding,
        "overflow": design.overflow,
        "input_max_out": design.input_max,
        "u_max": design.u_max,
        "input_lsb_out": design.input_lsb,
        "output_lsb_in": design.output_lsb,
        "n_nodes": len(design.rows),
        "node_peak": [float(p) for p in design.node_peak],
        "integrator": design.integrator is not None,
        "error_bound": design.error_bound(n_samples),
        "error_bound_n_samples": n_samples,
        "error_bound_terms_in": {k: v * design.u_max for k, v in design.bound_terms.items()},
    }
