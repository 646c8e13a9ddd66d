"""Benchmark of issue 22 item 4: a robust seek validated over a stage's variation box.

The stage of the issue: rigid body and resonances at 2.1 / 5.4 / 9.8 kHz, 15 us input
delay.  The issue gives no gain or residues; assumed here: rigid-body gain
2.5e6 um/(V s^2) (100 m/s^2 at 40 V, a fast voice-coil stage), residues -0.3 / 0.2 /
-0.1 of the rigid body's and dampings 2 % / 1 % / 3 % (the stage of
tests/test_variation_file.py), hold period 100 us (10 kHz).  Box: +-5 % frequency,
+-20 % damping, +-10 % residue per mode, independent (9 ranges).  1000 um move, |u| <=
40 V, +-0.1 um band.

Prints the plain design on 27 plants of the box against a 2000-plant Monte-Carlo check
(the issue's complaint), then the validated design and its wall time.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from servokit.models import ModalPlant, Mode, VariationSet
from servokit.seek import robust_minimum_time, robust_seek_over_box
from servokit.simulate import seek_time

STAGE = ModalPlant(
    gain=2.5e6,
    modes=(Mode(0, 0, 1.0), Mode(2100, 0.02, -0.3), Mode(5400, 0.01, 0.2), Mode(9800, 0.03, -0.1)),
    delay=15e-6,
    name="stage",
)
BOX = VariationSet.per_mode(STAGE, freq_rel=0.05, damping_rel=0.2, residue_rel=0.1, seed=1)
DT, TARGET, BAND, U_MAX = 100e-6, 1000.0, 0.1, 40.0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--plain", action="store_true", help="also time the unvalidated design")
    args = ap.parse_args()
    out: dict[str, object] = {}
    if args.plain:
        t0 = time.perf_counter()
        design = [STAGE, *BOX.monte_carlo(26, seed=5)]
        ff = robust_minimum_time(design, DT, TARGET, band=BAND, u_max=U_MAX, margin=0.1)
        mc = seek_time(BOX.monte_carlo(2000, seed=2), ff, TARGET, band=BAND)
        out |= {
            "plain_design_plants": len(design),
            "plain_guarantee_s": ff.guaranteed_seek_time,
            "plain_mc_worst_s": float(mc.max()),
            "plain_s": time.perf_counter() - t0,
        }
    t0 = time.perf_counter()
    res = robust_seek_over_box(BOX, DT, TARGET, band=BAND, u_max=U_MAX, progress=print)
    out |= {
        "validated_seek_time_s": res.seek_time,
        "design_seek_time_s": res.design_seek_time,
        "n_validation": res.n_validation,
        "n_adversarial": res.n_adversarial,
        "n_design": res.n_design,
        "rounds": len(res.rounds),
        "converged": res.converged,
        "worst_source": res.worst_source,
        "n_samples": res.ff.N,
        "peak_input": float(np.abs(res.ff.u).max()),
        "validated_s": time.perf_counter() - t0,
    }
    print(json.dumps(out, indent=1) if args.json else out)


if __name__ == "__main__":
    main()
