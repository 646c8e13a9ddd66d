"""Phase 4 (feedback): resonance-compensation filters and stability margins (book chapter 5).

* :mod:`~servokit.feedback.filters`: notch (5.14), inverse pairs, complex lag (5.92)-(5.94),
  lead-lag (5.91), lag (5.96), PI, peak filter (5.17), pseudo plant (5.16).
* :mod:`~servokit.feedback.dual_stage`: parallel / CMS / DMS dual-stage loops (5.79)-(5.89).
* :mod:`~servokit.feedback.margins`: every gain/phase/delay/modulus margin on the exact
  frequency response and a Nyquist stability verdict; :mod:`~servokit.feedback.margins_set`
  the worst case over a plant set; :mod:`~servokit.feedback.ieej_fit` the fit of issue
  20's IEEJ loop; :mod:`~servokit.models.frequency_grid` the
  pole-aware grid every Bode/sensitivity figure uses.
* :mod:`~servokit.feedback.loopshape_iterate`: fixed-structure controller design from the
  measured FRFs of a plant set (convex-concave iteration, stability certificate); set-up in
  ``loopshape_problem``/``loopshape_init``, cone program in ``loopshape_socp``, tables in
  ``loopshape_eval``, figures in ``loopshape_plots``.
"""

from servokit._lazy import lazy_exports

#: public name -> defining module, imported on first use (start-up, issue 23)
_EXPORTS = {
    "DualStageLoops": "servokit.feedback.dual_stage",
    "LoopRow": "servokit.feedback.loopshape_eval",
    "LoopTable": "servokit.feedback.loopshape_eval",
    "LoopshapeResult": "servokit.feedback.loopshape_iterate",
    "Structure": "servokit.feedback.loopshape_problem",
    "certify_models": "servokit.feedback.loopshape_iterate",
    "fixed_order_structure": "servokit.feedback.loopshape_problem",
    "loopshape": "servokit.feedback.loopshape_iterate",
    "pid_notch_structure": "servokit.feedback.loopshape_problem",
    "Margins": "servokit.feedback.margins",
    "SetMargins": "servokit.feedback.margins_set",
    "PeakFilterSpec": "servokit.feedback.peak_filtered",
    "peak_filtered_controller": "servokit.feedback.peak_filtered",
    "complex_lag": "servokit.feedback.filters",
    "design_peak_filter": "servokit.feedback.filters",
    "discretize_filter": "servokit.feedback.filters",
    "dual_stage_loops": "servokit.feedback.dual_stage",
    "frequency_grid": "servokit.models.frequency_grid",
    "inverse_pair": "servokit.feedback.filters",
    "lag": "servokit.feedback.filters",
    "lead_lag": "servokit.feedback.filters",
    "loop_response": "servokit.feedback.margins",
    "margins_over_set": "servokit.feedback.margins_set",
    "notch": "servokit.feedback.filters",
    "peak_filter": "servokit.feedback.filters",
    "peak_filter_phase": "servokit.feedback.filters",
    "pi_controller": "servokit.feedback.filters",
    "pseudo_plant": "servokit.feedback.filters",
    "stability_margins": "servokit.feedback.margins",
    "IEEJ_ISSUE_20_NUMBERS": "servokit.feedback.ieej_fit",
    "IEEJ_ISSUE_20_PRECISION": "servokit.feedback.ieej_fit",
    "IeejLoopFit": "servokit.feedback.ieej_fit",
    "fit_ieej_loop": "servokit.feedback.ieej_fit",
    "ieej_loop_numbers": "servokit.feedback.ieej_fit",
}

__all__ = [
    "IEEJ_ISSUE_20_NUMBERS",
    "IEEJ_ISSUE_20_PRECISION",
    "IeejLoopFit",
    "fit_ieej_loop",
    "ieej_loop_numbers",
    "DualStageLoops",
    "LoopRow",
    "LoopTable",
    "LoopshapeResult",
    "Structure",
    "certify_models",
    "fixed_order_structure",
    "loopshape",
    "pid_notch_structure",
    "Margins",
    "SetMargins",
    "PeakFilterSpec",
    "peak_filtered_controller",
    "complex_lag",
    "design_peak_filter",
    "discretize_filter",
    "dual_stage_loops",
    "frequency_grid",
    "inverse_pair",
    "lag",
    "lead_lag",
    "loop_response",
    "margins_over_set",
    "notch",
    "peak_filter",
    "peak_filter_phase",
    "pi_controller",
    "pseudo_plant",
    "stability_margins",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
