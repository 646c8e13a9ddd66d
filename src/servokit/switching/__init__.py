"""Mode-switching control (book chapter 3): initial value compensation (IVC),
switching-condition design and maximal output admissible sets.

The loop conventions are those of (3.12)-(3.17), see :mod:`servokit.switching.loop`.
"""

from servokit.switching.additional import (
    AdditionalInputIvc,
    additional_input_response,
    ivc_additional_input,
)
from servokit.switching.admissible import AdmissibleSet, max_output_admissible_set
from servokit.switching.conditions import (
    ConditionCheck,
    SwitchingCostGrid,
    SwitchingCostMap,
    admissible_conditions,
    optimal_condition,
    switching_cost_grid,
    switching_cost_map,
    switching_cost_matrix,
)
from servokit.switching.design import fit_delay_ratio, pade_double_integrator, place_controller
from servokit.switching.ivc import (
    IvcGains,
    ivc_jmin,
    ivc_jmin_jerk,
    ivc_pole_zero,
    ivc_transfer,
    ivc_zeros,
    jmin_cost,
    lyapunov_cost,
    match_poles,
)
from servokit.switching.loop import SwitchedLoop, free_response, siso_zeros, switched_loop
from servokit.switching.modeswitch import (
    SwitchedResponse,
    equilibrium,
    mode_switching_response,
    reference_switching_response,
)

__all__ = [
    "IvcGains",
    "ivc_jmin_jerk",
    "SwitchedResponse",
    "equilibrium",
    "mode_switching_response",
    "reference_switching_response",
    "SwitchingCostMap",
    "SwitchingCostGrid",
    "switching_cost_grid",
    "ConditionCheck",
    "admissible_conditions",
    "optimal_condition",
    "switching_cost_map",
    "switching_cost_matrix",
    "AdditionalInputIvc",
    "additional_input_response",
    "ivc_additional_input",
    "fit_delay_ratio",
    "pade_double_integrator",
    "place_controller",
    "AdmissibleSet",
    "max_output_admissible_set",
    "SwitchedLoop",
    "switched_loop",
    "free_response",
    "siso_zeros",
    "ivc_jmin",
    "ivc_pole_zero",
    "ivc_transfer",
    "ivc_zeros",
    "jmin_cost",
    "lyapunov_cost",
    "match_poles",
]
