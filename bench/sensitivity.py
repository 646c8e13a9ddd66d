"""``sampled_data_sensitivity`` over 10^4 frequencies: vectorised alias sums vs the
per-cell evaluation they replaced (``ModalPlant.freqresp`` and ``zoh_response`` on every
frequency x alias-order cell), and vs python-control's discrete ``Sd``/``Td``."""

from __future__ import annotations

import control
import numpy as np
from _timing import best_time, interleaved_best

from servokit.models import HDD_SAMPLED_DATA_TS as TS
from servokit.models import controller_eq_4_69, hdd_sampled_data
from servokit.sampled import _alias
from servokit.sampled import sensitivity as sens


def sensitivity(n_freq: int) -> dict:
    plant, C = hdd_sampled_data(), controller_eq_4_69()
    f = np.linspace(10.0, 0.4995 / TS, n_freq) + 0.123

    def run():
        return sens.sampled_data_sensitivity(plant, C, TS, f)

    new = run()

    def run_old():
        fast, cells = sens._path_terms, sens._MAX_CELLS
        sens._path_terms, sens._MAX_CELLS = _alias._per_cell_path_terms, 2_000_000  # pre-issue 8
        try:
            return run()
        finally:
            sens._path_terms, sens._MAX_CELLS = fast, cells

    old = run_old()
    best = interleaved_best({"new": run, "old": run_old}, 3)
    t_new, t_old = best["new"], best["old"]
    pd = plant.discretize(TS)
    w = 2 * np.pi * f

    def pc():
        L = control.series(control.ss(C), pd)
        return control.feedback(1, L).frequency_response(w), control.feedback(
            L, 1
        ).frequency_response(w)

    t_pc = best_time(pc, 3)
    rel = max(
        float(np.max(np.abs(a - b) / np.abs(b)))
        for a, b in ((new.Ssd, old.Ssd), (new.Tsd, old.Tsd), (new.gamma_sum, old.gamma_sum))
    )
    return {
        "frequencies": n_freq,
        "alias_terms": new.alias_terms,
        "servokit_s": t_new,
        "per_cell_baseline_s": t_old,
        "speedup_vs_per_cell": t_old / t_new,
        "python_control_discrete_sd_td_s": t_pc,
        "ratio_to_python_control_discrete": t_pc / t_new,
        "max_relative_difference": rel,
    }
