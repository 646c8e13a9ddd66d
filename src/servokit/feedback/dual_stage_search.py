"""Joint searches of the §5.5.2 unknowns against Table 5.4 (gain and inverse columns).

The book prints the notch frequencies but not the notch pole damping ζD, the notch
pole/zero frequency ratio fD/fR, the notch numerator ("depth") damping, the damping of
the inverse-compensation pair poles, or the two actuator input delays.  It does state a
range for one of them: (5.14) is "usually chosen" with √2/2 < ζD <= 1, and fD >= fR for
the high-pass notch.  The delays are searched around the values the inverse column
implies (VCM about 20 us, PZT about 9 us).

:func:`joint_table_search` fits the six unknowns to the gain-stabilisation and the
inverse-compensation columns together (the delays are the plant's, shared by both);
:func:`max_gain_margin` searches the largest gain margin the gain column can have;
:func:`pzt_phase_span` sweeps the PZT peak-filter phase ``arg T(j w1) - 90 deg`` of the
phase method over its unknowns.  The searches take minutes: their optima are stored in
:mod:`servokit.feedback.dual_stage_fitted` and re-run by a slow test.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from servokit.errors import ServokitValueError
from servokit.feedback.dual_stage_design import (
    BOOK_TABLE_5_4,
    ROW_TOLERANCES,
    SEARCH_GRID_HZ,
    DesignRow,
    Unknowns,
    evaluate_design,
    peak_filter_phases,
    table_cost,
)

__all__ = [
    "JOINT_NAMES",
    "BOOK_RANGES",
    "WIDE_RANGES",
    "JointFit",
    "joint_table_search",
    "max_gain_margin",
    "pzt_phase_span",
    "rows_within",
]

#: the unknowns of the joint search, in this order
JOINT_NAMES: tuple[str, ...] = (
    "notch_damping",
    "notch_freq_ratio",
    "notch_depth_damping",
    "pair_pole_damping",
    "delay_vcm_s",
    "delay_pzt_s",
)

#: the book's ranges: √2/2 < ζD <= 1 and fD >= fR (§5.3.1, (5.14)); VCM delay 15-25 us,
#: PZT delay 5-13 us around the inverse column's values; the book states nothing for the
#: depth and pair-pole dampings (searched over their physical ranges)
BOOK_RANGES: dict[str, tuple[float, float]] = {
    "notch_damping": (0.7072, 1.0),
    "notch_freq_ratio": (1.0, 1.5),
    "notch_depth_damping": (0.0, 0.5),
    "pair_pole_damping": (0.01, 1.0),
    "delay_vcm_s": (15e-6, 25e-6),
    "delay_pzt_s": (5e-6, 13e-6),
}

#: wide ranges: any damping 0.1-1.5, delays 0-100 us
WIDE_RANGES: dict[str, tuple[float, float]] = {
    **BOOK_RANGES,
    "notch_damping": (0.1, 1.5),
    "delay_vcm_s": (0.0, 1e-4),
    "delay_pzt_s": (0.0, 1e-4),
}


@dataclass(frozen=True)
class JointFit:
    """Optimum of :func:`joint_table_search`: unknowns, cost and rows within tolerance."""

    values: dict[str, float]
    cost: float
    within: int
    judged: int


def _unknowns(values: dict[str, float]) -> Unknowns:
    return replace(Unknowns(), **values)


def rows_within(row: DesignRow) -> tuple[int, int]:
    """Table 5.4 rows of ``row``'s column within the issue's tolerance, and rows judged.

    Parameters
    ----------
    row : DesignRow
        A column computed by :func:`evaluate_design`.

    Returns
    -------
    tuple of int
        (rows within 5 % / 1 dB / 5 deg, rows the book prints among ROW_TOLERANCES).
    """
    book, hit, n = BOOK_TABLE_5_4[row.method], 0, 0
    for key, tol in ROW_TOLERANCES.items():
        if key not in book:
            continue
        b, v = float(book[key]), float(getattr(row, key))
        n += 1
        hit += bool(abs(v - b) <= (tol * abs(b) if key.endswith("_hz") else tol))
    return hit, n


def _joint_cost(values: dict[str, float], freq_hz: np.ndarray, skip: tuple[str, ...] = ()) -> float:
    u = _unknowns(values)
    try:
        rows = [evaluate_design(m, u, freq_hz) for m in ("gain", "inverse")]
    except ServokitValueError:  # no crossover on the grid: an unusable design
        return 1e3
    # a skipped row of the gain column (the unreachable gain margin) is left out of the cost
    cost = sum(table_cost(r) for r in rows)
    for key in skip:
        b, v = float(BOOK_TABLE_5_4["gain"][key]), float(getattr(rows[0], key))
        err = (
            (v - b) / (b * ROW_TOLERANCES[key])
            if key.endswith("_hz")
            else (v - b) / ROW_TOLERANCES[key]
        )
        cost -= min(err * err, 100.0) if np.isfinite(err) else 100.0
    return cost


def joint_table_search(
    bounds: dict[str, tuple[float, float]],
    *,
    maxiter: int = 25,
    popsize: int = 8,
    seed: int = 1,
    freq_hz: np.ndarray = SEARCH_GRID_HZ,
    skip: tuple[str, ...] = (),
) -> JointFit:
    """Fit :data:`JOINT_NAMES` to the gain and inverse columns of Table 5.4 together.

    Differential evolution on the sum of :func:`table_cost` of both columns (each row's
    miss in units of its tolerance, squared); the optimum is judged on the fine grid.

    Parameters
    ----------
    bounds : dict
        Range per name of :data:`JOINT_NAMES` (:data:`BOOK_RANGES` or :data:`WIDE_RANGES`).
    maxiter, popsize, seed : int
        Differential-evolution settings.
    freq_hz : ndarray
        Search grid [Hz].
    skip : tuple of str
        Rows of the gain column left out of the cost (e.g. ``("gain_margin_db",)``, which
        no search reaches: :func:`max_gain_margin`).

    Returns
    -------
    JointFit
        The unknowns (rounded to 4 significant digits), the cost and the rows of both
        columns within tolerance on the default grid.
    """
    from scipy.optimize import differential_evolution

    def cost(x: np.ndarray) -> float:
        return _joint_cost(dict(zip(JOINT_NAMES, map(float, x), strict=True)), freq_hz, skip)

    res = differential_evolution(
        cost, [bounds[n] for n in JOINT_NAMES], maxiter=maxiter, popsize=popsize, seed=seed,
        tol=1e-6, polish=False,
    )  # fmt: skip
    values = {n: float(f"{v:.4g}") for n, v in zip(JOINT_NAMES, res.x, strict=True)}
    counts = [rows_within(evaluate_design(m, _unknowns(values))) for m in ("gain", "inverse")]
    return JointFit(
        values,
        round(_joint_cost(values, freq_hz, skip), 3),
        sum(c[0] for c in counts),
        sum(c[1] for c in counts),
    )


def max_gain_margin(
    bounds: dict[str, tuple[float, float]], *, maxiter: int = 15, popsize: int = 8, seed: int = 1
) -> float:
    """Largest gain margin [dB] of the gain-stabilisation column over ``bounds``.

    Parameters
    ----------
    bounds : dict
        Ranges of the gain column's unknowns (the names of :data:`JOINT_NAMES` except
        ``pair_pole_damping``, which the column does not use).
    maxiter, popsize, seed : int
        Differential-evolution settings.

    Returns
    -------
    float
        The best gain margin found on :data:`SEARCH_GRID_HZ` [dB, 0.01 dB].
    """
    from scipy.optimize import differential_evolution

    names = tuple(n for n in JOINT_NAMES if n != "pair_pole_damping")

    def neg_gm(x: np.ndarray) -> float:
        u = _unknowns(dict(zip(names, map(float, x), strict=True)))
        try:
            return -float(evaluate_design("gain", u, SEARCH_GRID_HZ).gain_margin_db)
        except ServokitValueError:
            return 1e3

    res = differential_evolution(
        neg_gm, [bounds[n] for n in names], maxiter=maxiter, popsize=popsize, seed=seed,
        polish=False,
    )  # fmt: skip
    return round(-float(res.fun), 2)


def pzt_phase_span(delays_s: np.ndarray, pair_damping: np.ndarray) -> dict[str, float]:
    """PZT peak-filter phases ``arg T(j w1) - 90 deg`` over a grid of their unknowns.

    The phase method's baseline PZT loop (KCM = 0.1737 and the (2484, 2751) Hz pair, both
    printed) leaves two unknowns: the PZT input delay and the pair's pole damping (used
    where the plant does not fix it).

    Parameters
    ----------
    delays_s : ndarray
        PZT input delays [s].
    pair_damping : ndarray
        Pair-pole dampings ``pair_pole_damping``.

    Returns
    -------
    dict
        ``min_deg``, ``max_deg`` (phases in [0, 360)) and ``n`` (grid points).
    """
    phis = [
        peak_filter_phases(replace(Unknowns(), delay_pzt_s=float(d), pair_pole_damping=float(z)))[
            "phi_pzt_deg"
        ]
        for d in delays_s
        for z in pair_damping
    ]
    return {"min_deg": float(np.min(phis)), "max_deg": float(np.max(phis)), "n": len(phis)}
