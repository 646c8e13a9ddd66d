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

from servokit.feedback.dual_stage import DualStageLoops, dual_stage_loops
from servokit.feedback.filters import (
    complex_lag,
    design_peak_filter,
    discretize_filter,
    inverse_pair,
    lag,
    lead_lag,
    notch,
    peak_filter,
    peak_filter_phase,
    pi_controller,
    pseudo_plant,
)
from servokit.feedback.ieej_fit import (
    IEEJ_ISSUE_20_NUMBERS,
    IEEJ_ISSUE_20_PRECISION,
    IeejLoopFit,
    fit_ieej_loop,
    ieej_loop_numbers,
)
from servokit.feedback.loopshape_eval import LoopRow, LoopTable
from servokit.feedback.loopshape_iterate import LoopshapeResult, certify_models, loopshape
from servokit.feedback.loopshape_problem import (
    Structure,
    fixed_order_structure,
    pid_notch_structure,
)
from servokit.feedback.margins import Margins, loop_response, stability_margins
from servokit.feedback.margins_set import SetMargins, margins_over_set
from servokit.feedback.peak_filtered import PeakFilterSpec, peak_filtered_controller
from servokit.models.frequency_grid import frequency_grid

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
