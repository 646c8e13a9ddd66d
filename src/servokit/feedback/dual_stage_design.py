"""The §5.5.2 dual-stage design example evaluated: Table 5.4 and the search of the unknowns.

The controllers of the three methods (gain, inverse, phase stabilisation), every
parameter the book prints and what it leaves unstated (:class:`Unknowns`) are in
:mod:`servokit.feedback.dual_stage_controllers` (re-exported here).  This module holds
the book's Table 5.4 (:data:`BOOK_TABLE_5_4`), the frequency grids, the responses of a
design for the figures (:func:`design_responses`), the Table 5.4 quantities servokit
computes (:func:`evaluate_design`, :class:`DesignRow`), the peak-filter phases of the
phase method (:func:`peak_filter_phases`) and the differential-evolution search of the
unknowns against the table (:func:`fit_unknowns`, :func:`table_cost`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedback import dual_stage_controllers
from servokit.feedback.dual_stage import (
    dual_stage_open_loop,
    handoff,
    loop_margins,
)
from servokit.feedback.dual_stage_controllers import (  # the names marked F401 are re-exported only
    METHODS,  # noqa: F401
    TWO_PI,  # noqa: F401
    Cascade,
    Method,  # noqa: F401
    Unknowns,
    _check_method,
    peak_filter_addon,  # noqa: F401
    plant_zeros,  # noqa: F401
    pzt_controller,
    vcm_controller,
    zero_pole_pair,  # noqa: F401
)
from servokit.feedback.margins import stability_margins
from servokit.models import pzt_active_suspension, vcm_dual_stage

__all__ = [
    *dual_stage_controllers.__all__,  # re-exported
    "DesignRow",
    "evaluate_design",
    "BOOK_TABLE_5_4",
    "DEFAULT_GRID_HZ",
]

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


#: the plant responses of recent (delays, grid) pairs: the designs of the three methods
#: and their root-refined margins share them (116 of the 330 plant evaluations of the
#: dual-stage case were repeats); read-only arrays, oldest entry dropped first
_PLANTS: dict[tuple[bytes, bytes, tuple[int, ...], bytes], tuple[np.ndarray, np.ndarray]] = {}
_PLANTS_MAX = 16


def _plant_responses(u: Unknowns, freq_hz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``PV`` and ``PM`` (delays exact) on ``freq_hz``, computed once per (delays, grid).

    The key holds the delays' and the grid's bytes, so a hit is the same computation.
    """
    f = np.ascontiguousarray(freq_hz, dtype=float)
    delays = (np.float64(u.delay_vcm_s).tobytes(), np.float64(u.delay_pzt_s).tobytes())
    key = (*delays, f.shape, f.tobytes())
    if key not in _PLANTS:
        pv = vcm_dual_stage().replace(delay=u.delay_vcm_s).freqresp(f)
        pm = pzt_active_suspension().replace(delay=u.delay_pzt_s).freqresp(f)
        pv.flags.writeable = pm.flags.writeable = False
        if len(_PLANTS) >= _PLANTS_MAX:
            del _PLANTS[next(iter(_PLANTS))]
        _PLANTS[key] = (pv, pm)
    return _PLANTS[key]


def _responses(
    cv_: Cascade, cm_: Cascade, u: Unknowns, freq_hz: np.ndarray, structure: str
) -> DesignResponses:
    pv, pm = _plant_responses(u, freq_hz)
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
