"""Feedforward design, phases 1-2 of a positioning move (book chapter 2).

* :func:`final_state_control` — minimum-norm final-state control, eq. (2.35);
* :func:`fsc_input` — minimum-jerk FSC (2.40)-(2.42) and frequency-shaped FFSC
  (2.44)-(2.61), (2.74)-(2.75) for modal plants, optionally constrained (2.62)-(2.72);
* bang-bang and minimum-jerk inputs (2.10)-(2.15), sampled-data polynomials (Table 2.1),
  constraint objects for the constrained FSC QP and the amplifier energy (2.89).

The names of the sympy-based modules (polynomials, minimum jerk) are imported lazily on first use so
that ``import servokit.feedforward`` stays fast.
"""

from __future__ import annotations

import importlib
from typing import Any

from servokit.feedforward.constraints import (
    CurrentLimit,
    InfeasibleConstraintsError,
    InputLimit,
    MotorModel,
    PositionLimit,
    SignalLimit,
    VelocityLimit,
    VoltageLimit,
    constraint_rows,
    solve_fsc_qp,
)
from servokit.feedforward.energy import amplifier_power, supply_voltage
from servokit.feedforward.ffsc import (
    FeedforwardInput,
    StepsBelowOrderError,
    augmented_design_model,
    band_frequencies,
    fsc_input,
    held_spectrum_matrix,
)
from servokit.feedforward.fsc import (
    LiftedModel,
    final_state_control,
    lifted_model,
    lifted_state_map,
    min_norm_final_state,
)

#: sympy-based modules, imported on first use of one of their names (their ``__all__``)
_LAZY_MODULES = ("polynomial", "minimum_jerk")

__all__ = [
    "CurrentLimit",
    "FeedforwardInput",
    "InfeasibleConstraintsError",
    "InputLimit",
    "LiftedModel",
    "MotorModel",
    "PositionLimit",
    "SignalLimit",
    "StepsBelowOrderError",
    "VelocityLimit",
    "VoltageLimit",
    "amplifier_power",
    "augmented_design_model",
    "band_frequencies",
    "constraint_rows",
    "final_state_control",
    "fsc_input",
    "held_spectrum_matrix",
    "lifted_model",
    "lifted_state_map",
    "min_norm_final_state",
    "solve_fsc_qp",
    "supply_voltage",
    # servokit.seek.robust (beyond the book, issue 13); see __getattr__
    "robust_minimum_time",
    # polynomial.py: Table 2.1, (2.24)-(2.25)
    "POLYNOMIAL_ORDERS",
    "boundary_condition_split",
    "polynomial_formula",
    "rigid_body_zoh_states",
    "sampled_polynomial",
    # minimum_jerk.py: bang-bang (2.10), minimum jerk (2.14)-(2.15), Fig. 2.10
    "MinimumJerkZOHResponse",
    "RigidBodyTrajectory",
    "bang_bang_input",
    "bang_bang_time",
    "bang_bang_trajectory",
    "held_input_response",
    "minimum_jerk_input",
    "minimum_jerk_trajectory",
    "minimum_jerk_zoh_plot",
    "minimum_jerk_zoh_response",
]


def __getattr__(name: str) -> Any:
    if name == "robust_minimum_time":
        # The public contract (DESIGN.md) names it here, but it lives in the seek layer
        # above (it evaluates designs by simulation): served on attribute access only, so
        # importing servokit.feedforward never imports servokit.seek.
        from servokit.seek.robust import robust_minimum_time

        return robust_minimum_time
    if name in __all__:
        for module_name in _LAZY_MODULES:
            module = importlib.import_module(f"{__name__}.{module_name}")
            if name in module.__all__:
                value = getattr(module, name)
                globals()[name] = value
                return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
