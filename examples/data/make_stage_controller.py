"""Generate examples/data/stage_controller.toml: a lead controller for the example stage.

A phase-lead ``C(s) = k (s + wc / 3) / (s + 3 wc)`` with crossover ``fc = 300 Hz`` on the
rigid body ``g / s^2`` (``g = 4e6 um / (V s^2)``, the order of the fitted gain), Tustin
at ``dt = 50 us``; ``k`` puts ``|g C(j wc) / wc^2| = 1``.  An illustration for the guide
(docs/guide/own_actuator.md), not a tuned design.

Run:  python examples/data/make_stage_controller.py [OUT.toml]
"""

from __future__ import annotations

import sys
from pathlib import Path

import control
import numpy as np

from servokit.models import save_controller

G, FC, DT = 4.0e6, 300.0, 50e-6


def main(out: Path) -> None:
    """Write the controller file."""
    wc = 2 * np.pi * FC
    k = wc**2 / G * abs(3j * wc + 3 * wc) / abs(1j * wc + wc / 3)
    ctrl = control.c2d(control.tf([k, k * wc / 3], [1.0, 3 * wc]), DT, "tustin")
    save_controller(ctrl, out)


if __name__ == "__main__":
    main(
        Path(sys.argv[1])
        if len(sys.argv) > 1
        else Path(__file__).with_name("stage_controller.toml")
    )
