"""Dual-stage control structures: parallel, coupled and decoupled master-slave (book §5.5.1).

With the primary actuator (VCM) ``PV`` and its controller ``CV``, the secondary actuator
(PZT) ``PM`` and its controller ``CM``, and the secondary-actuator estimator ``PM*``
(``PM_hat``) used by the master-slave structures, the dual-stage open loop ``LD`` is

* parallel (Fig. 5.35), eq. (5.79): ``LD = CV PV + CM PM``;
* coupled master-slave (CMS, Fig. 5.36), eq. (5.82): ``LD = CM (PM + PV CV PM*)``, which is
  ``(1 + CV PV) CM PM`` when ``PM* = PM``;
* decoupled master-slave (DMS, Fig. 5.37), eq. (5.85): ``LD = CV PV (1 + CM PM*) + CM PM``,
  which is ``(1 + CM PM) CV PV + CM PM`` when ``PM* = PM``;

and ``SD = 1 / (1 + LD)``, ``TD = LD / (1 + LD)`` (5.80)-(5.81), (5.83)-(5.84),
(5.86)-(5.88).  With a perfect estimator the DMS sensitivity factors, ``SD = SV SM``
(5.87), and DMS equals a parallel loop whose primary controller is
``CVP = (1 + CM PM) CV`` (5.89).

The general forms with ``PM* != PM`` are derived here from the block diagrams (the book
states the structures only with ``PM* = PM``): in CMS the VCM controller reads the
estimated PZT output ``yM* = PM* CM e``; in DMS it reads ``e + yM*``.

Besides the loops, this module measures what Table 5.4 tabulates from frequency
responses (exact, delays included): the hand-off frequency where the two actuator paths
have equal magnitude, the phase difference there, and the gain/phase margins of ``LD``
read on a dense grid, including the second phase margin of a phase-stabilised loop.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError

__all__ = [
    "STRUCTURES",
    "DualStageLoops",
    "dual_stage_loops",
    "dual_stage_open_loop",
    "LoopMargins",
    "loop_margins",
    "handoff",
    "Handoff",
]

Structure = Literal["parallel", "cms", "dms"]
STRUCTURES: tuple[str, ...] = ("parallel", "cms", "dms")


def _check_structure(structure: str) -> str:
    key = str(structure).lower()
    if key not in STRUCTURES:
        raise ServokitValueError(
            f"structure must be one of {', '.join(STRUCTURES)} (got {structure!r})"
        )
    return key


def dual_stage_open_loop(pv, cv, pm, cm, structure: str = "dms", pm_hat=None):
    """Open loop ``LD`` of a dual-stage structure, eqs. (5.79), (5.82), (5.85).

    Works on anything with ``+`` and ``*``: complex frequency-response arrays or
    python-control LTI objects (``TransferFunction``, ``StateSpace``, ``FRD``).

    Parameters
    ----------
    pv, cv, pm, cm
        Primary plant and controller, secondary plant and controller.
    structure : {"parallel", "cms", "dms"}
    pm_hat
        Estimator ``PM*`` of the master-slave structures; ``pm`` if omitted.
    """
    key = _check_structure(structure)
    est = pm if pm_hat is None else pm_hat
    if key == "parallel":
        return cv * pv + cm * pm
    if key == "cms":
        return cm * (pm + pv * cv * est)
    return cv * pv * (1 + cm * est) + cm * pm


@dataclass(frozen=True)
class DualStageLoops:
    """Open loop ``L``, sensitivity ``S`` and complementary sensitivity ``T`` of a structure."""

    structure: str
    L: control.LTI
    S: control.LTI
    T: control.LTI


def dual_stage_loops(
    PV: control.LTI,
    CV: control.LTI,
    PM: control.LTI,
    CM: control.LTI,
    structure: str = "dms",
    *,
    PM_hat: control.LTI | None = None,
) -> DualStageLoops:
    """Dual-stage ``L``, ``S``, ``T`` as python-control objects (book §5.5.1).

    Parameters
    ----------
    PV, CV, PM, CM : control.LTI
        VCM plant and controller, PZT plant and controller (same timebase).
    structure : {"parallel", "cms", "dms"}
        Fig. 5.35 (5.79)-(5.81), Fig. 5.36 (5.82)-(5.84), Fig. 5.37 (5.85)-(5.88).
    PM_hat : control.LTI, optional
        Estimator ``PM*`` of the master-slave structures (``PM`` if omitted).

    Returns
    -------
    DualStageLoops
        ``S = feedback(1, L)`` and ``T = feedback(L, 1)``.
    """
    for name, sys in (("PV", PV), ("CV", CV), ("PM", PM), ("CM", CM)):
        if not isinstance(sys, control.LTI):
            raise ServokitValueError(f"{name} must be a python-control LTI system")
    L = dual_stage_open_loop(PV, CV, PM, CM, structure, PM_hat)
    one = control.ss([], [], [], [[1.0]], L.dt) if isinstance(L, control.StateSpace) else 1
    return DualStageLoops(
        _check_structure(structure), L, control.feedback(one, L), control.feedback(L, 1)
    )


# --------------------------------------------------------------- grid measurements
def _log_cross(freq: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Frequencies where the real sequence ``g`` changes sign, by linear interpolation
    in log-frequency between the grid points that bracket each sign change."""
    s = np.sign(g)
    idx = np.flatnonzero(s[:-1] * s[1:] < 0)
    lf = np.log(freq)
    t = g[idx] / (g[idx] - g[idx + 1])
    return np.exp(lf[idx] + t * (lf[idx + 1] - lf[idx]))


def _interp(freq: np.ndarray, values: np.ndarray, at: np.ndarray) -> np.ndarray:
    return np.interp(np.log(at), np.log(freq), values)


@dataclass(frozen=True)
class LoopMargins:
    """Margins of an open loop read on a frequency grid.

    ``crossovers_hz`` are all gain crossovers (|L| = 1), ascending; ``phase_margins_deg``
    the phase margin at each, ``180 + angle(L)``: the first in (-180, 180], the later
    ones in [0, 360) (a phase-stabilised resonance that crosses 0 dB again with phase
    lead has a margin above 180 deg: the book's "second phase margin", 223.8 deg in
    §5.5.3).
    ``gain_margin_db`` is the smallest ``-20 log10 |L|`` at a phase crossover above the
    first gain crossover (NaN if there is none).
    """

    gain_crossover_hz: float
    phase_margin_deg: float
    gain_margin_db: float
    phase_crossover_hz: float
    crossovers_hz: np.ndarray
    phase_margins_deg: np.ndarray

    @property
    def second_phase_margin_deg(self) -> float:
        """Phase margin at the second gain crossover (NaN if there is none)."""
        pm = self.phase_margins_deg
        return float(pm[1]) if pm.size > 1 else float("nan")


def loop_margins(freq_hz: np.ndarray, L: np.ndarray) -> LoopMargins:
    """Gain crossover(s), phase margin(s) and gain margin of a loop response ``L(j 2 pi f)``.

    Parameters
    ----------
    freq_hz : ndarray
        Ascending grid [Hz], dense enough to resolve the resonances (log-spaced).
    L : ndarray of complex
        Open-loop response on the grid.

    Returns
    -------
    LoopMargins
        First gain crossover [Hz] and its phase margin [deg], every gain crossover
        (``crossovers_hz``, ``phase_margins_deg``; the second is the book's second phase
        margin), and the smallest gain margin [dB] over the phase crossovers above the
        first gain crossover with its frequency [Hz] (NaN if there is none).  Crossings
        are interpolated linearly in log-frequency between grid points.

    Raises
    ------
    ServokitValueError
        If the grid is not ascending and positive, ``L`` is not finite, or ``|L|`` never
        crosses 0 dB on the grid.
    """
    f = np.asarray(freq_hz, dtype=float)
    L = np.asarray(L, dtype=complex)
    if f.ndim != 1 or f.size < 3 or np.any(np.diff(f) <= 0) or f[0] <= 0:
        raise ServokitValueError("freq_hz must be an ascending grid of > 2 positive frequencies")
    if not np.all(np.isfinite(L)):
        raise ServokitValueError("the loop response holds NaN or inf; check the models")
    mag_db = 20 * np.log10(np.abs(L))
    phase = np.degrees(np.unwrap(np.angle(L)))
    wc = _log_cross(f, mag_db)
    if wc.size == 0:
        raise ServokitValueError("the loop never crosses 0 dB on the grid; widen fmin/fmax")
    pms = (180.0 + _interp(f, phase, wc)) % 360.0
    pms[0] = pms[0] - 360.0 if pms[0] > 180.0 else pms[0]
    # phase crossovers: phase = -180 + k 360 (|L| measured on the unwrapped phase)
    k = np.round((phase + 180.0) / 360.0)
    shifted = phase + 180.0 - 360.0 * k
    # only genuine crossings (the shift jumps by 360 where k changes)
    wp = _log_cross(f, np.where(np.abs(shifted) < 90, shifted, np.nan))
    wp = wp[wp > wc[0]]
    gms = -_interp(f, mag_db, wp)
    i = int(np.argmin(gms)) if gms.size else -1
    return LoopMargins(
        gain_crossover_hz=float(wc[0]),
        phase_margin_deg=float(pms[0]),
        gain_margin_db=float(gms[i]) if gms.size else float("nan"),
        phase_crossover_hz=float(wp[i]) if gms.size else float("nan"),
        crossovers_hz=wc,
        phase_margins_deg=pms,
    )


@dataclass(frozen=True)
class Handoff:
    """Hand-off frequency where two actuator paths have equal magnitude, and the phase
    difference ``|angle(a) - angle(b)|`` there (wrapped to [0, 180] deg)."""

    freq_hz: float
    phase_difference_deg: float


def handoff(freq_hz: np.ndarray, a: np.ndarray, b: np.ndarray) -> Handoff:
    """First frequency where ``|a| = |b|`` and the phase difference there (book §5.5.2).

    For Table 5.4 ``a = CV PV`` (VCM path) and ``b = CM PM`` (PZT path).

    Parameters
    ----------
    freq_hz : ndarray
        Ascending positive grid [Hz].
    a, b : ndarray of complex
        Frequency responses of the two paths on the grid.

    Returns
    -------
    Handoff
        ``freq_hz``, the lowest frequency where ``|a / b|`` crosses 1 (interpolated in
        log-frequency) [Hz], and ``phase_difference_deg``, ``|angle(a) - angle(b)|``
        there, wrapped to [0, 180] deg.

    Raises
    ------
    ServokitValueError
        If the two magnitudes never cross on the grid.
    """
    f = np.asarray(freq_hz, dtype=float)
    a, b = np.asarray(a, dtype=complex), np.asarray(b, dtype=complex)
    ratio = a / b
    fx = _log_cross(f, np.log(np.abs(ratio)))
    if fx.size == 0:
        raise ServokitValueError("the two paths never have equal magnitude on the grid")
    # phase of the ratio interpolated on its unwrapped phase
    dphi = _interp(f, np.unwrap(np.angle(ratio)), fx[:1])[0]
    wrapped = abs((np.degrees(dphi) + 180.0) % 360.0 - 180.0)
    return Handoff(float(fx[0]), float(wrapped))
