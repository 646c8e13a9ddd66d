"""Bit-true Python model of the generated fixed-point step functions.

Every operation is done on Python integers (exact; no int64 overflow of Q31 products),
with exactly the C code's primitives:

* ``shr(x, s)``: ``floor(x / 2**s)`` (Python's ``>>`` floors negatives, as the C code's
  ``x >= 0 ? x >> s : ~(~x >> s)`` does without implementation-defined shifts), then
  ``+1`` by the rounding mode from the remainder ``x & (2**s - 1)``: round-half-up if
  the remainder is at least half, convergent (half to even) if above half or exactly
  half with an odd quotient, never for truncation; ``s <= 0`` multiplies by ``2**-s``;
* ``store(x)``: to the word, by saturation or two's-complement wrap-around;
* the step: output row (plus the aligned integrator word), rounding, clamp to
  ``+-out_max``; then the stored nodes (DF-I sections in order, or all state rows from
  the old states); then the integrator.

Anti-windup (conditional integration plus clamping): the increment ``r x`` is skipped
when the unclamped output is beyond ``+-out_max`` and the increment has the same sign,
and the integrator word is clamped to ``+-V_max`` (``V_max = u_max +`` the remainder's
worst-case output), so it can hold any value it has while the output is unsaturated.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from servokit.errors import ServokitValueError
from servokit.export.fixed_point import FixedPointDesign, QFormat

__all__ = ["fixed_point_response", "quantize_input", "shr", "store"]


def shr(x: int, s: int, rounding: str) -> int:
    """``x / 2**s`` rounded as the C code rounds (``s <= 0``: exact ``x * 2**-s``).

    Parameters
    ----------
    x : int
        Accumulator value.
    s : int
        Shift.
    rounding : str
        ``"half-up"``, ``"convergent"`` or ``"truncate"`` (floor).

    Returns
    -------
    int
        The rounded quotient.
    """
    if s <= 0:
        return x << -s
    f = x >> s
    rem = x & ((1 << s) - 1)
    half = 1 << (s - 1)
    if rounding == "half-up":
        f += rem >= half
    elif rounding == "convergent":
        f += rem > half or (rem == half and f & 1)
    return f


def store(x: int, fmt: QFormat, overflow: str) -> int:
    """The word stored from accumulator value ``x`` (saturate or wrap).

    Parameters
    ----------
    x : int
        Value.
    fmt : QFormat
        Word format.
    overflow : str
        ``"saturate"`` or ``"wrap"``.

    Returns
    -------
    int
        A word integer.
    """
    if overflow == "saturate":
        return min(max(x, fmt.lo), fmt.hi)
    return ((x - fmt.lo) & ((1 << fmt.word_bits) - 1)) + fmt.lo


def quantize_input(design: FixedPointDesign, x: np.ndarray) -> np.ndarray:
    """Physical inputs as input words: ``round(x / input_lsb)``, clamped to the word.

    Parameters
    ----------
    design : FixedPointDesign
        The design.
    x : ndarray
        Inputs [controller input unit].

    Returns
    -------
    ndarray of int64
        The words.
    """
    q = np.rint(np.asarray(x, float) / design.input_lsb)
    return np.clip(q, design.fmt.lo, design.fmt.hi).astype(np.int64)


def _dot(coefs: Sequence[int], src: Sequence[int]) -> int:
    return sum(c * v for c, v in zip(coefs, src, strict=True))


class _Machine:
    """The state and one step of the generated code."""

    def __init__(self, d: FixedPointDesign) -> None:
        self.d = d
        n_nodes = len(d.rows)
        # sos: history w_k[n-1], w_k[n-2] for k = 0..K; ss: the states
        self.hist = [[0, 0] for _ in range(n_nodes + 1)] if d.realization == "sos" else None
        self.x = [0] * n_nodes
        self.v = 0
        self.pre: list[int] = [0] * n_nodes  # last unclamped node values (overflow checks)

    def _node(self, i: int, acc: int) -> int:
        d = self.d
        val = shr(acc, d.rows[i].frac, d.rounding)
        self.pre[i] = val
        return store(val, d.fmt, d.overflow)

    def _output(self, acc: int) -> tuple[int, int]:
        d, n = self.d, self.d.fmt.frac_bits
        p = n + d.out_row.frac
        if d.integrator is None:
            ylin = shr(acc, p - n, d.rounding)
        else:
            f_sum = min(p, d.integrator.state_frac)
            total = (acc >> (p - f_sum)) + (self.v >> (d.integrator.state_frac - f_sum))
            ylin = shr(total, f_sum - n, d.rounding)
        return ylin, min(max(ylin, -d.out_max), d.out_max)

    def _integrate(self, x: int, ylin: int) -> None:
        d, it = self.d, self.d.integrator
        if it is None:
            return
        s = d.fmt.frac_bits + it.gain.frac - it.state_frac
        inc = shr(it.gain.coefs[0] * x, s, d.rounding)
        if (ylin > d.out_max and inc > 0) or (ylin < -d.out_max and inc < 0):
            inc = 0
        self.v = min(max(self.v + inc, -it.limit), it.limit)

    def step(self, x: int) -> int:
        d = self.d
        if d.realization == "sos":
            w = self._sections(x)
            ylin, y = self._output(d.out_row.coefs[0] * w[-1])
            for k, wk in enumerate(w):
                self.hist[k] = [wk, self.hist[k][0]]
        else:
            src = [*self.x, x]
            ylin, y = self._output(_dot(d.out_row.coefs, src))
            self.x = [self._node(i, _dot(r.coefs, src)) for i, r in enumerate(d.rows)]
        self._integrate(x, ylin)
        return y

    def _sections(self, x: int) -> list[int]:
        """DF-I sections in order from the old histories: ``[w_0, ..., w_K]`` at this step."""
        w, h = [x], self.hist
        for k, row in enumerate(self.d.rows):
            src = (w[k], h[k][0], h[k][1], h[k + 1][0], h[k + 1][1])
            w.append(self._node(k, _dot(row.coefs, src)))
        return w


def fixed_point_response(
    design: FixedPointDesign, x: np.ndarray, *, nodes: bool = False
) -> np.ndarray | tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output words of the generated step function for input words ``x`` (bit for bit).

    Parameters
    ----------
    design : FixedPointDesign
        The design (:func:`~servokit.export.fixed_point.design_fixed_point`).
    x : ndarray of int
        Input words (within the word's range), from the initial (zero) state.
    nodes : bool
        Also return every stored node's value before saturation/wrap-around and the
        integrator word, per sample.

    Returns
    -------
    y : ndarray of int64
        Output words (``y * design.output_lsb`` in output units).
    pre : ndarray (N, n_nodes), only with ``nodes``
        Unclamped node values.
    v : ndarray (N,), only with ``nodes``
        Integrator word after each step (0 without an integrator).
    """
    xs = np.asarray(x)
    if xs.ndim != 1 or not np.issubdtype(xs.dtype, np.integer):
        raise ServokitValueError("fixed_point_response takes a 1-D array of input words")
    if xs.size and (xs.min() < design.fmt.lo or xs.max() > design.fmt.hi):
        raise ServokitValueError(f"input words must lie in the {design.fmt.name} range")
    m = _Machine(design)
    y = np.empty(xs.size, dtype=np.int64)
    pre = np.empty((xs.size, len(design.rows)), dtype=object) if nodes else None
    v = np.empty(xs.size, dtype=object) if nodes else None
    for i, xi in enumerate(xs.tolist()):
        y[i] = m.step(xi)
        if nodes:
            pre[i], v[i] = m.pre, m.v
    if nodes:
        return y, pre, v
    return y
