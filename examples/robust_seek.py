"""Robust minimum-time seek on the 18 HDD benchmark plants (issue 13, beyond the book).

Designs the shortest 1-track seek guaranteed on all plants of Table 2.3 at the peak input
of the book's Design 2, checks it with the ordinary simulator and compares it with
Design 2.  Run: ``PYTHONPATH=src python examples/robust_seek.py``.
"""

from __future__ import annotations

import numpy as np

import servokit as sk
from servokit.models import HDD_BENCHMARK_TS
from servokit.seek import DESIGNS


def main() -> None:
    # the book's convention of §2.4: time counted from when the input reaches the plant
    plants = [p.replace(delay=0.0) for p in sk.models.hdd_benchmark_variants()]
    design_2 = DESIGNS[2].design(plants[0])  # FFSC, N = 10, Table 2.4 weights
    u_max = float(np.abs(design_2.u).max())
    robust = sk.feedforward.robust_minimum_time(
        plants, HDD_BENCHMARK_TS, 1.0, band=0.1, u_max=u_max
    )
    t_rob = sk.simulate.seek_time(plants, robust, 1.0, band=0.1, horizon=0.02)
    t_d2 = sk.simulate.seek_time(plants, design_2, 1.0, band=0.1)
    print(f"peak input            : {u_max:.5f} A for both designs")
    print(f"Design 2 worst seek   : {t_d2.max() * 1e3:.4f} ms (N = {design_2.N})")
    print(
        f"robust worst seek     : {t_rob.max() * 1e3:.4f} ms (N = {robust.N}; LP guarantee "
        f"{robust.guaranteed_seek_time * 1e3:.4f} ms within +-{robust.band:g} track)"
    )
    print(f"shorter by            : {100 * (1 - t_rob.max() / t_d2.max()):.1f} %")


if __name__ == "__main__":
    main()
