"""Energy dissipated in a linear current amplifier (book §2.6.3, eq. (2.89)).

A linear amplifier fed by a supply ``Vp`` drops ``Vp - |VM(t)|`` across its output stage
while it drives the motor current ``i(t)``; all of that power turns into heat.  Its
average over the move, eq. (2.89)::

    Pamp = 1 / (N tau) * integral_0^{N tau} |i(t)| (Vp - |VM(t)|) dt,

is what a voltage-constrained FFSC design lowers: a lower motor-voltage limit lets the
supply (``limit + internal drop``) be lowered.  The motor voltage itself follows (2.83)
(``R i + L di/dt + Ke v``), discretised as (2.84) by
:meth:`servokit.feedforward.constraints.MotorModel.voltage`.
"""

from __future__ import annotations

import numpy as np

from servokit.errors import ServokitValueError, check_finite

__all__ = ["amplifier_power", "supply_voltage"]


def supply_voltage(voltage_limit: float, drop: float) -> float:
    """Supply ``Vp`` delivering ``voltage_limit`` through an internal ``drop`` [V] (§2.6.3).

    Parameters
    ----------
    voltage_limit : float
        Largest motor voltage ``|VM|`` the amplifier must deliver [V], > 0 (the design's
        voltage constraint, or the peak of an unconstrained design).
    drop : float
        Internal voltage drop of the amplifier's output stage [V], >= 0 (16 V in §2.6.3).

    Returns
    -------
    float
        ``Vp = voltage_limit + drop`` [V] (e.g. 36 V + 16 V = 52 V).

    Raises
    ------
    ServokitValueError
        If an argument is not finite, ``voltage_limit <= 0`` or ``drop < 0``.
    """
    v = float(check_finite("voltage_limit", voltage_limit))
    d = float(check_finite("drop", drop))
    if v <= 0 or d < 0:
        raise ServokitValueError("voltage_limit must be > 0 V and drop >= 0 V")
    return v + d


def amplifier_power(
    current: np.ndarray,
    voltage: np.ndarray,
    supply_voltage: float,
    dt: float,
    *,
    duration: float | None = None,
) -> float:
    """Average amplifier power loss ``Pamp`` of eq. (2.89) [W].

    ``current`` and ``voltage`` are samples held for ``dt`` each (the ZOH current reference
    of an FSC design and its motor voltage (2.84)), for which the integral is an exact sum.
    Pass samples on a finer grid (smaller ``dt``) for continuous waveforms.

    Parameters
    ----------
    current : ndarray (M,)
        Motor current ``i`` [A].
    voltage : ndarray (M,)
        Motor voltage ``VM`` [V].
    supply_voltage : float
        Supply ``Vp`` [V]; must cover ``max |VM|`` (else the amplifier saturates and
        (2.89) does not apply).
    dt : float
        Hold period of the samples [s].
    duration : float, optional
        Averaging time ``N tau`` [s]; default ``M dt``.

    Returns
    -------
    float
    """
    i = check_finite("current", current).ravel()
    v = check_finite("voltage", voltage).ravel()
    if i.shape != v.shape:
        raise ServokitValueError(
            f"current and voltage must have the same length, got {i.size} and {v.size}"
        )
    vp = float(check_finite("supply_voltage", supply_voltage))
    dt = float(check_finite("dt", dt))
    if dt <= 0:
        raise ServokitValueError(f"dt must be > 0 seconds (got {dt})")
    v_peak = float(np.max(np.abs(v), initial=0.0))
    if v_peak > vp * (1 + 1e-12):
        raise ServokitValueError(
            f"supply_voltage {vp:g} V is below the peak motor voltage {v_peak:g} V: the "
            "amplifier saturates; raise the supply or design with a VoltageLimit"
        )
    span = i.size * dt if duration is None else float(check_finite("duration", duration))
    if span <= 0:
        raise ServokitValueError("duration must be > 0 seconds")
    return float(np.sum(np.abs(i) * (vp - np.abs(v))) * dt / span)
