"""The §5.5.2 dual-stage design example: VCM and PZT loops by three methods, Table 5.4.

Plants: the Table 5.1 VCM (5.1) and the Table 5.3 PZT active suspension (5.12), from
:mod:`servokit.models`.  Controllers, with every parameter the book prints:

* VCM base (5.91) ``CCV = KCV (s + 100 pi)^2 / (s (s + 2 pi 30000))``;
  gain stabilisation: ``KCV = 5`` and notches (5.14) at 4449, 6412, 7141, 8600 Hz;
  inverse compensation: ``KCV = 3.3302`` and zero/pole pairs (4449, 4775), (6412, 5691),
  (7141, 6973), (8599, 7515) Hz; phase stabilisation: notches at 3800 and 4449 Hz, the
  peak filter (5.17) with K = 0.1778, phi = 2.5414 rad, f1 = 4449 Hz, zeta1 = 0.015 added
  as ``C (1 + F)`` (5.22), and the complex lag (5.92)-(5.94) at 6900 Hz, zeta_lg = 0.1,
  phi_m = 1.1519 rad.
* PZT base (5.96) ``CCM = KCM (s + 2 pi 30000) / (s + 2 pi 900)``; gain: ``KCM = 0.18`` and
  notches at 2484, 5461, 6074, 9103, 12000 Hz; inverse: ``KCM = 0.2473`` and pairs
  (2484, 2751), (5461, 5686), (6074, 6646), (9103, 9549), (12000, 11672) Hz; phase: the
  pair (2484, 2751), the peak filter K = 0.1585, phi = 4.2603 rad, f1 = 2484 Hz,
  zeta1 = 0.02, the pair (4600, 8000) Hz with zero/pole damping 0.03/0.7, the pair
  (6074, 6646) Hz, the first-order lag with zero 15000 Hz and pole 6074 Hz, and notches
  at 9103 and 13120 Hz.

These give the printed controller orders 10/11, 10/11, 10/14.

What the book does not state, and servokit makes explicit (:class:`Unknowns`):

* ``notch_damping`` ``zeta_D`` of every notch (5.14).  The book's range
  ``sqrt(2) < zeta_D <= 1`` is empty; read as ``1/sqrt(2) <= zeta_D <= 1``.
* the notch numerator damping ``notch_depth_damping`` (0: the damping of the mode
  notched, the reading of (5.14)) and the notch pole frequency ``fD = notch_freq_ratio fR``
  (1: ``fD = fR``; the book mentions ``fD > fR`` as an option).
* the numerator damping of notches at frequencies that are no mode of the tables
  (3800 Hz for the VCM, 13120 Hz for the PZT): ``extra_notch_depth_damping``.
* the pole damping of the inverse pairs.  Where the pole frequency is a zero of the
  tabulated model (5691, 6973, 7515 Hz; 2751, 5686, 6646, 11672 Hz, computed, not typed)
  the zero's own damping is used; two pairs, (4449, 4775) and (9103, 9549) Hz, match no
  zero of the models (the VCM has no zero within 15 % of 4775 Hz, the PZT none near
  9549 Hz), and their pole damping is ``pair_pole_damping``.
* the final gains of the phase-stabilised designs (``kcv_phase``, ``kcm_phase``): the book
  prints only the baseline gains 4.9175 and 0.1737 used to set phi.
* the input delays of the plants (``delay_vcm_s``, ``delay_pzt_s``): the text says the PZT
  has one (it motivates the partial inverse) but gives no value.
* continuous or sampled evaluation: servokit evaluates the continuous loop; a
  sampled-and-held loop is approximated by the delay (half a hold period plus
  computation), which is why the delays are searched.

Zero/pole damping of the inverse pairs at the plant modes is the mode's Table damping.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Literal

import control
import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedback.dual_stage import (
    dual_stage_open_loop,
    handoff,
    loop_margins,
)
from servokit.feedback.filters import (
    complex_lag,
    inverse_pair,
    lag,
    lead_lag,
    notch,
    peak_filter,
)
from servokit.feedback.margins import stability_margins
from servokit.models import ModalPlant, pzt_active_suspension, vcm_dual_stage

__all__ = [
    "METHODS",
    "Unknowns",
    "Cascade",
    "zero_pole_pair",
    "peak_filter_addon",
    "vcm_controller",
    "pzt_controller",
    "DesignRow",
    "evaluate_design",
    "BOOK_TABLE_5_4",
    "DEFAULT_GRID_HZ",
]

Method = Literal["gain", "inverse", "phase"]
METHODS: tuple[str, ...] = ("gain", "inverse", "phase")
TWO_PI = 2.0 * np.pi

#: the rows of Table 5.4 as printed, per method
BOOK_TABLE_5_4: dict[str, dict[str, str]] = {
    "gain": {
        "order_cv": "10",
        "order_cm": "11",
        "handoff_hz": "304",
        "phase_difference_deg": "84.9",
        "crossover_hz": "1.51e3",
        "gain_margin_db": "14.1",
        "phase_margin_deg": "31.8",
        "s_inf_db": "8.1",
    },
    "inverse": {
        "order_cv": "10",
        "order_cm": "11",
        "handoff_hz": "371",
        "phase_difference_deg": "88.0",
        "crossover_hz": "1.52e3",
        "gain_margin_db": "14.3",
        "phase_margin_deg": "66.9",
        "s_inf_db": "2.7",
    },
    "phase": {
        "order_cv": "10",
        "order_cm": "14",
        "handoff_hz": "317",
        "phase_difference_deg": "86.7",
        "crossover_hz": "1.64e3",
        "gain_margin_db": "9.28",
        "phase_margin_deg": "49.7",
        "s_inf_db": "5.2",
        "second_phase_margin_deg": "223.8",
        # §5.5.2: the printed peak-filter phases, read as arg T_baseline(j w1) - pi/2
        "phi_vcm_deg": str(round(np.degrees(2.5414), 1)),
        "phi_pzt_deg": str(round(np.degrees(4.2603), 1)),
    },
}


def design_grid(n_log: int, fmin: float = 1.0, fmax: float = 6.0e4) -> np.ndarray:
    """Log grid plus 41 points across each plant mode's half-power band (+-5 bandwidths):
    a 0.1 %-damped mode (the VCM at 32.8 kHz) is 66 Hz wide, finer than a log grid."""
    local = [
        m.freq_hz * (1.0 + m.damping * np.linspace(-10.0, 10.0, 41))
        for p in (vcm_dual_stage(), pzt_active_suspension())
        for m in p.modes
        if m.freq_hz > 100.0
    ]
    grid = np.unique(np.concatenate([np.geomspace(fmin, fmax, n_log), *local]))
    return grid[(grid >= fmin) & (grid <= fmax)]


#: grid for the design example: 1 Hz .. 60 kHz, log-spaced plus mode-local points
DEFAULT_GRID_HZ = design_grid(24000)


@dataclass(frozen=True)
class Unknowns:
    """Parameters the book leaves unstated (see the module docstring)."""

    notch_damping: float = 0.7
    notch_depth_damping: float = 0.0
    notch_freq_ratio: float = 1.0
    extra_notch_depth_damping: float = 0.05
    pair_pole_damping: float = 0.05
    kcv_phase: float = 4.9175
    kcm_phase: float = 0.1737
    delay_vcm_s: float = 0.0
    delay_pzt_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("notch_damping", "extra_notch_depth_damping", "pair_pole_damping"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0 < v <= 2):
                raise ServokitValueError(f"{name} must be in (0, 2] (got {v})")
        if not (np.isfinite(self.notch_depth_damping) and 0 <= self.notch_depth_damping <= 2):
            raise ServokitValueError(
                f"notch_depth_damping must be in [0, 2] (0: the mode's damping; got "
                f"{self.notch_depth_damping})"
            )
        if not (np.isfinite(self.notch_freq_ratio) and 0.5 <= self.notch_freq_ratio <= 3):
            raise ServokitValueError(
                f"notch_freq_ratio must be in [0.5, 3] (got {self.notch_freq_ratio})"
            )
        for name in ("kcv_phase", "kcm_phase"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ServokitValueError(f"{name} must be > 0 (got {getattr(self, name)})")
        for name in ("delay_vcm_s", "delay_pzt_s"):
            if not (np.isfinite(getattr(self, name)) and 0 <= getattr(self, name) < 1e-3):
                raise ServokitValueError(f"{name} must be in [0, 1e-3) s")


# ------------------------------------------------------------------ filter factors
# The filters of §5.3 live in :mod:`servokit.feedback.filters`; these two adapt them to
# the design example's conventions.
def zero_pole_pair(
    zero_hz: float, pole_hz: float, zero_damping: float, pole_damping: float
) -> control.TransferFunction:
    """Second-order filter with complex zeros and poles, monic (unit gain at high frequency).

    The book does not say how the pairs are scaled.  Monic pairs make the inverse VCM
    controller's low-frequency gain ``3.3302 prod (f_z/f_p)^2`` equal to the gain-method
    ``KCV = 5`` (the book: gains chosen "to ensure that the gain crossover frequencies are
    identical"); unit-DC-gain pairs (:func:`~servokit.feedback.filters.inverse_pair`)
    would not.

    Parameters
    ----------
    zero_hz, pole_hz : float
        Natural frequencies of the zeros and of the poles [Hz].
    zero_damping, pole_damping : float
        Their damping ratios (pole damping > 0).

    Returns
    -------
    control.TransferFunction
        ``(s^2 + 2 zeta_z wz s + wz^2) / (s^2 + 2 zeta_p wp s + wp^2)``, continuous, DC
        gain ``(f_z / f_p)^2``.
    """
    pair = inverse_pair(zero_hz, pole_hz, zero_damping=zero_damping, pole_damping=pole_damping)
    return pair * (zero_hz / pole_hz) ** 2


def peak_filter_addon(
    freq_hz: float, damping: float, gain: float, phi: float
) -> control.TransferFunction:
    """``1 + F(s)`` with the peak filter ``F`` of (5.17): the add-on factor of (5.22).

    Parameters
    ----------
    freq_hz : float
        Centre frequency ``f1`` of the peak filter [Hz].
    damping : float
        ``zeta1`` (> 0).
    gain : float
        ``K`` (> 0).
    phi : float
        Zero-placement phase ``phi`` [rad].

    Returns
    -------
    control.TransferFunction
        The continuous factor ``1 + F(s)``, multiplying the baseline controller.
    """
    return 1 + peak_filter(freq_hz, damping, gain, phi)


@dataclass(frozen=True)
class Cascade:
    """A controller as a product of factors (evaluated factor by factor: the product's
    polynomial coefficients would span ~70 orders of magnitude)."""

    factors: tuple[control.TransferFunction, ...]
    names: tuple[str, ...] = field(default=())

    @property
    def order(self) -> int:
        return sum(len(f.den[0][0]) - 1 for f in self.factors)

    def freqresp(self, freq_hz: np.ndarray) -> np.ndarray:
        s = TWO_PI * 1j * np.asarray(freq_hz, dtype=float)
        out = np.ones_like(s)
        for f in self.factors:
            out = out * np.polyval(f.num[0][0], s) / np.polyval(f.den[0][0], s)
        return out

    def tf(self) -> control.TransferFunction:
        """The product as one python-control transfer function."""
        out = self.factors[0]
        for f in self.factors[1:]:
            out = out * f
        return out


# ------------------------------------------------------------------ the controllers
def _mode_damping(plant: ModalPlant, freq_hz: float, rel: float = 0.01) -> float | None:
    for m in plant.modes:
        if abs(m.freq_hz - freq_hz) <= rel * freq_hz:
            return m.damping
    return None


def _zero_damping(zeros: dict[float, float], freq_hz: float, rel: float = 0.01) -> float | None:
    for f, z in zeros.items():
        if abs(f - freq_hz) <= rel * freq_hz:
            return z
    return None


@lru_cache(maxsize=8)
def plant_zeros(plant: ModalPlant) -> dict[float, float]:
    """Complex zeros of the modal plant in the upper half plane: {freq [Hz]: damping}."""
    z = control.zeros(plant.to_statespace())
    z = z[(np.imag(z) > 0) & (np.abs(z) < TWO_PI * 1e6)]
    return {float(abs(v) / TWO_PI): float(-v.real / abs(v)) for v in z}


def _notches(plant: ModalPlant, freqs: tuple[float, ...], u: Unknowns) -> list:
    out = []
    for f in freqs:
        zr = u.notch_depth_damping or _mode_damping(plant, f) or u.extra_notch_depth_damping
        out.append(
            notch(f, zr, filter_freq_hz=u.notch_freq_ratio * f, filter_damping=u.notch_damping)
        )
    return out


def _pairs(plant: ModalPlant, pairs: tuple[tuple[float, float], ...], u: Unknowns) -> list:
    zeros = plant_zeros(plant)
    out = []
    for fz, fp in pairs:
        zz = _mode_damping(plant, fz)
        zp = _zero_damping(zeros, fp)
        out.append(
            zero_pole_pair(
                fz,
                fp,
                u.pair_pole_damping if zz is None else zz,
                u.pair_pole_damping if zp is None else zp,
            )
        )
    return out


def _check_method(method: str) -> str:
    if method not in METHODS:
        raise ServokitValueError(f"method must be one of {', '.join(METHODS)} (got {method!r})")
    return method


def vcm_controller(method: str, u: Unknowns = Unknowns(), *, baseline: bool = False) -> Cascade:
    """VCM loop controller ``CV`` of §5.5.2.1 (``baseline``: phase method without
    peak filter and lag, KCV = 4.9175, the loop the peak-filter phase phi is read on).

    Parameters
    ----------
    method : {"gain", "inverse", "phase"}
        Gain stabilisation (lead-lag (5.91), KCV = 5, notches (5.14)), inverse compensation
        (KCV = 3.3302, monic zero/pole pairs) or phase stabilisation (notches at 3800 and
        4449 Hz, ``KCV = u.kcv_phase``, peak-filter add-on (5.22) and complex lag
        (5.92)-(5.94)); see the module docstring for the printed parameters.
    u : Unknowns
        The unstated notch and pair dampings, notch pole frequency ratio and phase-method
        gain.
    baseline : bool
        For ``method="phase"`` only: the lead-lag with KCV = 4.9175 and the two notches,
        without peak filter and lag.  Ignored by the other methods.

    Returns
    -------
    Cascade
        The continuous controller as a product of factors.
    """
    pv = vcm_dual_stage()
    if _check_method(method) == "gain":
        return Cascade((lead_lag(5.0), *_notches(pv, (4449, 6412, 7141, 8600), u)))
    if method == "inverse":
        pairs = ((4449, 4775), (6412, 5691), (7141, 6973), (8599, 7515))
        return Cascade((lead_lag(3.3302), *_pairs(pv, pairs, u)))
    notches = _notches(pv, (3800, 4449), u)
    if baseline:
        return Cascade((lead_lag(4.9175), *notches))
    return Cascade(
        (
            lead_lag(u.kcv_phase),
            *notches,
            peak_filter_addon(4449, 0.015, 0.1778, 2.5414),
            complex_lag(6900, 0.1, 1.1519),
        )
    )


def pzt_controller(method: str, u: Unknowns = Unknowns(), *, baseline: bool = False) -> Cascade:
    """PZT loop controller ``CM`` of §5.5.2.2 (``baseline`` as in :func:`vcm_controller`,
    KCM = 0.1737 with the (2484, 2751) Hz pair).

    Parameters
    ----------
    method : {"gain", "inverse", "phase"}
        Gain stabilisation (lag (5.96), KCM = 0.18, notches (5.14)), inverse compensation
        (KCM = 0.2473, monic zero/pole pairs) or phase stabilisation (``KCM = u.kcm_phase``,
        the (2484, 2751) Hz pair, peak-filter add-on (5.22), the (4600, 8000) and
        (6074, 6646) Hz pairs, a first-order lag and notches at 9103 and 13120 Hz); see
        the module docstring for the printed parameters.
    u : Unknowns
        The unstated notch and pair dampings, notch pole frequency ratio and phase-method
        gain.
    baseline : bool
        For ``method="phase"`` only: the lag with KCM = 0.1737 and the (2484, 2751) Hz
        pair.  Ignored by the other methods.

    Returns
    -------
    Cascade
        The continuous controller as a product of factors.
    """
    pm = pzt_active_suspension()
    if _check_method(method) == "gain":
        return Cascade((lag(0.18), *_notches(pm, (2484, 5461, 6074, 9103, 12000), u)))
    if method == "inverse":
        pairs = ((2484, 2751), (5461, 5686), (6074, 6646), (9103, 9549), (12000, 11672))
        return Cascade((lag(0.2473), *_pairs(pm, pairs, u)))
    first = _pairs(pm, ((2484, 2751),), u)
    if baseline:
        return Cascade((lag(0.1737), *first))
    lead = zero_pole_pair(4600, 8000, 0.03, 0.7)
    first_order_lag = lag(6074 / 15000, zero_hz=15000, pole_hz=6074)  # unit DC gain
    return Cascade(
        (
            lag(u.kcm_phase),
            *first,
            peak_filter_addon(2484, 0.02, 0.1585, 4.2603),
            lead,
            *_pairs(pm, ((6074, 6646),), u),
            first_order_lag,
            *_notches(pm, (9103, 13120), u),
        )
    )


# ------------------------------------------------------------------ Table 5.4
@dataclass(frozen=True)
class DesignRow:
    """One column of Table 5.4 computed by servokit."""

    method: str
    order_cv: int
    order_cm: int
    handoff_hz: float
    phase_difference_deg: float
    crossover_hz: float
    gain_margin_db: float
    phase_margin_deg: float
    s_inf_db: float
    second_phase_margin_deg: float
    phi_vcm_deg: float = float("nan")
    phi_pzt_deg: float = float("nan")

    def as_dict(self) -> dict[str, float | int | str]:
        return dict(self.__dict__)


@dataclass(frozen=True)
class DesignResponses:
    """Frequency responses of the design (for the figures)."""

    freq_hz: np.ndarray
    vcm_loop: np.ndarray
    pzt_loop: np.ndarray
    open_loop: np.ndarray
    sensitivity: np.ndarray


def design_responses(
    method: str,
    u: Unknowns = Unknowns(),
    freq_hz: np.ndarray = DEFAULT_GRID_HZ,
    structure: str = "dms",
) -> DesignResponses:
    """``CV PV``, ``CM PM``, the dual-stage ``LD`` and ``SD`` on ``freq_hz`` (delays exact)."""
    return _responses(vcm_controller(method, u), pzt_controller(method, u), u, freq_hz, structure)


def _responses(
    cv_: Cascade, cm_: Cascade, u: Unknowns, freq_hz: np.ndarray, structure: str
) -> DesignResponses:
    pv = vcm_dual_stage().replace(delay=u.delay_vcm_s).freqresp(freq_hz)
    pm = pzt_active_suspension().replace(delay=u.delay_pzt_s).freqresp(freq_hz)
    cv, cm = cv_.freqresp(freq_hz), cm_.freqresp(freq_hz)
    ld = dual_stage_open_loop(pv, cv, pm, cm, structure)
    return DesignResponses(freq_hz, cv * pv, cm * pm, ld, 1.0 / (1.0 + ld))


def evaluate_design(
    method: str,
    u: Unknowns = Unknowns(),
    freq_hz: np.ndarray = DEFAULT_GRID_HZ,
    structure: str = "dms",
    *,
    refine: bool = False,
) -> DesignRow:
    """Table 5.4 quantities of one method (DMS structure by default, as in the book).

    Margins are read on ``freq_hz`` (:func:`~servokit.feedback.dual_stage.loop_margins`,
    fast, used by the search) or, with ``refine``, by
    :func:`~servokit.feedback.margins.stability_margins` (root-refined crossings on
    60000 log-spaced points over the same band; agrees to ~1e-4 dB / 1e-6 deg).

    Parameters
    ----------
    method : {"gain", "inverse", "phase"}
        Design method of :func:`vcm_controller` and :func:`pzt_controller`.
    u : Unknowns
        The unstated parameters, including the plant input delays, applied exactly.
    freq_hz : ndarray
        Ascending frequency grid [Hz] for the responses, the hand-off and the grid margins.
    structure : {"parallel", "cms", "dms"}
        Dual-stage structure of the open loop ``LD`` (perfect estimator ``PM* = PM``).
    refine : bool
        Read the crossover and margins with
        :func:`~servokit.feedback.margins.stability_margins` instead of on the grid.

    Returns
    -------
    DesignRow
        ``method``; controller orders ``order_cv``, ``order_cm``; hand-off of ``CV PV`` and
        ``CM PM`` (``handoff_hz`` [Hz], ``phase_difference_deg``); first gain crossover of
        ``LD`` (``crossover_hz`` [Hz]), ``gain_margin_db``, ``phase_margin_deg`` and
        ``second_phase_margin_deg`` (NaN without a second crossover); ``s_inf_db``, the
        peak of ``|SD|`` on the grid [dB]; and, for ``method="phase"``, the peak-filter
        phases ``phi_vcm_deg``, ``phi_pzt_deg`` of the baseline loops (NaN otherwise).

    Raises
    ------
    ServokitValueError
        If ``method`` is unknown or ``LD`` never crosses 0 dB on the grid.
    """
    cv, cm = vcm_controller(method, u), pzt_controller(method, u)
    r = _responses(cv, cm, u, freq_hz, structure)
    m = loop_margins(freq_hz, r.open_loop)
    crossover, gm, pm, pm2 = (
        m.gain_crossover_hz,
        m.gain_margin_db,
        m.phase_margin_deg,
        m.second_phase_margin_deg,
    )
    if refine:
        sm = stability_margins(
            lambda f: _responses(cv, cm, u, f, structure).open_loop,
            fmin=float(freq_hz[0]),
            fmax=float(freq_hz[-1]),
            n_freq=60000,
        )
        crossover, gm = sm.pm_freq_hz, sm.gain_margin_db
        pm, pm2 = sm.phase_margin_deg, sm.second_phase_margin_deg
    h = handoff(freq_hz, r.vcm_loop, r.pzt_loop)
    return DesignRow(
        method=method,
        order_cv=cv.order,
        order_cm=cm.order,
        handoff_hz=h.freq_hz,
        phase_difference_deg=h.phase_difference_deg,
        crossover_hz=crossover,
        gain_margin_db=gm,
        phase_margin_deg=pm,
        s_inf_db=float(20 * np.log10(np.max(np.abs(r.sensitivity)))),
        second_phase_margin_deg=pm2,
        **(peak_filter_phases(u) if method == "phase" else {}),
    )


def peak_filter_phases(u: Unknowns) -> dict[str, float]:
    """The peak-filter phases the baseline loops of the phase method give [deg, 0..360).

    §5.5.2 says phi "is chosen to be equivalent to the phase of the baseline closed-loop
    transfer function at w1"; servokit reads it as ``arg T(j w1) - pi/2`` (the zero
    placement whose filter poles depart at 0 deg, (5.51) corrected), which reproduces the
    printed VCM value 2.5414 rad with the delay found on the inverse column.
    """
    out = {}
    for key, ctrl, plant, f1 in (
        ("phi_vcm_deg", vcm_controller, vcm_dual_stage().replace(delay=u.delay_vcm_s), 4449.0),
        (
            "phi_pzt_deg",
            pzt_controller,
            pzt_active_suspension().replace(delay=u.delay_pzt_s),
            2484.0,
        ),
    ):
        f = np.array([f1])
        loop = ctrl("phase", u, baseline=True).freqresp(f)[0] * plant.freqresp(f)[0]
        out[key] = float(np.degrees(np.angle(loop / (1 + loop)) - np.pi / 2) % 360.0)
    return out


def with_unknowns(u: Unknowns, **changes: float) -> Unknowns:
    """``u`` with some unknowns replaced."""
    return replace(u, **changes)


# ------------------------------------------------------------------ the search
#: the issue's tolerances per Table 5.4 row: relative for frequencies, absolute otherwise
ROW_TOLERANCES: dict[str, float] = {
    "handoff_hz": 0.05,
    "phase_difference_deg": 5.0,
    "crossover_hz": 0.05,
    "gain_margin_db": 1.0,
    "phase_margin_deg": 5.0,
    "s_inf_db": 1.0,
    "second_phase_margin_deg": 5.0,
    "phi_vcm_deg": 5.0,
    "phi_pzt_deg": 5.0,
}

#: search ranges of the unknowns (physically sensible: damping ratios of filters, delays of
#: a few samples at most)
SEARCH_BOUNDS: dict[str, tuple[float, float]] = {
    "notch_damping": (0.1, 1.5),
    "extra_notch_depth_damping": (0.005, 0.5),
    "notch_depth_damping": (0.0, 0.5),
    "notch_freq_ratio": (1.0, 1.5),
    "pair_pole_damping": (0.01, 1.0),
    "kcv_phase": (0.5, 20.0),
    "kcm_phase": (0.05, 2.0),
    "delay_vcm_s": (0.0, 1.0e-4),
    "delay_pzt_s": (0.0, 1.0e-4),
}

#: the unknowns each method depends on
METHOD_UNKNOWNS: dict[str, tuple[str, ...]] = {
    "gain": ("notch_damping", "delay_vcm_s", "delay_pzt_s"),
    "inverse": ("pair_pole_damping", "delay_vcm_s", "delay_pzt_s"),
    "phase": (
        "notch_damping",
        "extra_notch_depth_damping",
        "kcv_phase",
        "kcm_phase",
        "delay_vcm_s",
        "delay_pzt_s",
    ),
}

#: coarse grid for the search (the final rows are evaluated on :data:`DEFAULT_GRID_HZ`)
SEARCH_GRID_HZ = design_grid(4000, fmin=5.0)


def table_cost(row: DesignRow) -> float:
    """Sum of squared misses of ``row`` against Table 5.4, each in units of the issue's
    tolerance (5 % / 1 dB / 5 deg), capped at 100 per row (missing value: 100)."""
    book = BOOK_TABLE_5_4[row.method]
    total = 0.0
    for key, tol in ROW_TOLERANCES.items():
        if key not in book:
            continue
        b, v = float(book[key]), float(getattr(row, key))
        err = (v - b) / (b * tol) if key.endswith("_hz") else (v - b) / tol
        total += min(err * err, 100.0) if np.isfinite(err) else 100.0
    return total


@dataclass(frozen=True)
class FitResult:
    """Unknowns found by :func:`fit_unknowns`, the cost and the row they give."""

    method: str
    unknowns: Unknowns
    free: tuple[str, ...]
    cost: float
    n_evaluations: int
    row: DesignRow


def fit_unknowns(
    method: str,
    *,
    free: tuple[str, ...] | None = None,
    start: Unknowns = Unknowns(),
    maxiter: int = 60,
    popsize: int = 12,
    seed: int = 1,
    freq_hz: np.ndarray = SEARCH_GRID_HZ,
    on_generation: Callable[[], object] | None = None,
) -> FitResult:
    """Search the unstated parameters that best reproduce one column of Table 5.4.

    Differential evolution (:func:`scipy.optimize.differential_evolution`) over
    :data:`SEARCH_BOUNDS` of the ``free`` unknowns (default: those the method depends on,
    :data:`METHOD_UNKNOWNS`), the others held at ``start``; cost :func:`table_cost`.
    ``on_generation`` is called after each generation (a progress bar).
    """
    from scipy.optimize import differential_evolution

    names = METHOD_UNKNOWNS[_check_method(method)] if free is None else tuple(free)
    unknown = [n for n in names if n not in SEARCH_BOUNDS]
    if unknown:
        raise ServokitValueError(f"cannot search {unknown[0]!r}; choose from {list(SEARCH_BOUNDS)}")

    def unpack(x: np.ndarray) -> Unknowns:
        return replace(start, **{n: float(v) for n, v in zip(names, x, strict=True)})

    def cost(x: np.ndarray) -> float:
        try:
            return table_cost(evaluate_design(method, unpack(x), freq_hz))
        except ServokitValueError:  # no crossover on the grid: an unusable design
            return 1e3

    res = differential_evolution(
        cost,
        [SEARCH_BOUNDS[n] for n in names],
        maxiter=maxiter,
        popsize=popsize,
        seed=seed,
        tol=1e-6,
        polish=True,
        callback=None if on_generation is None else (lambda *_a, **_k: on_generation()),
    )
    best = unpack(res.x)
    row = evaluate_design(method, best)
    return FitResult(method, best, names, table_cost(row), int(res.nfev), row)
