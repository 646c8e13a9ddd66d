"""Book §5.4-§5.5: dual-stage loops, the Table 5.4 design example, self-sensing actuation.

Run from the repository root:  PYTHONPATH=src python examples/chapter5_dual_stage.py
"""

from __future__ import annotations

import control
import numpy as np

from servokit.feedback.adaptive import AdaptiveGains, cantilever_beam, simulate_adaptive
from servokit.feedback.dual_stage import dual_stage_loops, loop_margins
from servokit.feedback.dual_stage_design import BOOK_TABLE_5_4, METHODS, evaluate_design
from servokit.feedback.dual_stage_fitted import fitted_unknowns
from servokit.feedback.ssa import amd_controller, ddssa_bridge, mode_damping
from servokit.models import pzt_active_suspension


def structures() -> None:
    """Parallel / CMS / DMS loops from python-control objects (5.79)-(5.89)."""
    PV = control.tf([1.4e8], [1, 48, 120**2])
    CV = control.tf([5e-4, 0.314, 49.3], [1, 1.885e5, 0])
    PM = control.tf([0.36], [1])
    CM = 0.2 * control.tf([1, 1.885e5], [1, 5655])
    for structure in ("parallel", "cms", "dms"):
        loops = dual_stage_loops(PV, CV, PM, CM, structure)
        f = np.geomspace(1, 1e5, 4000)
        m = loop_margins(f, np.asarray(loops.L(2j * np.pi * f)).ravel())
        print(
            f"{structure:8s} crossover {m.gain_crossover_hz:7.1f} Hz, "
            f"PM {m.phase_margin_deg:5.1f} deg"
        )


def table_5_4() -> None:
    """The three DMS designs with the searched unknowns, book vs servokit."""
    for method in METHODS:
        row = evaluate_design(method, fitted_unknowns(method))
        book = BOOK_TABLE_5_4[method]
        print(
            f"{method:8s} crossover {row.crossover_hz:7.1f} Hz (book {book['crossover_hz']}), "
            f"GM {row.gain_margin_db:5.2f} dB (book {book['gain_margin_db']}), "
            f"PM {row.phase_margin_deg:5.1f} deg (book {book['phase_margin_deg']}), "
            f"hand-off {row.handoff_hz:5.1f} Hz (book {book['handoff_hz']})"
        )


def self_sensing() -> None:
    bridge = ddssa_bridge(2e-9, 2e-9, 2e-9, 2e-9)
    print("DDSSA balanced:", bridge.balanced, "vs/vM =", complex(bridge.from_vm(1j)).real)
    modes = [(5461, 2.0, 10.0), (6074, 2.0, 10.0), (9103, 2.0, 10.0)]
    res = mode_damping(
        pzt_active_suspension().to_statespace(), amd_controller(modes), [m[0] for m in modes]
    )
    print("AMD attenuation [dB]:", np.round(res.attenuation_db, 1))
    run = simulate_adaptive(cantilever_beam(3), AdaptiveGains(), duration=2e-3)
    print(f"adaptive: V {run.V[0]:.3g} -> {run.V[-1]:.3g}, max increase {run.max_increase():.1e}")


if __name__ == "__main__":
    structures()
    table_5_4()
    self_sensing()
