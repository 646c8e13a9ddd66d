"""Fixed-point word formats ``Qm.n`` and the quantisation of one accumulation's coefficients.

See :mod:`servokit.export.fixed_point` for how they are used.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError

__all__ = ["FixedRow", "QFormat", "parse_qformat", "quantize_row", "rounding_bound"]


@dataclass(frozen=True)
class QFormat:
    """Signed fixed-point word ``Qm.n``: ``1 + m + n`` bits, value ``k 2**-n``.

    Attributes
    ----------
    int_bits : int
        ``m``, integer bits besides the sign.
    frac_bits : int
        ``n``, fractional bits.
    """

    int_bits: int
    frac_bits: int

    @property
    def word_bits(self) -> int:
        """Bits of the word, sign included."""
        return 1 + self.int_bits + self.frac_bits

    @property
    def acc_bits(self) -> int:
        """Accumulator bits: 32 for words up to 16 bits, else 64."""
        return 32 if self.word_bits <= 16 else 64

    @property
    def ctype(self) -> str:
        """C type of a stored word."""
        return "int16_t" if self.word_bits <= 16 else "int32_t"

    @property
    def acc_ctype(self) -> str:
        """C type of the accumulator."""
        return f"int{self.acc_bits}_t"

    @property
    def hi(self) -> int:
        """Largest word integer."""
        return 2 ** (self.word_bits - 1) - 1

    @property
    def lo(self) -> int:
        """Smallest word integer."""
        return -(2 ** (self.word_bits - 1))

    @property
    def acc_max(self) -> int:
        """Largest accumulator integer."""
        return 2 ** (self.acc_bits - 1) - 1

    @property
    def name(self) -> str:
        """``"Q0.15"`` etc."""
        return f"Q{self.int_bits}.{self.frac_bits}"


def parse_qformat(text: str) -> QFormat:
    """``"q15"``, ``"q31"`` or ``"qM.N"`` (word of ``1 + M + N`` <= 32 bits) as a format.

    Parameters
    ----------
    text : str
        The ``--precision`` value.

    Returns
    -------
    QFormat
        The word format.
    """
    t = text.strip().lower()
    if t in ("q15", "q31"):
        return QFormat(0, int(t[1:]))
    match = re.fullmatch(r"q(\d{1,2})\.(\d{1,2})", t)
    if match is None:
        raise ServokitValueError(f"--precision {text!r}: use q15, q31 or qM.N (e.g. q3.12)")
    fmt = QFormat(int(match[1]), int(match[2]))
    if fmt.frac_bits < 1 or not 4 <= fmt.word_bits <= 32:
        raise ServokitValueError(
            # no bare "N": the CLI would read it as the --n-samples parameter
            f"--precision {text!r}: a word of {fmt.word_bits} bits (sign, integer and "
            f"{fmt.frac_bits} fraction bits); use 4 to 32 bits with at least 1 fraction bit"
        )
    return fmt


@dataclass(frozen=True)
class FixedRow:
    """One accumulation: integer coefficients sharing ``frac`` fractional bits.

    Attributes
    ----------
    coefs : tuple of int
        The coefficients (value ``c 2**-frac``).
    frac : int
        Fractional bits of the coefficients; products carry ``n + frac``.
    """

    coefs: tuple[int, ...]
    frac: int

    def values(self) -> np.ndarray:
        """The coefficients' real values."""
        return np.array([math.ldexp(c, -self.frac) for c in self.coefs])


def _row_fits(ints: np.ndarray, fmt: QFormat, extra: int) -> bool:
    return bool(
        np.max(np.abs(ints), initial=0) <= fmt.hi
        and int(np.sum(np.abs(ints))) * 2 ** (fmt.word_bits - 1) + extra <= fmt.acc_max
    )


def quantize_row(values: np.ndarray, fmt: QFormat, extra: int = 0) -> FixedRow:
    """Coefficients of one accumulation with the most fractional bits that fit.

    Parameters
    ----------
    values : ndarray
        Real coefficients.
    fmt : QFormat
        Word format (the coefficients are words too).
    extra : int
        Accumulator integers reserved for other terms.

    Returns
    -------
    FixedRow
        Integers and their fractional bits ``cf >= 0`` (refused if none fits).
    """
    peak = float(np.max(np.abs(values), initial=0.0))
    cf = fmt.word_bits - 1 - (math.frexp(peak)[1] if peak > 0 else 0)
    cf = min(cf, fmt.acc_bits - 2)  # every shift stays below the accumulator width (C)
    while cf >= 0:
        ints = np.rint(np.ldexp(values, cf)).astype(np.int64)
        if _row_fits(ints, fmt, extra):
            return FixedRow(tuple(int(v) for v in ints), cf)
        cf -= 1
    raise ServokitValueError(
        f"a coefficient ({peak:.6g}) is too large for {fmt.name}; raise --u-max or lower "
        "--input-max"
    )


def rounding_bound(fmt: QFormat, rounding: str, shift: int) -> float:
    """Bound of one rounding error, in units of the target word's value.

    Parameters
    ----------
    fmt : QFormat
        Target word.
    rounding : str
        ``"truncate"`` (error below one unit) or a round-to-nearest mode (half a unit).
    shift : int
        Right shift of the rounding (``<= 0``: exact, no error).

    Returns
    -------
    float
        The bound.
    """
    if shift <= 0:
        return 0.0
    q = math.ldexp(1.0, -fmt.frac_bits)
    return q if rounding == "truncate" else q / 2
