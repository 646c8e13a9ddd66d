"""Galvano scanner I and II (book §2.5 and §2.6): FSC vs FFSC, voltage-constrained FFSC.

The registered case ``galvano`` (:func:`run`): FSC and FFSC inputs and the outputs of the
primary-mode variants of Galvano I (Figs. 2.25, 2.26, 2.28), the voltage-constrained FFSC
designs of Galvano II and their amplifier loss (Figs. 2.36, 2.39), with an illustrative
model.  The book's numbers for this case are experimental, so no row of the comparison
table is claimed; the qualitative findings of §2.6.3 are reported in ``extra``.

This module holds the case entry point and its findings.  The illustrative model values
(what the book omits and what servokit assumes), the plant helpers and the designs are in
:mod:`servokit.cases.galvano_designs` (re-exported here), the figures in
:mod:`servokit.cases._galvano_figures`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit.cases import galvano_designs, register
from servokit.cases._galvano_figures import _limit_label, _plot_galvano_i, _plot_galvano_ii
from servokit.cases.galvano_designs import (  # the names marked F401 are re-exported only
    _J,
    _KT,
    _LIMITS,
    _N_GALVANO_I,
    _STEPS,
    _V_MAX,
    GALVANO_GAIN,
    GALVANO_II_TS,
    GALVANO_LENS,
    GALVANO_MOTOR,
    GALVANO_TS,
    ConstrainedDesign,
    GalvanoIResult,  # noqa: F401
    ffsc_bands,  # noqa: F401
    galvano_i,
    galvano_ii,
    normalised_plant,  # noqa: F401
    primary_mode_variants,  # noqa: F401
)
from servokit.report import CaseResult

__all__ = [*galvano_designs.__all__, "run"]


def _at_velocity_limit(d: ConstrainedDesign) -> float:
    """Time [s] the design spends within 1 % of the velocity limit (coasting)."""
    return float(np.count_nonzero(np.abs(d.velocity) >= 0.99 * _V_MAX) * d.ff.dt)


def _findings(designs: list[ConstrainedDesign]) -> dict[str, object]:
    """The qualitative statements of §2.6.3 / Fig. 2.39, evaluated on ``designs``."""
    pamp = {(d.target, d.voltage_limit): d.pamp for d in designs}
    targets = [t for t, _ in _STEPS]
    lowest = {
        _limit_label(lim): min(targets, key=lambda t, lim=lim: pamp[(t, lim)]) * 1e3
        for lim in _LIMITS
    }
    return {
        "pamp_decreases_with_voltage_limit": {
            f"{t * 1e3:g} mm": bool(pamp[(t, None)] > pamp[(t, 72.0)] > pamp[(t, 36.0)])
            for t in targets
        },
        "lowest_pamp_step_mm": lowest,
        "voltage_limit_binds": {
            f"{d.target * 1e3:g} mm, {d.voltage_limit:g} V": bool(
                np.max(np.abs(d.voltage)) >= d.voltage_limit * (1 - 1e-6)
            )
            for d in designs
            if d.voltage_limit is not None
        },
    }


@register("galvano", order=10)
def run(outdir: Path) -> CaseResult:
    """Galvano scanner I and II (§2.5, §2.6) with the illustrative model; figures in ``outdir``.

    Parameters
    ----------
    outdir : pathlib.Path
        Directory for the figures (created if missing).

    Returns
    -------
    CaseResult
        No comparison rows (the book's numbers are experimental); Figs. 2.25-2.26, 2.28,
        2.36 and 2.39; extras ``assumptions`` and ``illustrative`` (the model values),
        ``galvano_I`` (settling times and residuals of :func:`galvano_i`, with the book's
        experimental settling times for reference), ``galvano_II`` (one row per design
        of :func:`galvano_ii`: N used, peaks, coasting time, supply, Pamp) and
        ``galvano_II_findings`` (the qualitative statements of §2.6.3 checked).
    """
    outdir.mkdir(parents=True, exist_ok=True)
    g1 = galvano_i()
    g2 = galvano_ii()
    figures = _plot_galvano_i(g1, outdir) + _plot_galvano_ii(g2, outdir)
    nominal = int(np.flatnonzero(g1.percents == 0)[0])
    extra = {
        # shown as a note in report.html: what the figures rest on
        "assumptions": (
            f"the book omits the galvano data: illustrative model (R = "
            f"{GALVANO_MOTOR.resistance:g} ohm, L = {GALVANO_MOTOR.inductance * 1e3:g} mH, "
            f"Kt = {_KT:g} N m/A, J = {_J:g} kg m^2, lens {GALVANO_LENS:g} m/rad, Ts = "
            f"{GALVANO_TS * 1e6:g} us / {GALVANO_II_TS * 1e6:g} us); the figures show the "
            "book's qualitative results, no printed number is compared"
        ),
        "illustrative": {
            "sampling_period_galvano_I_s": GALVANO_TS,
            "sampling_period_galvano_II_s": GALVANO_II_TS,
            "lens_m_per_rad": GALVANO_LENS,
            "gain_m_per_s2_per_A": GALVANO_GAIN,
            "motor": {
                "R_ohm": GALVANO_MOTOR.resistance,
                "L_H": GALVANO_MOTOR.inductance,
                "Ke_V_s_per_m": GALVANO_MOTOR.back_emf,
                "Kt_N_m_per_A": GALVANO_MOTOR.torque_constant,
                "J_kg_m2": GALVANO_MOTOR.inertia,
            },
            "ffsc_weights": "q per SI second (as Table 2.4)",
        },
        "galvano_I": {
            "N": _N_GALVANO_I,
            "percents": g1.percents,
            "settling_fsc_s_per_unit": g1.settle_fsc,
            "settling_ffsc_s_per_unit": g1.settle_ffsc,
            "nominal_settling_fsc": float(g1.settle_fsc[nominal]),
            "nominal_settling_ffsc": float(g1.settle_ffsc[nominal]),
            "worst_residual_fsc": float(g1.residual_fsc.max()),
            "worst_residual_ffsc": float(g1.residual_ffsc.max()),
            "peak_input_fsc": float(np.abs(g1.fsc.u).max()),
            "peak_input_ffsc": float(np.abs(g1.ffsc.u).max()),
            "book_experiment_s_per_unit": {
                "FSC nominal": 1.33,
                "FFSC nominal": 1.39,
                "FSC +6%": 1.94,
                "FFSC +6%": 1.44,
            },
            "note": "open-loop simulation of the illustrative model; book values are "
            "experiments with feedback (MMTDOF), not comparable one to one",
        },
        "galvano_II": [
            {
                "step_mm": d.target * 1e3,
                "book_N": d.book_N,
                "N": d.N,
                "infeasible_at_book_N": list(d.infeasible),
                "book_N_unconstrained_peak_V": d.book_N_free_peak,
                "book_N_unconstrained_pamp_W": d.book_N_free_pamp,
                "voltage_limit_V": d.voltage_limit,
                "peak_voltage_V": float(np.max(np.abs(d.voltage))),
                "peak_current_A": float(np.max(np.abs(d.current))),
                "peak_velocity_m_per_s": float(np.max(np.abs(d.velocity))),
                "constant_velocity_ms": _at_velocity_limit(d) * 1e3,
                "supply_V": d.supply,
                "pamp_W": d.pamp,
            }
            for d in g2
        ],
        "galvano_II_findings": _findings(g2),
    }
    return CaseResult(
        name="galvano",
        title="Galvano scanner I/II: FSC vs FFSC, voltage-constrained FFSC (§2.5-§2.6)",
        comparisons=[],
        figures=figures,
        extra=extra,
        chapter=2,
    )
