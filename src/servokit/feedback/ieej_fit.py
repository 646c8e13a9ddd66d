"""The fit of issue 20's IEEJ benchmark loop: the filter data the benchmark does not publish.

Issue 20 quotes four numbers for its version of the IEEJ benchmark tracking loop
(:data:`IEEJ_ISSUE_20_NUMBERS`: PM 35.17°, GM 4.11 dB at 1626 Hz, delay margin 97.68 µs).
The benchmark's ``followdemo.m`` publishes the PID, its gain and the 1 kHz zero-cross
target, not the notch pole dampings nor the 8 kHz low-pass of the v2 loop
(:func:`~servokit.models.ieej_example_controller`). :func:`fit_ieej_loop` fits the
unknowns by least squares (scipy's ``least_squares``) on residuals scaled by the quoted
precision of each number (:data:`IEEJ_ISSUE_20_PRECISION`):

* by default the low-pass damping and the crossover, notch pole damping 0.5 (assumed),
  to the PM and the delay margin only, on :func:`~servokit.models.ieej_benchmark_plant`;
  the gain margin and the phase crossover are then predictions. This is where
  :data:`~servokit.models.benchmark_controller.IEEJ_FITTED_LOWPASS_DAMPING` and
  :data:`~servokit.models.benchmark_controller.IEEJ_FITTED_CROSSOVER_HZ` come from
  (``tests/test_margins_cases.py`` checks them against this function);
* with ``fit_notches=True`` also the notch pole dampings (4.1 kHz; 5 and 7 kHz shared),
  e.g. to all four numbers on the book's rigid-body plant, which no choice explains
  (``examples/ieej_benchmark_loop.py``).

It sits in :mod:`servokit.feedback` (not next to ``ieej_benchmark_loop`` in
:mod:`servokit.models`) because it needs the margins: models must not import feedback.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedback.margins import stability_margins
from servokit.models.benchmark_controller import ieej_example_controller
from servokit.models.catalogue import HDD_BENCHMARK_TS, ieej_benchmark_plant
from servokit.models.modal import ModalPlant

__all__ = [
    "IEEJ_ISSUE_20_NUMBERS",
    "IEEJ_ISSUE_20_PRECISION",
    "IeejLoopFit",
    "fit_ieej_loop",
    "ieej_loop_numbers",
]

#: Issue 20's numbers for its IEEJ loop, keyed like :class:`~servokit.feedback.Margins`.
IEEJ_ISSUE_20_NUMBERS: dict[str, float] = {
    "phase_margin_deg": 35.17,
    "gain_margin_db": 4.11,
    "gm_freq_hz": 1626.0,
    "delay_margin_s": 97.68e-6,
}
#: The precision each number is quoted to (one unit of its last digit).
IEEJ_ISSUE_20_PRECISION: dict[str, float] = {
    "phase_margin_deg": 0.01,
    "gain_margin_db": 0.01,
    "gm_freq_hz": 1.0,
    "delay_margin_s": 0.01e-6,
}


@dataclass(frozen=True)
class IeejLoopFit:
    """Fitted filter data of the IEEJ loop and what the fitted loop gives.

    Attributes
    ----------
    lowpass_damping, crossover_hz : float
        Fitted low-pass damping and crossover [Hz].
    notch_pole_damping : tuple of float
        Notch pole dampings (4.1, 5, 7 kHz): fitted with ``fit_notches``, else assumed.
    numbers : dict
        PM [deg], GM [dB], phase crossover [Hz] and delay margin [s] of the fitted loop.
    residuals : dict
        ``numbers - target`` for each of the four (fitted or predicted).
    fitted_to : tuple of str
        The numbers the fit used (the others are predictions).
    """

    lowpass_damping: float
    crossover_hz: float
    notch_pole_damping: tuple[float, float, float]
    numbers: dict[str, float]
    residuals: dict[str, float]
    fitted_to: tuple[str, ...]


def ieej_loop_numbers(
    lowpass_damping: float,
    crossover_hz: float,
    notch_pole_damping: float | tuple[float, float, float] = 0.5,
    *,
    plant: ModalPlant | None = None,
    method: str = "tustin",
    dt: float = HDD_BENCHMARK_TS,
) -> dict[str, float]:
    """PM, GM, phase crossover and delay margin of one candidate IEEJ loop.

    Parameters
    ----------
    lowpass_damping, crossover_hz : float
        Low-pass damping and crossover [Hz] (0 dB there on ``plant``).
    notch_pole_damping : float or tuple of 3 floats
        Notch pole dampings (4.1, 5, 7 kHz).
    plant : ModalPlant, optional
        Default :func:`~servokit.models.ieej_benchmark_plant`.
    method : {"tustin", "matched"}
        Discretisation of the filter sections.
    dt : float
        Sampling period [s].

    Returns
    -------
    dict
        Keys of :data:`IEEJ_ISSUE_20_NUMBERS`.
    """
    model = ieej_benchmark_plant() if plant is None else plant
    ctrl = ieej_example_controller(
        dt=dt,
        notch_pole_damping=notch_pole_damping,
        lowpass_damping=lowpass_damping,
        crossover_hz=crossover_hz,
        method=method,
        plant=model,
    )
    m = stability_margins([model.discretize(dt), *ctrl])
    return {key: float(getattr(m, key)) for key in IEEJ_ISSUE_20_NUMBERS}


def _unpack(p: np.ndarray, notches: tuple[float, float, float] | None) -> tuple:
    """(low-pass damping, crossover, notch dampings) from a parameter vector."""
    if notches is not None:
        return p[0], p[1], notches
    return p[2], p[3], (p[0], p[1], p[1])


def fit_ieej_loop(
    *,
    plant: ModalPlant | None = None,
    fit_to: Sequence[str] = ("phase_margin_deg", "delay_margin_s"),
    fit_notches: bool = False,
    notch_pole_damping: float = 0.5,
    method: str = "tustin",
    starts: Sequence[Sequence[float]] | None = None,
    max_nfev: int | None = None,
    diff_step: float = 1e-6,
) -> IeejLoopFit:
    """Fit the IEEJ loop's unpublished filter data to issue 20's numbers (least squares).

    Parameters
    ----------
    plant : ModalPlant, optional
        Default :func:`~servokit.models.ieej_benchmark_plant` (the benchmark file's plant).
    fit_to : sequence of str
        Keys of :data:`IEEJ_ISSUE_20_NUMBERS` to fit; residuals are scaled by
        :data:`IEEJ_ISSUE_20_PRECISION`.
    fit_notches : bool
        Also fit the notch pole dampings (4.1 kHz; 5 and 7 kHz shared); else they are
        ``notch_pole_damping`` (ASSUMED).
    notch_pole_damping : float
        Notch pole damping when not fitted.
    method : {"tustin", "matched"}
        Discretisation of the filter sections.
    starts : sequence of parameter vectors, optional
        Starting points, each ``(low-pass damping, crossover Hz)``, or with
        ``fit_notches`` ``(notch 4.1 kHz, notch 5/7 kHz, low-pass damping, crossover Hz)``;
        the best fit over all is returned. Default one start at dampings 0.5, 1000 Hz.
    max_nfev : int, optional
        Evaluation cap per start (scipy's default when None).
    diff_step : float
        Relative finite-difference step of the Jacobian.

    Returns
    -------
    IeejLoopFit
    """
    from scipy.optimize import least_squares

    keys = tuple(fit_to)
    if not keys or any(k not in IEEJ_ISSUE_20_NUMBERS for k in keys):
        raise ServokitValueError(f"fit_to must name some of {sorted(IEEJ_ISSUE_20_NUMBERS)}")
    fixed = None if fit_notches else (notch_pole_damping,) * 3
    target = np.array([IEEJ_ISSUE_20_NUMBERS[k] for k in keys])
    scale = np.array([IEEJ_ISSUE_20_PRECISION[k] for k in keys])
    n = 4 if fit_notches else 2
    x0s = [np.asarray(s, dtype=float) for s in starts] if starts else [np.r_[[0.5] * (n - 1), 1e3]]

    def numbers(p: np.ndarray) -> dict[str, float]:
        lp, fc, zn = _unpack(p, fixed)
        return ieej_loop_numbers(lp, fc, zn, plant=plant, method=method)

    def resid(p: np.ndarray) -> np.ndarray:
        got = numbers(p)
        return (np.array([got[k] for k in keys]) - target) / scale

    lo, hi = [0.02] * (n - 2) + [0.05, 800.0], [5.0] * (n - 2) + [3.0, 1200.0]
    best = None
    for x0 in x0s:
        if x0.size != n:
            raise ServokitValueError(f"each start needs {n} values (got {x0.size})")
        fit = least_squares(
            resid, x0, bounds=(lo, hi), diff_step=diff_step, xtol=1e-12, max_nfev=max_nfev
        )
        best = fit if best is None or fit.cost < best.cost else best
    lp, fc, zn = _unpack(best.x, fixed)
    got = numbers(best.x)
    return IeejLoopFit(
        lowpass_damping=float(lp),
        crossover_hz=float(fc),
        notch_pole_damping=tuple(float(z) for z in zn),  # type: ignore[arg-type]
        numbers=got,
        residuals={k: got[k] - IEEJ_ISSUE_20_NUMBERS[k] for k in IEEJ_ISSUE_20_NUMBERS},
        fitted_to=keys,
    )
