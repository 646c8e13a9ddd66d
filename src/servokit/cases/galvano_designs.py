"""Designs of the galvano scanner case (book §2.5 and §2.6): FSC vs FFSC, constrained FFSC.

Galvano I (§2.5, Figs. 2.25, 2.26, 2.28): FSC and FFSC inputs (N = 79) for the rigid body
plus two vibration modes (2.76)-(2.82), FFSC weights of §2.5.2 in the cost (2.44)
(bands +-6 % around both modes, 50 points each, q = 1e9 and 5e7), outputs of plants whose
primary mode moves from -6 % to +6 % in 1 % steps.  As in the book's figures, time is
normalised so that the final time ``N tau`` is one unit and the target is 1.

Galvano II (§2.6, Figs. 2.36, 2.39): FFSC inputs with the current (12 A), velocity
(5 m/s) and motor-voltage constraints (2.84)-(2.88) (none / 72 V / 36 V), for 0.1 mm,
1 mm and 10 mm steps (N = 37, 73, 351), and the amplifier loss Pamp (2.89) with the
supply ``Vp = limit + 16 V`` (internal drop of §2.6.3); without a voltage limit the
supply is the 1 mm design's peak voltage + 16 V, as in the book.

Illustrative values (the book gives neither the scanner's gain, residues and damping nor
the motor's R, L, Ke, Kt, J, nor the sampling period of §2.5-§2.6):

* the weights q are taken per SI second, as the HDD weights of Table 2.4 (frequencies in
  Hz); a design in a time unit of ``T`` seconds uses ``q T**2``
  (``|Uc|^2`` carries time squared);
* Galvano I uses 20 us, the galvano sampling period of §3.5.1;
* Galvano II uses 8 us: with N = 351 a 10 mm move only reaches the 5 m/s velocity limit
  (and so shows the zero-current, constant-velocity interval of §2.6.3) if
  ``N tau < 1.875 * 10 mm / 5 m/s`` (minimum-jerk peak velocity), i.e. tau < 10.7 us;
  at 10 us the 1 mm design cannot meet 36 V once its unconstrained peak is ~146 V;
* motor: rotary Kt = 0.15 N m/A, J = 1e-5 kg m^2 (rotor and a large drilling mirror),
  R = 1 ohm, L = 0.25 mH, mirror-to-work-surface factor 0.2 m/rad (f = 100 mm lens,
  optical doubling); hence the gain ``0.2 Kt / J = 3000 m/s^2/A`` and the work-surface
  back-EMF ``Kt / 0.2 = 0.75 V s/m``.  L sets the 1 mm unconstrained peak near the
  book's 146 V.

With these values the 0.1 mm step at N = 37 (0.9 period of the 3020 Hz mode) cannot meet
72 V or 36 V at all (:class:`InfeasibleConstraintsError`, binding: the voltage limit); the
0.1 mm designs are then made at the smallest N at which every limit is feasible.  The
book's numbers for this case are experimental, so no row of the comparison table is
claimed; the qualitative findings are reported in ``extra``.

This module holds the illustrative model values, the plant helpers and the designs
(:func:`galvano_i`, :func:`galvano_ii`); the case entry point and its findings are in
:mod:`servokit.cases.galvano` (which re-exports these names), the figures in
:mod:`servokit.cases._galvano_figures`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit.feedforward.constraints import (
    CurrentLimit,
    InfeasibleConstraintsError,
    MotorModel,
    VelocityLimit,
    VoltageLimit,
)
from servokit.feedforward.energy import amplifier_power, supply_voltage
from servokit.feedforward.ffsc import FeedforwardInput, augmented_design_model, fsc_input
from servokit.feedforward.fsc import lifted_model
from servokit.models import ModalPlant, Mode, galvano_scanner
from servokit.simulate import seek_response, settling_time

__all__ = [
    "GALVANO_TS",
    "GALVANO_II_TS",
    "GALVANO_MOTOR",
    "GALVANO_GAIN",
    "GALVANO_LENS",
    "normalised_plant",
    "primary_mode_variants",
    "ffsc_bands",
    "galvano_i",
    "galvano_ii",
]

#: Sampling period of Galvano I [s] (the galvano servo of §3.5.1).
GALVANO_TS = 20e-6
#: Illustrative sampling period of Galvano II [s] (see the module docstring).
GALVANO_II_TS = 8e-6
#: Illustrative mirror-angle to work-surface factor [m/rad] (f = 100 mm, optical doubling).
GALVANO_LENS = 0.2
_KT, _J = 0.15, 1e-5  # illustrative torque constant [N m/A] and inertia [kg m^2]
#: Plant gain ``lens Kt / J`` [m/s^2/A] for positions at the work surface.
GALVANO_GAIN = GALVANO_LENS * _KT / _J
#: Illustrative motor: R [ohm], L [H], work-surface back-EMF ``Kt / lens`` [V s/m].
GALVANO_MOTOR = MotorModel(
    resistance=1.0,
    inductance=0.25e-3,
    back_emf=_KT / GALVANO_LENS,
    torque_constant=_KT,
    inertia=_J,
)
#: FFSC weights of §2.5.2 per SI second: primary, secondary band.
_Q_PRIMARY, _Q_SECONDARY = 1e9, 5e7
_N_GALVANO_I = 79
_BAND = 0.0008  # +-0.08 % of the target: the galvano's allowable error (§2.5.4)
_AMP_DROP = 16.0  # internal voltage drop of the current amplifier [V] (§2.6.3)
_STEPS = ((1e-4, 37), (1e-3, 73), (1e-2, 351))  # target [m], N (§2.6.3)
_LIMITS = (None, 72.0, 36.0)  # motor-voltage constraint [V]
_I_MAX, _V_MAX = 12.0, 5.0  # current [A] and velocity [m/s] limits (§2.6.3)
_REFERENCE_STEP = 1e-3  # the step whose unconstrained peak sets the supply (§2.6.3)
_N_SEARCH = 60  # extra steps tried when a book N is infeasible


def normalised_plant(plant: ModalPlant, time_unit: float) -> ModalPlant:
    """``plant`` with time measured in units of ``time_unit`` seconds and gain 1.

    Frequencies become Hz/unit (``f * time_unit``) and the delay ``delay / time_unit``.
    The gain is set to 1 (the book's [A/unit] when the target is 1).

    Parameters
    ----------
    plant : ModalPlant
        Plant in SI time (frequencies [Hz], delay [s]).
    time_unit : float
        Length of the new time unit [s]; Galvano I uses the final time ``N dt``.

    Returns
    -------
    ModalPlant
        Same dampings and residues, gain 1, frequencies [Hz/unit] and delay [unit];
        named ``"<name> (normalised)"``.
    """
    modes = tuple(Mode(m.freq_hz * time_unit, m.damping, m.residue) for m in plant.modes)
    return plant.replace(
        gain=1.0, modes=modes, delay=plant.delay / time_unit, name=f"{plant.name} (normalised)"
    )


def primary_mode_variants(plant: ModalPlant, percents: np.ndarray) -> list[ModalPlant]:
    """Copies of ``plant`` with the first vibration mode's frequency moved by ``percents``.

    Parameters
    ----------
    plant : ModalPlant
        Plant with at least one vibration mode (``freq_hz > 0``).
    percents : ndarray
        Frequency changes [%] of the first vibration mode (-6 .. +6 in Galvano I).

    Returns
    -------
    list of ModalPlant
        One plant per entry of ``percents``, in order, with that mode's frequency
        ``f1 (1 + p / 100)`` and everything else unchanged; named ``"<name> f1 +p%"``.
    """
    idx = next(i for i, m in enumerate(plant.modes) if m.freq_hz > 0)
    out = []
    for p in percents:
        modes = list(plant.modes)
        m = modes[idx]
        modes[idx] = Mode(m.freq_hz * (1 + p / 100.0), m.damping, m.residue)
        out.append(plant.replace(modes=tuple(modes), name=f"{plant.name} f1 {p:+.0f}%"))
    return out


def ffsc_bands(plant: ModalPlant, time_unit: float = 1.0) -> list[tuple[float, float, float, int]]:
    """Band weights of §2.5.2 (+-6 % around both modes, 50 points) for ``fsc_input``.

    The weights 1e9 and 5e7 are taken per SI second (as the HDD weights of Table 2.4).
    For a ``plant`` whose time unit is ``time_unit`` seconds (see :func:`normalised_plant`)
    they become ``q * time_unit**2``: ``|Uc|^2`` of (2.43) carries time squared, while
    the jerk term of (2.44) does not, so the designed input is the same.

    Parameters
    ----------
    plant : ModalPlant
        Plant with exactly two vibration modes (``freq_hz > 0``), as the galvano model;
        its frequencies may be in Hz or Hz/unit.
    time_unit : float
        Time unit of ``plant`` [s] (1 for SI time).

    Returns
    -------
    list of (float, float, float, int)
        ``(f_low, f_high, weight, n_points)`` for the first and the second mode:
        ``0.94 f`` to ``1.06 f`` (in ``plant``'s frequency unit), weight
        ``1e9 time_unit**2`` resp. ``5e7 time_unit**2``, 50 points; the
        ``band_weights`` of :func:`~servokit.feedforward.ffsc.fsc_input`.
    """
    f1, f2 = (m.freq_hz for m in plant.modes if m.freq_hz > 0)
    s = time_unit**2
    return [
        (0.94 * f1, 1.06 * f1, _Q_PRIMARY * s, 50),
        (0.94 * f2, 1.06 * f2, _Q_SECONDARY * s, 50),
    ]


@dataclass(frozen=True)
class GalvanoIResult:
    """FSC and FFSC designs and the outputs of the primary-mode variants (normalised)."""

    fsc: FeedforwardInput
    ffsc: FeedforwardInput
    percents: np.ndarray
    t: np.ndarray
    y_fsc: np.ndarray
    y_ffsc: np.ndarray
    settle_fsc: np.ndarray
    settle_ffsc: np.ndarray
    residual_fsc: np.ndarray
    residual_ffsc: np.ndarray


def galvano_i(dt: float = GALVANO_TS, N: int = _N_GALVANO_I) -> GalvanoIResult:
    """§2.5: FSC vs FFSC on the normalised galvano model, primary mode -6 % .. +6 %.

    Both inputs minimise (2.44) with jerk weight 1 (the FSC one without band terms) on
    the galvano model normalised to the time unit ``N dt`` (final time 1, target 1).

    Parameters
    ----------
    dt : float
        Sampling period [s] (20 us, the galvano servo of §3.5.1).
    N : int
        Number of steps (79 in §2.5).

    Returns
    -------
    GalvanoIResult
        The FSC and FFSC (:func:`ffsc_bands`) inputs; the open-loop outputs of the 13
        plants with the primary mode moved by -6 .. +6 % in 1 % steps over 3 time units;
        per plant the settling time into the +-0.08 % band [time units] and the largest
        ``|y - 1|`` after the final time plus the delay.
    """
    plant = normalised_plant(galvano_scanner(), N * dt)
    dtn = 1.0 / N
    fsc = fsc_input(plant, dtn, N, 1.0, input_weight=1.0)
    bands = ffsc_bands(plant, N * dt)
    ffsc = fsc_input(plant, dtn, N, 1.0, input_weight=1.0, band_weights=bands)
    percents = np.arange(-6, 7, dtype=float)
    variants = primary_mode_variants(plant, percents)
    res_fsc = seek_response(variants, fsc, horizon=3.0)
    res_ffsc = seek_response(variants, ffsc, horizon=3.0)
    after = res_fsc.t >= 1.0 + plant.delay
    return GalvanoIResult(
        fsc=fsc,
        ffsc=ffsc,
        percents=percents,
        t=res_fsc.t,
        y_fsc=res_fsc.yc,
        y_ffsc=res_ffsc.yc,
        settle_fsc=settling_time(res_fsc.t, res_fsc.yc, 1.0, _BAND),
        settle_ffsc=settling_time(res_ffsc.t, res_ffsc.yc, 1.0, _BAND),
        residual_fsc=np.abs(res_fsc.yc[:, after] - 1.0).max(axis=1),
        residual_ffsc=np.abs(res_ffsc.yc[:, after] - 1.0).max(axis=1),
    )


@dataclass(frozen=True)
class ConstrainedDesign:
    """One voltage-constrained FFSC design of §2.6.3 and its electrical waveforms.

    ``book_N`` is the book's step number; when a limit of this step is infeasible there
    (``infeasible`` lists the binding constraint), ``N`` is the smallest larger step
    number at which all limits of the step are feasible.
    """

    target: float
    N: int
    book_N: int
    voltage_limit: float | None
    ff: FeedforwardInput
    current: np.ndarray
    velocity: np.ndarray
    voltage: np.ndarray
    supply: float
    pamp: float
    infeasible: tuple[str, ...] = ()
    book_N_free_peak: float = float("nan")
    book_N_free_pamp: float = float("nan")


def _waveforms(plant: ModalPlant, ff: FeedforwardInput) -> tuple[np.ndarray, np.ndarray]:
    """Held current and the output velocity at the samples, from the design model."""
    A, B, n = augmented_design_model(plant, ff.dt)
    vel_row = np.zeros(n + 1)
    vel_row[1:n:2] = 1.0
    pos_row = np.zeros(n + 1)
    pos_row[0:n:2] = 1.0
    lm = lifted_model(A, B, ff.N, np.zeros(n + 1), dt=ff.dt, position=pos_row, velocity=vel_row)
    return ff.u, lm.states(ff.jerk)[: ff.N] @ vel_row


def _design_step(
    plant: ModalPlant, dt: float, target: float, N: int, motor: MotorModel
) -> tuple[int, dict[float | None, FeedforwardInput], tuple[str, ...], FeedforwardInput | None]:
    """FFSC designs of one step for every limit, at ``N`` or the first feasible N above.

    Returns ``(N_used, designs by limit, binding constraints of the limits infeasible at
    the book's N, unconstrained design at the book's N)``.
    """
    bands = ffsc_bands(plant)

    def design(n: int, limit: float | None) -> FeedforwardInput:
        cons: list[object] = [CurrentLimit(_I_MAX), VelocityLimit(_V_MAX)]
        if limit is not None:
            cons.append(VoltageLimit(limit, motor=motor))
        # the default QP path: the scaled banded QP now solves these designs (issue 24),
        # but with 200 band rows the dense QP is the faster one and is chosen
        return fsc_input(
            plant, dt, n, target, input_weight=1.0, band_weights=bands, constraints=cons
        )

    binding: list[str] = []
    for n in range(N, N + _N_SEARCH + 1):
        designs: dict[float | None, FeedforwardInput] = {}
        for limit in _LIMITS:
            try:
                designs[limit] = design(n, limit)
            except InfeasibleConstraintsError as err:
                if n > N:
                    break
                binding += [b for b in err.binding if b not in binding]
        if n == N:
            at_book_N = designs.get(None)
        if len(designs) == len(_LIMITS):
            return n, designs, tuple(binding), at_book_N
    raise InfeasibleConstraintsError(
        f"{target * 1e3:g} mm step: no N in {N}..{N + _N_SEARCH} meets every limit", binding
    )


def galvano_ii(
    dt: float = GALVANO_II_TS, motor: MotorModel = GALVANO_MOTOR, gain: float = GALVANO_GAIN
) -> list[ConstrainedDesign]:
    """§2.6.3: FFSC with current, velocity and voltage constraints for three step sizes.

    The supply of an unconstrained design is the reference (1 mm) step's unconstrained
    peak voltage plus the amplifier drop (the book's 162 V rule), raised to the design's
    own peak if that is higher (the amplifier would saturate otherwise).

    Parameters
    ----------
    dt : float
        Sampling period [s] (illustrative 8 us, see the module docstring).
    motor : MotorModel
        Motor of the voltage constraint (2.84) and of the voltage waveforms.
    gain : float
        Plant gain [m/s^2/A], replacing the catalogue's normalised gain, so that positions
        are at the work surface [m].

    Returns
    -------
    list of ConstrainedDesign
        Nine designs, for the 0.1 mm, 1 mm and 10 mm steps (book N = 37, 73, 351) in
        turn, each with no voltage limit, 72 V and 36 V; all FFSC (:func:`ffsc_bands`)
        with the 12 A current and 5 m/s velocity limits.  A step whose limits are not all
        feasible at the book's N is designed at the first feasible larger N (all three of
        its designs).  ``supply`` [V] and ``pamp`` (2.89) [W] as above.

    Raises
    ------
    InfeasibleConstraintsError
        If a step has no N up to 60 above the book's at which every limit is feasible.
    """
    plant = galvano_scanner().replace(gain=gain, name="galvano-scanner (illustrative)")
    steps = [(t, N, *_design_step(plant, dt, t, N, motor)) for t, N in _STEPS]
    waves = {
        (t, lim): (*(w := _waveforms(plant, ff)), motor.voltage(w[0], w[1], dt))
        for t, _, _, ffs, _, _ in steps
        for lim, ff in ffs.items()
    }
    v_ref = float(np.max(np.abs(waves[(_REFERENCE_STEP, None)][2])))
    designs = []
    for target, book_N, n, ffs, binding, free_book in steps:
        free_peak = free_pamp = float("nan")
        if free_book is not None:
            c, v = _waveforms(plant, free_book)
            vm = motor.voltage(c, v, dt)
            free_peak = float(np.max(np.abs(vm)))
            vp_book = supply_voltage(max(v_ref, free_peak), _AMP_DROP)
            free_pamp = amplifier_power(c, vm, vp_book, dt)
        for limit, ff in ffs.items():
            current, velocity, voltage = waves[(target, limit)]
            peak = float(np.max(np.abs(voltage)))
            vp = supply_voltage(max(v_ref, peak) if limit is None else limit, _AMP_DROP)
            designs.append(
                ConstrainedDesign(
                    target=target,
                    N=n,
                    book_N=book_N,
                    voltage_limit=limit,
                    ff=ff,
                    current=current,
                    velocity=velocity,
                    voltage=voltage,
                    supply=vp,
                    pamp=amplifier_power(current, voltage, vp, dt),
                    infeasible=binding,
                    book_N_free_peak=free_peak,
                    book_N_free_pamp=free_pamp,
                )
            )
    return designs
