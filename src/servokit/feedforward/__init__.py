"""Feedforward design, phases 1-2 of a positioning move (book chapter 2).

* :func:`final_state_control` — minimum-norm final-state control, eq. (2.35);
* :func:`fsc_input` — minimum-jerk FSC (2.40)-(2.42) and frequency-shaped FFSC
  (2.44)-(2.61), (2.74)-(2.75) for modal plants, optionally constrained (2.62)-(2.72);
* :func:`choose_N` — step number minimising the worst-case seek time over a plant set;
* bang-bang and minimum-jerk inputs (2.10)-(2.15), sampled-data polynomials (Table 2.1),
  constraint objects for the constrained FSC QP and the amplifier energy (2.89).

The names of the sympy-based and QP-based modules are imported lazily on first use so
that ``import servokit.feedforward`` stays fast.
"""

from __future__ import annotations

import importlib
from typing import Any

from servokit.feedforward.ffsc import (
    FeedforwardInput,
    NSearchResult,
    augmented_design_model,
    band_frequencies,
    choose_N,
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

#: name -> submodule for the lazily imported names
_LAZY: dict[str, str] = {
    # minimum_jerk.py: bang-bang (2.10) and minimum jerk (2.14)-(2.15), Fig. 2.10
    "RigidBodyTrajectory": "minimum_jerk",
    "MinimumJerkZOHResponse": "minimum_jerk",
    "bang_bang_time": "minimum_jerk",
    "bang_bang_input": "minimum_jerk",
    "bang_bang_trajectory": "minimum_jerk",
    "minimum_jerk_input": "minimum_jerk",
    "minimum_jerk_trajectory": "minimum_jerk",
    "held_input_response": "minimum_jerk",
    "minimum_jerk_zoh_response": "minimum_jerk",
    "minimum_jerk_zoh_plot": "minimum_jerk",
    # polynomial.py: Table 2.1, (2.24)-(2.25)
    "POLYNOMIAL_ORDERS": "polynomial",
    "boundary_condition_split": "polynomial",
    "polynomial_formula": "polynomial",
    "sampled_polynomial": "polynomial",
    "rigid_body_zoh_states": "polynomial",
    # constraints.py: constrained FSC QP (2.62)-(2.72), (2.84)-(2.88)
    "InfeasibleConstraintsError": "constraints",
    "MotorModel": "constraints",
    "SignalLimit": "constraints",
    "InputLimit": "constraints",
    "CurrentLimit": "constraints",
    "VelocityLimit": "constraints",
    "PositionLimit": "constraints",
    "VoltageLimit": "constraints",
    "constraint_rows": "constraints",
    "solve_fsc_qp": "constraints",
    # energy.py: amplifier energy (2.89)
    "amplifier_power": "energy",
    "supply_voltage": "energy",
}

__all__ = [
    "FeedforwardInput",
    "LiftedModel",
    "NSearchResult",
    "augmented_design_model",
    "band_frequencies",
    "choose_N",
    "final_state_control",
    "fsc_input",
    "held_spectrum_matrix",
    "lifted_model",
    "lifted_state_map",
    "min_norm_final_state",
    "RigidBodyTrajectory",
    "MinimumJerkZOHResponse",
    "bang_bang_time",
    "bang_bang_input",
    "bang_bang_trajectory",
    "minimum_jerk_input",
    "minimum_jerk_trajectory",
    "held_input_response",
    "minimum_jerk_zoh_response",
    "minimum_jerk_zoh_plot",
    "POLYNOMIAL_ORDERS",
    "boundary_condition_split",
    "polynomial_formula",
    "sampled_polynomial",
    "rigid_body_zoh_states",
    "InfeasibleConstraintsError",
    "MotorModel",
    "SignalLimit",
    "InputLimit",
    "CurrentLimit",
    "VelocityLimit",
    "PositionLimit",
    "VoltageLimit",
    "constraint_rows",
    "solve_fsc_qp",
    "amplifier_power",
    "supply_voltage",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
