"""Self-sensing actuation bridges and active mode damping (book §5.4.2-§5.4.3).

Direct-driven SSA (DDSSA, Fig. 5.27, eqs. 5.59-5.62)
    The PZT is a capacitance ``CPZT`` in series with the strain voltage ``vM``.  Read
    from (5.59)-(5.60): the PZT arm (``uM`` -> PZT -> node ``v1``) over ``C1`` to ground,
    and the reference arm ``uM`` -> ``C2`` -> node ``v2`` -> ``C3`` to ground; the
    differential amplifier gives ``vs = v2 - v1``.  With admittances (``R1 || C1``,
    ``R3 || C3`` when the drift resistors are fitted)::

        v1 = YP (uM - vM) / (YP + Y1),   v2 = Y2 uM / (Y2 + Y3),
        vs = [Y2/(Y2+Y3) - YP/(YP+Y1)] uM + YP/(YP+Y1) vM.

    **Correction**: the printed (5.61) has the ``uM`` coefficient with the opposite sign
    (``CPZT/(C1+CPZT) - C2/(C2+C3)``); it follows from ``vs = v2 - v1`` as above.  It
    vanishes at balance either way.  Balance for all frequencies needs
    ``CPZT C3 = C1 C2`` and, with resistors, ``CPZT / R3 = C2 / R1``; the book's choice
    ``C1 = C2 = C3 = CPZT`` gives ``vs = vM / 2`` (5.62).

Indirect-driven SSA (IDSSA, Fig. 5.28, eqs. 5.63-5.66)
    The figure's topology is lost in the text; servokit implements the printed relations
    (5.63)-(5.64).  **Correction**: the printed ``v2`` denominator
    ``C3 C4 R3 R4 s^2 + (C'PZT + C3 + C4) R1 s + 1`` is read with ``R3`` for ``R1``
    (the mirror of ``v1``); the two agree at balance (5.65).  With (5.65),
    ``vS = k (v2 - v1)``: ``uM`` cancels and ``vS / vM = k s^2 / (s^2 + 2 zeta wc s + wc^2)``
    (5.66) with ``fc = 1 / (2 pi sqrt(C1 C2 R1 R2))`` and
    ``zeta = sqrt(C1 C2 R1 R2) (C1 + C2 + CPZT) / (2 C1 C2 R2)``.

Active mode damping (AMD, eqs. 5.67-5.69)
    The printed (5.67) lost its fraction layout.  servokit reads it as::

        CD,i(s) = KD,i (s + wn/eps) (s + wn) / ((s + kappa wn / eps) (s + eps wn / kappa))

    which is what the text describes: the two poles multiply to ``wn^2``, a PPF-like pair
    ``s^2 + 2 zeta_D wn s + wn^2`` with ``zeta_D = (kappa/eps + eps/kappa)/2`` ("a general
    case of PPF with additional zeros"); the zeros at ``wn/eps`` and ``wn`` give the phase
    lead; the DC gain is ``KD / eps``, so the text's usual ``KD = eps`` gives unit DC gain
    and a gain ``eps`` at high frequency.  In this reading the phase at exactly ``wn`` is
    ``atan(eps) - 45 deg`` whatever ``kappa``; ``kappa`` sets the pole damping, i.e. how
    fast the phase changes around ``wn`` (the lift at ``wn (1 +- P %)``), which is how we
    read "kappa determines the amount of phase lift".  The loop
    (5.68) ``yM/uM = PM / (1 + CD PM)`` attenuates mode ``i`` by about ``1/|CD(j wn)|``
    when ``|CD PM| >> 1`` (5.69).

numpy evaluations
    The python-control objects above cost a second of start-up to build; the ``ssa``
    commands use :func:`ddssa_response`, :func:`idssa_response`, :func:`amd_response`,
    :func:`amd_statespace` and :func:`amd_mode_damping`, which evaluate the same
    equations directly (the bridges' admittances at ``s = j 2 pi f``, (5.67) factor by
    factor) and give the same numbers (``tests/test_ssa_arrays.py``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_positive

if TYPE_CHECKING:
    from servokit.models import ModalPlant

__all__ = [
    "DDSSABridge",
    "ddssa_bridge",
    "IDSSABridge",
    "idssa_bridge",
    "ddssa_response",
    "idssa_response",
    "amd_controller",
    "amd_mode",
    "amd_mode_damping",
    "amd_response",
    "amd_statespace",
    "ModeDamping",
    "mode_damping",
]


def _positive_or_none(name: str, value: float | None) -> float | None:
    return None if value is None else check_positive(name, value)


def _rc_admittance(c: float, r: float | None) -> control.TransferFunction:
    """``s C`` or ``s C + 1/R`` as a transfer function."""
    return control.tf([c, 0.0 if r is None else 1.0 / r], [1.0])


@dataclass(frozen=True)
class DDSSABridge:
    """Direct-driven bridge (Fig. 5.27): ``vs = from_um * uM + from_vm * vM``."""

    from_um: control.TransferFunction
    from_vm: control.TransferFunction
    balanced: bool


def ddssa_bridge(
    c_pzt: float,
    c1: float,
    c2: float,
    c3: float,
    *,
    r1: float | None = None,
    r3: float | None = None,
    rtol: float = 1e-9,
) -> DDSSABridge:
    """DDSSA transfer functions from ``uM`` and ``vM`` to ``vs`` (5.59)-(5.62), corrected.

    Parameters
    ----------
    c_pzt, c1, c2, c3 : float
        Capacitances [F].
    r1, r3 : float, optional
        Drift resistors [ohm] in parallel with ``C1`` and ``C3``.
    rtol : float
        Relative tolerance of the balance test ``CPZT C3 = C1 C2`` (and
        ``CPZT / R3 = C2 / R1``).

    Returns
    -------
    DDSSABridge
        ``from_um = Y2/(Y2+Y3) - YP/(YP+Y1)`` (the corrected uM coefficient of (5.61)),
        ``from_vm = YP/(YP+Y1)`` (dimensionless transfer functions to ``vs``) and
        ``balanced``, whether the balance conditions hold within ``rtol`` (then
        ``from_um`` is zero at all frequencies and, with ``C1 = C2 = C3 = CPZT``,
        ``vs = vM / 2`` (5.62)).
    """
    cp, c1, c2, c3, r1, r3, balanced = _ddssa_checked(c_pzt, c1, c2, c3, r1, r3, rtol)
    yp, y1 = control.tf([cp, 0.0], [1.0]), _rc_admittance(c1, r1)
    y2, y3 = control.tf([c2, 0.0], [1.0]), _rc_admittance(c3, r3)
    arm1 = control.minreal(yp / (yp + y1), verbose=False)
    arm2 = control.minreal(y2 / (y2 + y3), verbose=False)
    return DDSSABridge(arm2 - arm1, arm1, balanced)


def _ddssa_checked(c_pzt, c1, c2, c3, r1, r3, rtol):  # noqa: ANN001, ANN202
    """Validated ``(CPZT, C1, C2, C3, R1, R3, balanced)`` of :func:`ddssa_bridge`."""
    cp, c1, c2, c3 = (
        check_positive(n, v, "F") for n, v in (("c_pzt", c_pzt), ("c1", c1), ("c2", c2), ("c3", c3))
    )
    r1, r3 = _positive_or_none("r1", r1), _positive_or_none("r3", r3)
    if (r1 is None) != (r3 is None):
        raise ServokitValueError("give both r1 and r3 (the drift resistors) or neither")
    balanced = np.isclose(cp * c3, c1 * c2, rtol=rtol, atol=0.0) and (
        r1 is None or np.isclose(cp / r3, c2 / r1, rtol=rtol, atol=0.0)
    )
    return cp, c1, c2, c3, r1, r3, bool(balanced)


def ddssa_response(
    c_pzt: float,
    c1: float,
    c2: float,
    c3: float,
    freq_hz: float | np.ndarray,
    *,
    r1: float | None = None,
    r3: float | None = None,
    rtol: float = 1e-9,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`ddssa_bridge`'s two transfer functions evaluated at ``freq_hz``, with numpy.

    The admittances ``Y = s C (+ 1/R)`` of (5.59)-(5.60) are evaluated at ``s = j 2 pi f``
    and combined as in the module docstring; no python-control object is built.

    Parameters
    ----------
    c_pzt, c1, c2, c3 : float
        Capacitances [F].
    freq_hz : float or ndarray
        Frequencies [Hz].
    r1, r3 : float, optional
        Drift resistors [ohm] in parallel with ``C1`` and ``C3``.
    rtol : float
        Relative tolerance of the balance test.

    Returns
    -------
    from_um, from_vm : ndarray of complex
        ``Y2/(Y2+Y3) - YP/(YP+Y1)`` and ``YP/(YP+Y1)`` at ``freq_hz`` (shape of ``freq_hz``).
    balanced : bool
        As :attr:`DDSSABridge.balanced`.
    """
    cp, c1, c2, c3, r1, r3, balanced = _ddssa_checked(c_pzt, c1, c2, c3, r1, r3, rtol)
    s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    yp, y1 = s * cp, s * c1 + (0.0 if r1 is None else 1.0 / r1)
    y2, y3 = s * c2, s * c3 + (0.0 if r3 is None else 1.0 / r3)
    arm1, arm2 = yp / (yp + y1), y2 / (y2 + y3)
    return arm2 - arm1, arm1, balanced


@dataclass(frozen=True)
class IDSSABridge:
    """Indirect-driven bridge (Fig. 5.28): ``vs = from_um * uM + from_vm * vM`` (5.63)-(5.64)
    and, at balance (5.65), the high-pass (5.66) with ``fc_hz``, ``damping``, ``gain``."""

    from_um: control.TransferFunction
    from_vm: control.TransferFunction
    fc_hz: float
    damping: float
    gain: float


def _idssa_arm(ca: float, cb: float, cp: float, ra: float, rb: float) -> control.TransferFunction:
    """``1 + (ca cp ra rb s^2 + ca rb s) / (ca cb ra rb s^2 + (cp + ca + cb) ra s + 1)`` (5.63)."""
    den = [ca * cb * ra * rb, (cp + ca + cb) * ra, 1.0]
    return 1 + control.tf([ca * cp * ra * rb, ca * rb, 0.0], den)


def idssa_bridge(
    c: tuple[float, float, float, float],
    c_pzt: float,
    c_pzt_ref: float,
    r: tuple[float, float, float, float, float, float, float, float],
) -> IDSSABridge:
    """IDSSA output (5.63)-(5.64) for ``c = (C1, C2, C3, C4)``, ``r = (R1, ..., R8)``.

    ``c_pzt`` is the PZT capacitance, ``c_pzt_ref`` the reference ``C'PZT``.  ``fc_hz``,
    ``damping`` and ``gain`` are those of (5.66) (meaningful at balance (5.65)).

    Parameters
    ----------
    c : tuple of 4 float
        Capacitances ``(C1, C2, C3, C4)`` [F]; ``C1, C2`` are in the PZT arm ``v1``,
        ``C3, C4`` in the reference arm ``v2``.
    c_pzt : float
        PZT capacitance ``CPZT`` [F].
    c_pzt_ref : float
        Reference capacitance ``C'PZT`` [F] of the ``v2`` arm.
    r : tuple of 8 float
        Resistances ``(R1, ..., R8)`` [ohm]: ``R1, R2`` in the ``v1`` arm, ``R3, R4`` in
        the ``v2`` arm, ``R5 ... R8`` the differential amplifier of (5.64).

    Returns
    -------
    IDSSABridge
        ``from_um`` and ``from_vm``, the transfer functions from ``uM`` and ``vM`` to
        ``vS = a2 v2 - a1 v1`` with ``a2 = R6 (R7 + R8) / ((R5 + R6) R8)`` and
        ``a1 = R7 / R8`` (5.64); ``fc_hz = 1 / (2 pi sqrt(C1 C2 R1 R2))`` [Hz],
        ``damping = sqrt(C1 C2 R1 R2) (C1 + C2 + CPZT) / (2 C1 C2 R2)`` and
        ``gain = R6 / R5``, the parameters of the high-pass (5.66) that ``from_vm`` equals
        at balance (5.65), where ``from_um`` vanishes.
    """
    (c1, c2, c3, c4), cp, cpr, rr = _idssa_checked(c, c_pzt, c_pzt_ref, r)
    r1, r2, r3, r4 = rr[:4]
    v1_um = _idssa_arm(c1, c2, cp, r1, r2)
    v1_vm = -control.tf([c1 * cp * r1 * r2, 0.0, 0.0], [c1 * c2 * r1 * r2, (cp + c1 + c2) * r1, 1])
    v2_um = _idssa_arm(c3, c4, cpr, r3, r4)
    a2, a1 = _idssa_amplifier(rr)
    return IDSSABridge(
        control.minreal(a2 * v2_um - a1 * v1_um, verbose=False),
        -a1 * v1_vm,
        *_idssa_highpass(c1, c2, cp, rr),
    )


def _idssa_checked(c, c_pzt, c_pzt_ref, r):  # noqa: ANN001, ANN202
    """Validated ``((C1..C4), CPZT, C'PZT, [R1..R8])`` of :func:`idssa_bridge`."""
    cc = tuple(check_positive(f"C{i + 1}", v, "F") for i, v in enumerate(c))
    cp, cpr = check_positive("c_pzt", c_pzt, "F"), check_positive("c_pzt_ref", c_pzt_ref, "F")
    return cc, cp, cpr, [check_positive(f"R{i + 1}", v, "ohm") for i, v in enumerate(r)]


def _idssa_amplifier(rr: list[float]) -> tuple[float, float]:
    """``a2 = R6 (R7 + R8) / ((R5 + R6) R8)`` and ``a1 = R7 / R8`` of (5.64)."""
    r5, r6, r7, r8 = rr[4:]
    return r6 / (r5 + r6) * (r7 + r8) / r8, r7 / r8


def _idssa_highpass(c1: float, c2: float, cp: float, rr: list[float]) -> tuple[float, float, float]:
    """``fc_hz``, ``damping`` and ``gain`` of the high-pass (5.66)."""
    r1, r2, r5, r6 = rr[0], rr[1], rr[4], rr[5]
    wc = 1.0 / np.sqrt(c1 * c2 * r1 * r2)
    zeta = np.sqrt(c1 * c2 * r1 * r2) * (c1 + c2 + cp) / (2.0 * c1 * c2 * r2)
    return float(wc / (2 * np.pi)), float(zeta), float(r6 / r5)


def _idssa_arm_at(s: np.ndarray, ca: float, cb: float, cp: float, ra: float, rb: float):  # noqa: ANN202
    """``v/uM`` of one arm (5.63) at ``s`` and the ``vM`` term's ``s^2`` numerator factor."""
    den = ca * cb * ra * rb * s * s + (cp + ca + cb) * ra * s + 1.0
    return 1.0 + (ca * cp * ra * rb * s * s + ca * rb * s) / den, den


def idssa_response(
    c: tuple[float, float, float, float],
    c_pzt: float,
    c_pzt_ref: float,
    r: tuple[float, float, float, float, float, float, float, float],
    freq_hz: float | np.ndarray,
) -> tuple[np.ndarray, np.ndarray, tuple[float, float, float]]:
    """:func:`idssa_bridge` evaluated at ``freq_hz`` with numpy (no python-control object).

    Parameters
    ----------
    c, c_pzt, c_pzt_ref, r
        As :func:`idssa_bridge`.
    freq_hz : float or ndarray
        Frequencies [Hz].

    Returns
    -------
    from_um, from_vm : ndarray of complex
        ``vS/uM`` and ``vS/vM`` (5.63)-(5.64) at ``freq_hz``.
    highpass : tuple of float
        ``(fc_hz, damping, gain)`` of (5.66), as :class:`IDSSABridge`.
    """
    (c1, c2, c3, c4), cp, cpr, rr = _idssa_checked(c, c_pzt, c_pzt_ref, r)
    s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    v1_um, den1 = _idssa_arm_at(s, c1, c2, cp, rr[0], rr[1])
    v2_um, _ = _idssa_arm_at(s, c3, c4, cpr, rr[2], rr[3])
    a2, a1 = _idssa_amplifier(rr)
    from_vm = a1 * c1 * cp * rr[0] * rr[1] * s * s / den1
    return a2 * v2_um - a1 * v1_um, from_vm, _idssa_highpass(c1, c2, cp, rr)


# --------------------------------------------------------------- active mode damping
def amd_mode(freq_hz: float, eps: float, kappa: float, gain: float | None = None):
    """One AMD factor ``CD,i`` (5.67) as read in the module docstring (``KD,i = eps`` default).

    ``1 < eps <= P`` (frequency uncertainty, P < 3) and ``5 < kappa < 15`` in the book.

    Parameters
    ----------
    freq_hz : float
        Natural frequency ``fn = wn / 2 pi`` of the mode to damp [Hz].
    eps : float
        ``eps`` (> 0): zeros at ``wn / eps`` and ``wn``; the high-frequency gain over the
        DC gain.
    kappa : float
        ``kappa`` (> ``eps``): real poles at ``kappa wn / eps`` and ``eps wn / kappa``, a
        pair of natural frequency ``wn`` and damping ``(kappa/eps + eps/kappa) / 2``.
    gain : float, optional
        ``KD,i`` (> 0); ``eps`` by default, which gives unit DC gain.

    Returns
    -------
    control.TransferFunction
        The continuous ``CD,i(s)``, DC gain ``KD,i / eps``, high-frequency gain ``KD,i``.
    """
    k, zeros, poles = _amd_factor(freq_hz, eps, kappa, gain)
    num = np.polymul([1, zeros[0]], [1, zeros[1]])
    den = np.polymul([1, poles[0]], [1, poles[1]])
    return control.tf(k * num, den)


def _amd_factor(freq_hz, eps, kappa, gain=None):  # noqa: ANN001, ANN202
    """``(KD, (wn/eps, wn), (kappa wn/eps, eps wn/kappa))``: ``CD,i = KD (s + a)(s + b) /
    ((s + c)(s + d))`` of (5.67), its arguments checked."""
    wn = 2 * np.pi * check_positive("freq_hz", freq_hz, "Hz")
    eps, kappa = check_positive("eps", eps), check_positive("kappa", kappa)
    if not kappa > eps:
        raise ServokitValueError(f"kappa must exceed eps (got kappa={kappa}, eps={eps})")
    k = eps if gain is None else check_positive("gain", gain)
    return k, (wn / eps, wn), (kappa * wn / eps, eps * wn / kappa)


def amd_controller(modes: list[tuple[float, float, float]]) -> control.TransferFunction:
    """``CD = prod_i CD,i`` for ``modes = [(freq_hz, eps, kappa), ...]`` (§5.4.3).

    Parameters
    ----------
    modes : list of tuple of (float, float, float)
        One ``(freq_hz, eps, kappa)`` per mode, passed to :func:`amd_mode` (frequency
        [Hz], dimensionless ``eps`` and ``kappa``; ``KD,i = eps``).  Not empty.

    Returns
    -------
    control.TransferFunction
        The continuous product of the factors (5.67).
    """
    if not modes:
        raise ServokitValueError("modes is empty; give at least one (freq_hz, eps, kappa)")
    out = amd_mode(*modes[0])
    for m in modes[1:]:
        out = out * amd_mode(*m)
    return out


@dataclass(frozen=True)
class ModeDamping:
    """Peaks of ``|PM|`` and of the damped ``|PM / (1 + CD PM)|`` (5.68) near each mode,
    the attenuation [dB], the estimate ``1/|CD(j wn)|`` of (5.69), and stability."""

    freq_hz: np.ndarray
    open_db: np.ndarray
    damped_db: np.ndarray
    attenuation_db: np.ndarray
    estimate_db: np.ndarray
    stable: bool


def mode_damping(
    plant: control.LTI, cd: control.LTI, freq_hz: np.ndarray, *, band: float = 0.1
) -> ModeDamping:
    """Effect of the AMD loop (5.68) on the modes at ``freq_hz`` (peak within +-``band``).

    Parameters
    ----------
    plant : control.LTI
        Continuous PZT plant ``PM`` (input ``uM``, output ``yM``).
    cd : control.LTI
        Continuous AMD controller ``CD`` (e.g. from :func:`amd_controller`) in negative
        feedback around ``plant``.
    freq_hz : array_like
        Mode frequencies [Hz] (a scalar is taken as one mode).
    band : float
        Relative half-width of the search for each peak: ``|PM|`` and the damped
        response are maximised over 2001 points in ``[(1 - band) f, (1 + band) f]``.

    Returns
    -------
    ModeDamping
        Per mode: ``freq_hz`` [Hz], the peaks ``open_db`` of ``|PM|`` and ``damped_db`` of
        ``|PM / (1 + CD PM)|`` [dB], ``attenuation_db = open_db - damped_db`` [dB], and
        ``estimate_db = 20 log10 (1 / |CD(j wn)|)`` [dB], the (5.69) approximation
        ``PM / (1 + CD PM) ~ 1 / CD`` valid where ``|CD PM| >> 1``; ``stable`` is whether
        every closed-loop pole has a negative real part.
    """
    closed = control.feedback(plant, cd)
    stable = bool(np.all(np.real(control.poles(closed)) < 0))

    from servokit.models.lti_response import lti_response  # sys(x) vectorised, same values

    def response(sys: control.LTI) -> Callable[[np.ndarray], np.ndarray]:
        return lambda s: np.asarray(lti_response(sys, s)).ravel()

    return _damping_peaks(response(plant), response(cd), freq_hz, band, stable)


def _damping_peaks(
    plant: Callable[[np.ndarray], np.ndarray],
    cd: Callable[[np.ndarray], np.ndarray],
    freq_hz: np.ndarray,
    band: float,
    stable: bool,
) -> ModeDamping:
    """:class:`ModeDamping` from the responses ``s -> PM(s)`` and ``s -> CD(s)``."""
    centres = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    rows = []
    for f in centres:
        s = 2j * np.pi * np.linspace((1 - band) * f, (1 + band) * f, 2001)
        p, c = plant(s), cd(s)
        at_wn = complex(cd(np.array([2j * np.pi * f]))[0])
        rows.append((np.abs(p).max(), np.abs(p / (1 + c * p)).max(), 1 / abs(at_wn)))
    a = 20 * np.log10(np.array(rows))
    return ModeDamping(centres, a[:, 0], a[:, 1], a[:, 0] - a[:, 1], a[:, 2], stable)


def amd_response(modes: list[tuple[float, float, float]], s: complex | np.ndarray) -> np.ndarray:
    """:func:`amd_controller` evaluated at ``s`` with numpy: the product of the factors (5.67).

    Parameters
    ----------
    modes : list of tuple of (float, float, float)
        ``(freq_hz, eps, kappa)`` per mode, as :func:`amd_controller`.
    s : complex or ndarray
        Laplace variable [rad/s] (e.g. ``2j pi f``).

    Returns
    -------
    ndarray of complex
        ``CD(s)``, the shape of ``s``.
    """
    if not modes:
        raise ServokitValueError("modes is empty; give at least one (freq_hz, eps, kappa)")
    s = np.asarray(s, dtype=complex)
    out = np.ones_like(s)
    for mode in modes:
        k, (a, b), (c, d) = _amd_factor(*mode)
        out = out * (k * (s + a) * (s + b) / ((s + c) * (s + d)))
    return out


def amd_statespace(
    modes: list[tuple[float, float, float]],
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A real state space ``(A, B, C, D)`` of :func:`amd_controller`: the factors in series.

    Each factor ``KD (s + a)(s + b)/((s + c)(s + d)) = KD + KD ((a + b - c - d) s + ab - cd) /
    (s^2 + (c + d) s + cd)`` in controllable companion form; one factor at a time keeps
    the coefficients at ``wn^2`` instead of the ``wn^(2m)`` of the expanded product.

    Parameters
    ----------
    modes : list of tuple of (float, float, float)
        ``(freq_hz, eps, kappa)`` per mode, as :func:`amd_controller`.

    Returns
    -------
    A : ndarray (2m, 2m)
    B : ndarray (2m, 1)
    C : ndarray (1, 2m)
    D : ndarray (1, 1)
    """
    if not modes:
        raise ServokitValueError("modes is empty; give at least one (freq_hz, eps, kappa)")
    A, B, C, D = np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
    for mode in modes:
        k, (a, b), (c, d) = _amd_factor(*mode)
        a2 = np.array([[0.0, 1.0], [-c * d, -(c + d)]])
        b2, c2 = np.array([[0.0], [1.0]]), k * np.array([[a * b - c * d, a + b - c - d]])
        n = A.shape[0]  # series: the new factor reads the output of the ones before
        A = np.block([[A, np.zeros((n, 2))], [b2 @ C, a2]])
        B = np.vstack([B, b2 @ D])
        C = np.hstack([k * C, c2])
        D = k * D
    return A, B, C, D


def amd_mode_damping(
    plant: ModalPlant, modes: list[tuple[float, float, float]], *, band: float = 0.1
) -> ModeDamping:
    """:func:`mode_damping` of :func:`amd_controller` ``(modes)`` on a modal plant, with numpy.

    The same numbers without python-control: the responses from
    :meth:`ModalPlant.freqresp` and :func:`amd_response`, stability from the eigenvalues of
    the closed loop of the plant's modal state space and :func:`amd_statespace`.

    Parameters
    ----------
    plant : ModalPlant
        Continuous PZT plant ``PM`` without input delay.
    modes : list of tuple of (float, float, float)
        ``(freq_hz, eps, kappa)`` per damped mode; the peaks are sought near each
        ``freq_hz``.
    band : float
        Relative half-width of each peak search, as :func:`mode_damping`.

    Returns
    -------
    ModeDamping
    """
    from servokit.models import modal_matrices

    if plant.delay != 0.0:
        raise ServokitValueError(
            "plant has an input delay: its closed loop has no finite state space; give a "
            "plant without delay (ModalPlant.replace(delay=0.0))"
        )
    ap, bp, cp = modal_matrices(*plant.arrays())
    ac, bc, cc, dc = amd_statespace(modes)
    # yM = PM (uM - CD yM): the controller reads the plant output, its output subtracts
    a_cl = np.block([[ap - bp @ dc @ cp, -bp @ cc], [bc @ cp, ac]])
    stable = bool(np.all(np.linalg.eigvals(a_cl).real < 0))
    return _damping_peaks(
        lambda s: plant.freqresp(s.imag / (2 * np.pi)),
        lambda s: amd_response(modes, s),
        [m[0] for m in modes],
        band,
        stable,
    )
