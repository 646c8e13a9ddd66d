"""Controllers of the §5.5.2 dual-stage design example: VCM and PZT loops, three methods.

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

This module holds the controllers (:func:`vcm_controller`, :func:`pzt_controller`, as a
:class:`Cascade` of factors), the unstated parameters (:class:`Unknowns`) and the two
filter factors of the example; :mod:`servokit.feedback.dual_stage_design` evaluates them
against Table 5.4 and searches the unknowns.

The factors are numpy coefficients (:class:`~servokit.models.rational.RationalTF`, built
from the filters' ``*_coefficients`` twins) and the plant zeros are the poles of the
zero dynamics (:func:`~servokit.models.rational.siso_zeros`: within 2.2e-14 of a
150-digit reference on the VCM plant, where the Rosenbrock pencil's QZ python-control
uses is off by up to 1.8e-6), so evaluating a design imports neither python-control nor
scipy.linalg (``servokit dual-stage`` start-up, issue 23). :func:`zero_pole_pair`,
:func:`peak_filter_addon` and :meth:`Cascade.tf` still return python-control transfer
functions, with the same coefficients.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Literal

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError
from servokit.feedback.filters import (
    complex_lag_coefficients,
    inverse_pair_coefficients,
    lag_coefficients,
    lead_lag_coefficients,
    notch_coefficients,
    peak_filter_coefficients,
)
from servokit.models import ModalPlant, pzt_active_suspension, vcm_dual_stage
from servokit.models.modal import modal_matrices
from servokit.models.rational import RationalTF, siso_zeros

__all__ = [
    "METHODS",
    "Unknowns",
    "Cascade",
    "zero_pole_pair",
    "peak_filter_addon",
    "vcm_controller",
    "pzt_controller",
]

Method = Literal["gain", "inverse", "phase"]
METHODS: tuple[str, ...] = ("gain", "inverse", "phase")
TWO_PI = 2.0 * np.pi


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
    return _pair(zero_hz, pole_hz, zero_damping, pole_damping).to_control()


def _pair(zero_hz: float, pole_hz: float, zero_damping: float, pole_damping: float) -> RationalTF:
    """:func:`zero_pole_pair` as numpy coefficients."""
    pair = RationalTF(
        *inverse_pair_coefficients(
            zero_hz, pole_hz, zero_damping=zero_damping, pole_damping=pole_damping
        )
    )
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
    return _addon(freq_hz, damping, gain, phi).to_control()


def _addon(freq_hz: float, damping: float, gain: float, phi: float) -> RationalTF:
    """:func:`peak_filter_addon` as numpy coefficients (python-control's ``1 + F`` sum)."""
    return 1 + RationalTF(*peak_filter_coefficients(freq_hz, damping, gain, phi))


@dataclass(frozen=True)
class Cascade:
    """A controller as a product of factors (evaluated factor by factor: the product's
    polynomial coefficients would span ~70 orders of magnitude)."""

    factors: tuple[RationalTF, ...]
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
        out = self.factors[0].to_control()
        for f in self.factors[1:]:
            out = out * f.to_control()
        return out


# ------------------------------------------------------------------ the controllers
def _lead_lag(gain: float) -> RationalTF:
    return RationalTF(*lead_lag_coefficients(gain))


def _lag(gain: float, **corners_hz: float) -> RationalTF:
    return RationalTF(*lag_coefficients(gain, **corners_hz))


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
    A, B, C = modal_matrices(*plant.arrays())  # plant.to_statespace() without python-control
    z = siso_zeros(A, B, C)  # the zero dynamics: accurate here where QZ is not, no scipy
    z = z[(np.imag(z) > 0) & (np.abs(z) < TWO_PI * 1e6)]
    return {float(abs(v) / TWO_PI): float(-v.real / abs(v)) for v in z}


def _notches(plant: ModalPlant, freqs: tuple[float, ...], u: Unknowns) -> list:
    out = []
    for f in freqs:
        zr = u.notch_depth_damping or _mode_damping(plant, f) or u.extra_notch_depth_damping
        num, den = notch_coefficients(
            f, zr, filter_freq_hz=u.notch_freq_ratio * f, filter_damping=u.notch_damping
        )
        out.append(RationalTF(num, den))
    return out


def _pairs(plant: ModalPlant, pairs: tuple[tuple[float, float], ...], u: Unknowns) -> list:
    zeros = plant_zeros(plant)
    out = []
    for fz, fp in pairs:
        zz = _mode_damping(plant, fz)
        zp = _zero_damping(zeros, fp)
        out.append(
            _pair(
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
        return Cascade((_lead_lag(5.0), *_notches(pv, (4449, 6412, 7141, 8600), u)))
    if method == "inverse":
        pairs = ((4449, 4775), (6412, 5691), (7141, 6973), (8599, 7515))
        return Cascade((_lead_lag(3.3302), *_pairs(pv, pairs, u)))
    notches = _notches(pv, (3800, 4449), u)
    if baseline:
        return Cascade((_lead_lag(4.9175), *notches))
    return Cascade(
        (
            _lead_lag(u.kcv_phase),
            *notches,
            _addon(4449, 0.015, 0.1778, 2.5414),
            RationalTF(*complex_lag_coefficients(6900, 0.1, 1.1519)),
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
        return Cascade((_lag(0.18), *_notches(pm, (2484, 5461, 6074, 9103, 12000), u)))
    if method == "inverse":
        pairs = ((2484, 2751), (5461, 5686), (6074, 6646), (9103, 9549), (12000, 11672))
        return Cascade((_lag(0.2473), *_pairs(pm, pairs, u)))
    first = _pairs(pm, ((2484, 2751),), u)
    if baseline:
        return Cascade((_lag(0.1737), *first))
    lead = _pair(4600, 8000, 0.03, 0.7)
    first_order_lag = _lag(6074 / 15000, zero_hz=15000, pole_hz=6074)  # unit DC gain
    return Cascade(
        (
            _lag(u.kcm_phase),
            *first,
            _addon(2484, 0.02, 0.1585, 4.2603),
            lead,
            *_pairs(pm, ((6074, 6646),), u),
            first_order_lag,
            *_notches(pm, (9103, 13120), u),
        )
    )
