"""Chapter 6 (§6.1.4): loop shaping from a disturbance model, on the HDD benchmark.

Read top to bottom; run with ``python examples/chapter6_hdd_pes.py [OUTDIR]``.

1. Generate the HDD Benchmark v2 disturbances (sensor noise, force noise, flutter, RRO).
2. Simulate track following with servokit's baseline controller (1 kHz crossover) and
   report NRPE 3 sigma in % of the track pitch.
3. Add a phase-stable peak filter (5.17)-(5.18) at the flutter band and compare.
4. Compare with the output-variance lower bound (6.16) of the same loop.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import control
import numpy as np

from servokit.feedback import PeakFilterSpec, peak_filtered_controller
from servokit.limits import output_variance, rolloff_bandwidth, variance_lower_bound
from servokit.models import (
    BenchmarkDisturbances,
    benchmark_controller,
    disturbance_magnitude,
    hdd_benchmark,
)
from servokit.simulate import track_following_pes

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"
outdir = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")

# 1. disturbances (seeded, reproducible)
bd = BenchmarkDisturbances()
record = bd.generate(30 if SMALL else 200, seed=0)

# 2. baseline loop
plant = hdd_benchmark()
c0 = benchmark_controller()
base = track_following_pes(plant, c0, record)
print(f"baseline:         NRPE 3sigma = {base.nrpe_3sigma_percent:.2f} % of track")

# 3. peak filter on the flutter band (900-1020 Hz carry most of the NRPE)
pd = plant.discretize(bd.dt)
c1 = peak_filtered_controller(c0, pd, PeakFilterSpec(960.0, 0.08, 12.0))
filt = track_following_pes(plant, c1, record)
print(f"with peak filter: NRPE 3sigma = {filt.nrpe_3sigma_percent:.2f} % of track")

# 4. how far from the limit? (6.13) vs the corrected (6.16)
if not SMALL:  # the quadratures take a few seconds
    loop = control.ss(c0) * pd
    dist = disturbance_magnitude(bd, pd)
    omega_hz = rolloff_bandwidth(loop)
    bound = variance_lower_bound(dist, omega_hz, dt=bd.dt, breakpoints_hz=bd.flutter_freq_hz)
    var = output_variance(loop, dist, breakpoints_hz=bd.flutter_freq_hz)
    print(
        f"(6.13): 3sigma {300 * np.sqrt(var):.2f} %, bound (6.16): "
        f"{300 * np.sqrt(bound.bound):.2f} % (Omega = {omega_hz:.0f} Hz)"
    )
