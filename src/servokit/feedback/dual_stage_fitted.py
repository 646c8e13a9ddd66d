"""The dual-stage unknowns fitted to Table 5.4 (§5.5.2-§5.5.3), as library data.

The book omits some parameters of its three DMS designs (notch damping and pole/zero
ratio, the depth of the extra notch, the pair-pole damping, the phase-method gains and
the two actuator delays).  :func:`~servokit.feedback.dual_stage_design.fit_unknowns`
searched them against the printed Table 5.4; the values are kept here so the CLI and the
reproduce case start from the same fitted design (a slow test re-finds them).
"""

from __future__ import annotations

from servokit.feedback.dual_stage_design import Unknowns

__all__ = [
    "FITTED",
    "FIT_FREE",
    "JOINT_FIT",
    "MAX_GM_DB",
    "JOINT_SEARCH",
    "fitted_unknowns",
    "joint_unknowns",
]


#: unknowns found by ``fit_unknowns`` (differential evolution, seed 1, popsize 12 on
#: SEARCH_GRID_HZ): first the inverse column with its three unknowns (maxiter 60; a slow
#: test re-runs it), then the gain and phase columns with the plant delays held at the
#: inverse column's values (maxiter 40; free unknowns in FIT_FREE)
FIT_FREE: dict[str, tuple[str, ...]] = {
    "gain": ("notch_damping", "notch_freq_ratio"),
    "inverse": ("pair_pole_damping", "delay_vcm_s", "delay_pzt_s"),
    "phase": (
        "notch_damping",
        "notch_freq_ratio",
        "extra_notch_depth_damping",
        "kcv_phase",
        "kcm_phase",
    ),
}


FITTED: dict[str, dict[str, float]] = {
    "gain": {
        "notch_damping": 0.3096,
        "notch_freq_ratio": 1.048,
        "delay_vcm_s": 1.6771e-5,
        "delay_pzt_s": 1.0014e-5,
    },
    "inverse": {"pair_pole_damping": 1.0, "delay_vcm_s": 1.6771e-5, "delay_pzt_s": 1.0014e-5},
    "phase": {
        "notch_damping": 1.488,
        "notch_freq_ratio": 1.4973,
        "extra_notch_depth_damping": 0.1516,
        "kcv_phase": 3.290,
        "kcm_phase": 0.6405,
        "delay_vcm_s": 1.6771e-5,
        "delay_pzt_s": 1.0014e-5,
    },
}


def fitted_unknowns(method: str) -> Unknowns:
    """The :class:`Unknowns` of ``method`` with the fitted values of :data:`FITTED`.

    Parameters
    ----------
    method : {"gain", "inverse", "phase"}
        Design method (a key of :data:`FITTED`).

    Returns
    -------
    Unknowns
        The values of ``FITTED[method]`` (dampings, notch pole frequency ratio,
        phase-method gains, plant delays [s]; the gain and phase columns reuse the
        inverse column's delays); the other unknowns keep their defaults.
    """
    return Unknowns(**FITTED[method])


#: settings of the joint searches of :mod:`servokit.feedback.dual_stage_search` behind
#: :data:`JOINT_FIT` (``joint_table_search``) and :data:`MAX_GM_DB` (``max_gain_margin``)
JOINT_SEARCH: dict[str, dict[str, dict[str, int]]] = {
    "table": {
        "inside": {"maxiter": 25, "popsize": 8, "seed": 1},
        "outside": {"maxiter": 50, "popsize": 10, "seed": 1},
    },
    "gain_margin": {
        "inside": {"maxiter": 30, "popsize": 10, "seed": 1},
        "outside": {"maxiter": 30, "popsize": 10, "seed": 1},
    },
}

#: ``joint_table_search`` optima on the gain and inverse columns together, inside the
#: book's ranges (``BOOK_RANGES``) and in the wide ones (``WIDE_RANGES``): the six
#: unknowns, the cost and the rows of both columns within tolerance (a slow test re-runs)
JOINT_FIT: dict[str, dict[str, float]] = {
    "inside": {
        "notch_damping": 0.7762,
        "notch_freq_ratio": 1.099,
        "notch_depth_damping": 0.1683,
        "pair_pole_damping": 0.8587,
        "delay_vcm_s": 2.123e-05,
        "delay_pzt_s": 8.665e-06,
    },
    "outside": {
        "notch_damping": 0.608,
        "notch_freq_ratio": 1.096,
        "notch_depth_damping": 0.09736,
        "pair_pole_damping": 0.8384,
        "delay_vcm_s": 2.066e-05,
        "delay_pzt_s": 7.033e-06,
    },
}

#: the largest gain margin [dB] ``max_gain_margin`` finds for the gain column, inside the
#: book's ranges and in the wide ones (Table 5.4 prints 14.1 dB)
MAX_GM_DB: dict[str, float] = {"inside": 9.37, "outside": 11.95}


def joint_unknowns(box: str) -> Unknowns:
    """The :class:`Unknowns` of the joint gain/inverse fit ``box`` ("inside"/"outside").

    Parameters
    ----------
    box : {"inside", "outside"}
        Inside the book's ranges or in the wide ranges (a key of :data:`JOINT_FIT`).

    Returns
    -------
    Unknowns
        The six fitted values of ``JOINT_FIT[box]``; the others keep their defaults.
    """
    return Unknowns(**JOINT_FIT[box])
