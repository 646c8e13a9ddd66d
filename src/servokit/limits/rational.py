"""A SISO loop given by its polynomial coefficients, evaluated with numpy alone.

The limit computations of §6.3 (Bode integrals (6.17)-(6.18), the variance bound
(6.13)-(6.16)) need only the response ``L(x) = num(x)/den(x)`` on a grid, the open-loop
poles ``roots(den)`` and the closed-loop poles of unity feedback ``roots(den + num)``
(``1 + L = 0``).  :class:`RationalLoop` offers exactly those, with the attribute names of a
python-control transfer function (``num``/``den`` arrays, ``dt``, ``isdtime()``,
``poles()``, ``zeros()``, calling it), so the same code serves both; building a
``control.TransferFunction`` just to evaluate it costs about a second of start-up
(python-control imports scipy.signal, scipy.stats and matplotlib; issue 23).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError

__all__ = ["RationalLoop", "as_rational"]


def _coefficients(name: str, values: object) -> np.ndarray:
    c = np.atleast_1d(np.asarray(values, dtype=float))
    if c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
        raise ServokitValueError(f"{name} must be a non-empty 1-D array of finite numbers")
    nz = np.flatnonzero(np.abs(c) > 1e-300)  # leading zeros (as python-control reads them)
    if nz.size == 0 and name == "den":
        raise ServokitValueError("den must have a non-zero coefficient")
    return c[nz[0] :] if nz.size else np.zeros(1)


@dataclass(frozen=True)
class RationalLoop:
    """``L(x) = num(x) / den(x)`` (``x = s``, or ``x = z`` when ``dt`` is set).

    Parameters
    ----------
    num, den : array_like
        Polynomial coefficients, highest power first (leading zeros are dropped).
    dt : float, optional
        Sampling period [s]; ``None`` for a continuous loop.
    """

    num: np.ndarray
    den: np.ndarray
    dt: float | None = None
    _roots: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "num", _coefficients("num", self.num))
        object.__setattr__(self, "den", _coefficients("den", self.den))
        if self.dt is not None and not (np.isfinite(self.dt) and self.dt > 0):
            raise ServokitValueError(f"dt must be a positive number of seconds (got {self.dt})")

    def isdtime(self) -> bool:
        """Whether the loop is discrete (``dt`` set).

        Returns
        -------
        bool
        """
        return self.dt is not None

    def __call__(self, x: complex | np.ndarray) -> np.ndarray:
        """``num(x) / den(x)`` at the complex points ``x`` (``s`` or ``z``).

        Parameters
        ----------
        x : complex or ndarray
            Evaluation points.

        Returns
        -------
        ndarray
            Complex response, the shape of ``x``.
        """
        x = np.asarray(x, dtype=complex)
        return np.polyval(self.num, x) / np.polyval(self.den, x)

    def poles(self) -> np.ndarray:
        """Open-loop poles, ``roots(den)``.

        Returns
        -------
        ndarray
        """
        return self._cached("poles", self.den)

    def zeros(self) -> np.ndarray:
        """Open-loop zeros, ``roots(num)``.

        Returns
        -------
        ndarray
        """
        return self._cached("zeros", self.num)

    def closed_loop_poles(self) -> np.ndarray:
        """Poles of unity negative feedback ``L / (1 + L)``: ``roots(den + num)``.

        Returns
        -------
        ndarray
        """
        n = max(self.num.size, self.den.size)
        char = np.pad(self.den, (n - self.den.size, 0)) + np.pad(self.num, (n - self.num.size, 0))
        return self._cached("closed", char)

    def _cached(self, key: str, coeffs: np.ndarray) -> np.ndarray:
        if key not in self._roots:
            self._roots[key] = np.roots(coeffs).astype(complex)
        return self._roots[key]


def as_rational(loop: object) -> RationalLoop:
    """A :class:`RationalLoop` as given, or from a SISO python-control TF / StateSpace.

    Parameters
    ----------
    loop : RationalLoop or SISO LTI
        The loop.

    Returns
    -------
    RationalLoop
    """
    if isinstance(loop, RationalLoop):
        return loop
    from servokit._lazy import control  # only a python-control object can need it

    if not isinstance(loop, control.TransferFunction | control.StateSpace):
        raise ServokitTypeError(
            f"loop must be a RationalLoop or a python-control TransferFunction or StateSpace, "
            f"got {type(loop).__name__}"
        )
    if loop.ninputs != 1 or loop.noutputs != 1:
        raise ServokitValueError("loop must be SISO (one input, one output)")
    tf = control.tf(loop)
    return RationalLoop(tf.num[0][0], tf.den[0][0], float(tf.dt) if tf.isdtime() else None)
