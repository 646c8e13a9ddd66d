"""A controller with a phase-stable peak filter added at one frequency, (5.17)-(5.18).

``C (1 + F)``: the peak filter ``F`` is placed by the discrete pseudo plant at its centre
so that it deepens the sensitivity there by a chosen depth (used for the RRO/NRRO peaks
of the HDD PES case, §6.2, and the ``servokit pes`` command).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import check_positive
from servokit.feedback.filters import (
    discretize_filter,
    discretize_filter_data,
    peak_filter_coefficients,
    peak_filter_phase,
)
from servokit.models.rational import RationalTF, StateSpaceData

__all__ = ["PeakFilterSpec", "peak_filtered_controller", "peak_filtered_data"]


@dataclass(frozen=True)
class PeakFilterSpec:
    """Peak filter at ``freq_hz`` with damping ``damping`` and ``depth_db`` of extra
    attenuation of the sensitivity at its centre."""

    freq_hz: float
    damping: float
    depth_db: float


def peak_filtered_controller(
    controller: control.TransferFunction, plant_d: control.LTI, spec: PeakFilterSpec
) -> control.TransferFunction:
    """``C (1 + F)`` with F the phase-stable peak filter (5.17)-(5.18) of ``spec``.

    The zero placement uses the discrete pseudo plant at ``freq_hz``; F is sampled by
    Tustin prewarped at ``freq_hz``, so its response there is exact.

    Parameters
    ----------
    controller : discrete TransferFunction
        Baseline ``C(z)``.
    plant_d : LTI
        Plant discretised at the controller's ``dt``.
    spec : PeakFilterSpec
        Centre [Hz], damping and attenuation depth [dB].

    Returns
    -------
    TransferFunction
        ``C (1 + F)``.
    """
    f1, dt, (num, den) = _peak_filter(controller, plant_d, spec)
    return controller * (1 + discretize_filter(control.tf(num, den), dt, f1))


def peak_filtered_data(
    controller: RationalTF, plant_d: StateSpaceData, spec: PeakFilterSpec
) -> RationalTF:
    """:func:`peak_filtered_controller` as numpy coefficients, python-control left unloaded
    (the same arithmetic: python-control's coefficients bit for bit for the same inputs).

    Parameters
    ----------
    controller : RationalTF
        Baseline discrete ``C(z)``.
    plant_d : StateSpaceData or RationalTF
        Plant discretised at the controller's ``dt``
        (:meth:`~servokit.models.ModalPlant.discretize_data`).
    spec : PeakFilterSpec
        Centre [Hz], damping and attenuation depth [dB].

    Returns
    -------
    RationalTF
        ``C (1 + F)``.
    """
    f1, dt, (num, den) = _peak_filter(controller, plant_d, spec)
    return controller * (1 + discretize_filter_data(RationalTF(num, den), dt, f1))


def _peak_filter(controller: Any, plant_d: Any, spec: PeakFilterSpec) -> tuple:
    """``(f1, dt, (num, den))``: the continuous peak filter F of ``spec`` placed by the
    pseudo plant ``C P / (1 + C P)`` at ``f1`` (5.18)."""
    f1 = check_positive("freq_hz", spec.freq_hz, "Hz")
    zeta = check_positive("damping", spec.damping)
    depth = check_positive("depth_db", spec.depth_db, "dB")
    dt = float(controller.dt)
    z1 = np.exp(2j * np.pi * f1 * dt)
    loop = _value(controller, z1) * _value(plant_d, z1)
    sh = loop / (1.0 + loop)
    gain = 2.0 * zeta * (10 ** (depth / 20) - 1.0) / abs(sh)
    return f1, dt, peak_filter_coefficients(f1, zeta, gain, peak_filter_phase(sh, "stable"))


def _value(sys: Any, z: complex) -> complex:
    """``sys(z)`` of a SISO system as a Python complex (a 1 x 1 array from state space)."""
    return complex(np.asarray(sys(z)).ravel()[0])
