"""Chapter 5: the VCM loop of the dual-stage HDD, its margins, and its firmware.

Read top to bottom; run with ``python examples/chapter5_vcm_loop.py [OUTDIR]``.

1. The VCM (primary actuator) model of eq. (5.1) / Table 5.1 and the controller of
   Table 5.2, sampled at the PES rate.
2. Discretise the plant exactly (zero-order hold) and form the open loop L = C Pd with
   python-control; read the margins and the closed-loop pole radius.
3. Export the controller as second-order sections in C (double), with a step function
   that the firmware calls once per sample.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import control
import matplotlib.pyplot as plt
import numpy as np

import servokit as sk
from servokit._figures import save_figure
from servokit.export import sos_tables, write_export

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"  # the test suite runs small sizes
out = Path(sys.argv[1] if len(sys.argv) > 1 else "example_out")
out.mkdir(parents=True, exist_ok=True)

# 1. plant and controller
plant = sk.models.vcm_dual_stage()
ctrl = sk.models.vcm_controller_table_5_2()
ts = sk.models.VCM_PES_TS

# 2. exact ZOH discretisation (servokit) and the loop (python-control); the margins are
#    read on a dense frequency grid (the lightly damped modes make root-based crossover
#    searches fragile)
loop = ctrl * plant.discretize(ts)
freq_hz = np.geomspace(10.0, 0.5 / ts, 5_000 if SMALL else 50_000)
resp = loop(np.exp(2j * np.pi * freq_hz * ts))
mag, phase_deg = np.abs(resp), np.degrees(np.unwrap(np.angle(resp)))
gc = np.flatnonzero(np.diff(np.sign(mag - 1.0)))  # |L| crosses 1
pc = np.flatnonzero(np.diff(np.sign(np.mod(phase_deg + 180.0, 360.0) - 180.0)) > 0)
for i in gc:
    print(
        f"gain crossover {freq_hz[i]:.0f} Hz: phase margin {180.0 + phase_deg[i] % -360.0:.1f} deg"
    )
for i in pc:
    print(f"phase crossover {freq_hz[i]:.0f} Hz: gain margin {-20 * np.log10(mag[i]):.2f} dB")
radius = float(np.max(np.abs(control.feedback(loop, 1).poles())))
print(f"closed-loop pole radius {radius:.4f} (< 1: stable)")

fig, ax = plt.subplots(figsize=(7, 4))
ax.semilogx(freq_hz, 20 * np.log10(np.abs(resp)), label="|L| = |C Pd|")
ax.semilogx(freq_hz, -20 * np.log10(np.abs(1 + resp)), label="|S| = 1/|1 + L|")
ax.set_xlabel("frequency [Hz]")
ax.set_ylabel("magnitude [dB]")
ax.set_title("VCM loop of the dual-stage HDD (Table 5.2 controller, eq. 5.1 plant)")
ax.legend()
print("wrote", save_figure(fig, out / "ch5_vcm_loop.png"))

# 3. the controller for firmware: cascade of second-order sections + a step function
for path in write_export(
    sos_tables(ctrl, "c_vcm"), out, "vcm_ctrl", precision="double", step="sos"
):
    print("wrote", path)
