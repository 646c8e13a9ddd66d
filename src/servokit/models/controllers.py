"""The book's numerically given controllers, as python-control objects.

* C(z) of eq. (4.69): PI-lead controller of the multirate HDD example (§4.5.2).
* Cpc(s), Cnc(s) of eqs. (4.72)-(4.73): PI-lead and notch of the TDOF seek (§4.5.4),
  discretised as the book does (Cp by the bilinear transform, Cn by pole-zero matching).
* The VCM controller of Table 5.2 (gain 0.1365; PES sampled at 30 kHz, §5.2.1.2).
"""

from __future__ import annotations

from servokit._lazy import control
from servokit.models.catalogue import HDD_SAMPLED_DATA_TS
from servokit.models.rational import RationalTF, rational_zpk
from servokit.models.tf import require_proper, zpk

__all__ = [
    "zpk",
    "controller_eq_4_69",
    "cpc_eq_4_72",
    "cnc_eq_4_73",
    "controller_fig_4_57",
    "vcm_controller_table_5_2",
    "VCM_PES_TS",
    "CONTROLLERS",
    "RATIONAL_CONTROLLERS",
    "require_proper",
]

#: PES sampling period of the dual-stage HDD of chapter 5 (30 kHz, §5.2.1.2) [s].
VCM_PES_TS = 1.0 / 30000.0


def controller_eq_4_69() -> control.TransferFunction:
    """C(z) = 0.872 (z-0.490)(z-0.865)(z-0.908) / ((z-0.0182)(z-0.409)(z-1)), eq. (4.69).

    Its z-domain coefficients hold for the sampling period of §4.5.2 only (153.5 us).

    Returns
    -------
    control.TransferFunction
        Discrete ``C(z)`` with ``dt = HDD_SAMPLED_DATA_TS`` (153.5 us).
    """
    return _eq_4_69_rational().to_control()


def _eq_4_69_rational() -> RationalTF:
    return rational_zpk([0.490, 0.865, 0.908], [0.0182, 0.409, 1.0], 0.872, HDD_SAMPLED_DATA_TS)


def cpc_eq_4_72() -> control.TransferFunction:
    """Cpc(s) = 1318 (s+628.3)(s+1257) / (s (s+25130)), eq. (4.72).

    Returns
    -------
    control.TransferFunction
        Continuous PI-lead ``Cpc(s)``: integrator, zeros at 100 Hz and 200 Hz, pole at
        4 kHz.
    """
    return zpk([-628.3, -1257.0], [0.0, -25130.0], 1318.0)


def cnc_eq_4_73() -> control.TransferFunction:
    """Cnc(s) = (s^2 + 515.2 s + 663.6e6) / (s^2 + 7728 s + 663.6e6), eq. (4.73).

    Returns
    -------
    control.TransferFunction
        Continuous notch ``Cnc(s)`` at ``sqrt(663.6e6) / 2 pi`` = 4.1 kHz (the primary
        mode of Table 4.1), zero damping 0.01, pole damping 0.15; unity gain away from it.
    """
    return control.tf([1.0, 515.2, 663.6e6], [1.0, 7728.0, 663.6e6])


def controller_fig_4_57(dt: float = HDD_SAMPLED_DATA_TS) -> control.TransferFunction:
    """C(z) = Cp(z) Cn(z) of §4.5.4.1: Cp = Tustin(Cpc), Cn = matched pole-zero(Cnc).

    Parameters
    ----------
    dt : float
        Sampling period [s] of the discretisation (the §4.5.4 case uses ``Ts / 4`` =
        38.375 us).

    Returns
    -------
    control.TransferFunction
        Discrete ``C(z)`` with period ``dt``: :func:`cpc_eq_4_72` by the bilinear
        transform (no prewarping) times :func:`cnc_eq_4_73` by pole-zero matching.
    """
    cp = control.sample_system(cpc_eq_4_72(), dt, method="tustin")
    cn = control.sample_system(cnc_eq_4_73(), dt, method="matched")
    return cp * cn


def vcm_controller_table_5_2(dt: float = VCM_PES_TS) -> control.TransferFunction:
    """VCM controller C(z) of Table 5.2: gain 0.1365 with the listed zeros and poles.

    Parameters
    ----------
    dt : float
        Sampling period [s] attached to the transfer function; the table's z-domain
        zeros and poles hold for the 30 kHz PES rate (``VCM_PES_TS``) only.

    Returns
    -------
    control.TransferFunction
        Discrete 10th-order ``C(z)`` (an integrator at ``z = 1``) with period ``dt``.
    """
    return _table_5_2_rational(dt).to_control()


def _table_5_2_rational(dt: float = VCM_PES_TS) -> RationalTF:
    zeros = [
        -0.2199 + 0.9392j,
        -0.2199 - 0.9392j,
        0.0741 + 0.9824j,
        0.0741 - 0.9824j,
        0.2163 + 0.9292j,
        0.2163 - 0.9292j,
        0.5777 + 0.7766j,
        0.5777 - 0.7766j,
        0.9896,
        0.9896,
    ]
    poles = [
        0.0019,
        0.009,
        0.5026,
        1.0,
        0.0711 + 0.8581j,
        0.0711 - 0.8581j,
        0.2032 + 0.8504j,
        0.2032 - 0.8504j,
        0.5467 + 0.7287j,
        0.5467 - 0.7287j,
    ]
    return rational_zpk(zeros, poles, 0.1365, dt)


def _hdd_benchmark_controller() -> control.TransferFunction:
    from servokit.models.benchmark_controller import benchmark_controller

    return benchmark_controller()


#: Book controllers by command-line name (all discrete, at their book sampling period),
#: and servokit's baseline tracking controller of the HDD benchmark (PI + lead + notches).
CONTROLLERS = {
    "eq-4.69": controller_eq_4_69,
    "fig-4.57": controller_fig_4_57,
    "table-5.2": vcm_controller_table_5_2,
    "hdd-benchmark": _hdd_benchmark_controller,
}


#: The controllers of :data:`CONTROLLERS` that are zeros, poles and a gain, as numpy-only
#: :class:`~servokit.models.rational.RationalTF` (no python-control import: a command's
#: start-up); the same systems as ``CONTROLLERS[name]()`` (``.to_control()``).
RATIONAL_CONTROLLERS = {
    "eq-4.69": _eq_4_69_rational,
    "table-5.2": _table_5_2_rational,
}


def __getattr__(name: str) -> object:
    # The old import path of get_discrete_controller, now in servokit.models.lookup (above this
    # module); resolved on attribute access so this module imports nothing above it.
    if name == "get_discrete_controller":
        from servokit.models import lookup

        return lookup.get_discrete_controller
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
