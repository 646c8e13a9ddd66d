"""Firmware tables: named arrays of a design, and their fixed-point quantisation.

A :class:`FirmwareTable` is one named array (a feedforward table, a gain matrix, state-
space matrices, second-order-section coefficients).  :func:`quantize` maps it to signed
Q15 / Q31 integers with one power-of-two scale per table:

    value ~= q * 2**(e - b),   q in [-2**b, 2**b - 1],   b = 15 or 31,

with the smallest exponent ``e`` that holds the largest magnitude without saturation;
the rounding error of every entry is at most half a unit of the last place,
``2**(e - b - 1)`` (stated in the export), and the measured worst error is reported
beside it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from servokit._lazy import control
from servokit._lazy import scipy_signal as signal
from servokit.errors import ServokitValueError, check_finite

__all__ = [
    "FORMATS",
    "FirmwareTable",
    "Quantized",
    "feedforward_tables",
    "quantize",
    "sos_tables",
    "statespace_tables",
]

#: Number formats of an export: C type and fractional bits (None: floating point).
FORMATS: dict[str, tuple[str, int | None]] = {
    "float": ("float", None),
    "double": ("double", None),
    "q15": ("int16_t", 15),
    "q31": ("int32_t", 31),
}
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


@dataclass(frozen=True)
class FirmwareTable:
    """One named array for firmware.

    Attributes
    ----------
    name : str
        C identifier (letters, digits, underscores).
    values : ndarray
        1-D or 2-D finite float array.
    description : str
        What the table holds (written as a comment).
    unit : str
        Unit of the entries.
    """

    name: str
    values: np.ndarray = field(repr=False)
    description: str = ""
    unit: str = ""

    def __post_init__(self) -> None:
        if not _IDENT.match(self.name):
            raise ServokitValueError(
                f"table name {self.name!r} is not a C identifier; use letters, digits and _"
            )
        values = check_finite(f"table {self.name}", self.values)
        if values.ndim not in (1, 2) or values.size == 0:
            raise ServokitValueError(
                f"table {self.name} must be a non-empty 1-D or 2-D array (got shape {values.shape})"
            )
        object.__setattr__(self, "values", values)


@dataclass(frozen=True)
class Quantized:
    """A table in signed fixed point: ``values ~= integers * scale``.

    Attributes
    ----------
    integers : ndarray of int64
        The stored integers.
    frac_bits : int
        15 (Q15) or 31 (Q31).
    exponent : int
        ``e`` in ``scale = 2**(e - frac_bits)``.
    max_error : float
        Largest ``|value - integer * scale|`` over the table.
    """

    integers: np.ndarray
    frac_bits: int
    exponent: int
    max_error: float

    @property
    def scale(self) -> float:
        """Value of one integer unit, ``2**(exponent - frac_bits)``."""
        return math.ldexp(1.0, self.exponent - self.frac_bits)

    @property
    def error_bound(self) -> float:
        """Half a unit: the rounding error bound of every entry."""
        return 0.5 * self.scale


def quantize(values: np.ndarray, frac_bits: int) -> Quantized:
    """Round ``values`` to signed fixed point with ``frac_bits`` fractional bits.

    Parameters
    ----------
    values : ndarray
        Finite values.
    frac_bits : int
        15 for Q15 (int16), 31 for Q31 (int32).

    Returns
    -------
    Quantized
        Integers, the power-of-two scale and the worst rounding error.
    """
    v = check_finite("values", values)
    peak = float(np.max(np.abs(v))) if v.size else 0.0
    top = 2**frac_bits - 1
    exponent = math.frexp(peak)[1] if peak > 0 else 0  # peak < 2**exponent
    while np.max(np.abs(np.rint(np.ldexp(v, frac_bits - exponent))), initial=0) > top:
        exponent += 1  # rounding reached 2**b: one more bit of range
    ints = np.rint(np.ldexp(v, frac_bits - exponent)).astype(np.int64)
    err = float(np.max(np.abs(v - np.ldexp(ints.astype(float), exponent - frac_bits))))
    return Quantized(ints, frac_bits, exponent, err)


def feedforward_tables(u: np.ndarray, dt: float, name: str = "ff") -> list[FirmwareTable]:
    """The held feedforward input ``u_c[0..N-1]`` as a table (one sample per period ``dt``).

    Parameters
    ----------
    u : ndarray (N,)
        Held input samples, e.g. ``FeedforwardInput.u`` (eqs. 2.40-2.42).
    dt : float
        Hold period [s] (stated in the table description).
    name : str
        C identifier of the table.

    Returns
    -------
    list of FirmwareTable
        One table ``name``.
    """
    desc = f"held feedforward input u_c[k], applied for dt = {dt:.9g} s from t = k dt"
    return [FirmwareTable(name, np.asarray(u, dtype=float), desc, "plant input")]


def statespace_tables(sys: control.LTI, name: str = "ctrl") -> list[FirmwareTable]:
    """State-space matrices ``A, B, C, D`` of a discrete controller.

    ``x[k+1] = A x[k] + B u[k]``, ``y[k] = C x[k] + D u[k]``; a transfer function is
    realised by python-control (``control.ss``).

    Parameters
    ----------
    sys : control.StateSpace or control.TransferFunction
        Discrete-time controller.
    name : str
        Prefix of the table names (``name_A`` ...).

    Returns
    -------
    list of FirmwareTable
        ``name_A, name_B, name_C, name_D``.
    """
    _require_discrete(sys)
    ss = control.ss(sys)
    desc = f"x[k+1] = A x[k] + B u[k], y[k] = C x[k] + D u[k]; dt = {float(ss.dt):.9g} s"
    return [FirmwareTable(f"{name}_{m}", np.atleast_2d(getattr(ss, m)), desc) for m in "ABCD"]


def sos_tables(sys: control.LTI, name: str = "filt") -> list[FirmwareTable]:
    """Second-order sections ``[b0 b1 b2 1 a1 a2]`` per row of a discrete SISO system.

    Uses ``scipy.signal.zpk2sos`` on the poles and zeros (pairing by SciPy, which keeps
    coefficients small), so that the cascade equals the transfer function.

    Parameters
    ----------
    sys : control.TransferFunction or control.StateSpace
        Discrete-time SISO filter or controller.
    name : str
        Table name.

    Returns
    -------
    list of FirmwareTable
        One ``(n_sections, 6)`` table ``name``.
    """
    _require_discrete(sys)
    tf = control.tf(sys)
    if tf.ninputs != 1 or tf.noutputs != 1:
        raise ServokitValueError("second-order sections need a SISO system; give one")
    z, p, k = signal.tf2zpk(np.asarray(tf.num[0][0], float), np.asarray(tf.den[0][0], float))
    sos = signal.zpk2sos(z, p, k)
    desc = f"second-order sections [b0 b1 b2 a0 a1 a2] (a0 = 1), cascade, dt = {float(tf.dt):.9g} s"
    return [FirmwareTable(name, sos, desc)]


def _require_discrete(sys: control.LTI) -> None:
    if not isinstance(sys.dt, int | float) or sys.dt is True or not sys.dt:
        raise ServokitValueError(
            "the controller is continuous; discretise it first (a 'dt' field in its file)"
        )
