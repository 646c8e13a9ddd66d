"""Chapter 4: what a sampled-data loop hides between the samples.

Read top to bottom; run with ``python examples/chapter4_sampled_data.py [OUTDIR]``.

1. The HDD loop of §4.5.2: the Table 4.1 plant at Ts = 153.5 us with the PI-lead
   controller (4.69).  The discrete sensitivity Sd only sees the samples; the
   sampled-data sensitivity |Ssd| (4.32) also counts the output between them.
2. An oscillation at a frequency near a multiple of the sampling frequency is nearly
   invisible in the samples: the unobservable magnitude (4.41)-(4.42).
3. The shock response spectrum (4.57) of a held half-sine acceleration: the residual
   vibration it leaves in an oscillator of each frequency.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import servokit as sk
from servokit._figures import save_figure

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"
out = Path(sys.argv[1] if len(sys.argv) > 1 else "example_out")
out.mkdir(parents=True, exist_ok=True)
n_freq = 60 if SMALL else 400

# 1. |Ssd| against |Sd| up to twice the sampling frequency
plant, ctrl = sk.models.hdd_sampled_data(), sk.models.controller_eq_4_69()
ts = sk.models.HDD_SAMPLED_DATA_TS
freq_hz = np.geomspace(50.0, 1.9 / ts, n_freq)  # k/Ts itself aliases onto 0 Hz
res = sk.sampled.sampled_data_sensitivity(plant, ctrl, ts, freq_hz)
print(
    f"peak |Sd| = {20 * np.log10(np.max(np.abs(res.Sd))):.2f} dB, "
    f"peak |Ssd| = {20 * np.log10(np.max(res.Ssd)):.2f} dB"
)
fig, ax = plt.subplots(figsize=(7, 4))
ax.semilogx(freq_hz, 20 * np.log10(np.abs(res.Sd)), label="|Sd| (samples only)")
ax.semilogx(freq_hz, 20 * np.log10(res.Ssd), label="|Ssd| (between samples too)")
ax.axvline(0.5 / ts, color="0.5", ls=":", label="Nyquist frequency")
ax.set_xlabel("frequency [Hz]")
ax.set_ylabel("magnitude [dB]")
ax.set_title("Sampled-data sensitivity of the HDD loop (single-rate ZOH, cf. book §4.5.2)")
ax.legend()
print("wrote", save_figure(fig, out / "ch4_sensitivity.png"))

# 2. worst-case unobservable magnitude of a unit oscillation sampled at 1/Ts
for f in (0.5 / ts, 0.9 / ts, 0.99 / ts):
    u = sk.sampled.unobservable_magnitude(f, ts)
    print(f"oscillation at {f:8.1f} Hz: worst unobservable magnitude {float(u.worst):.3f}")

# 3. residual SRS of a half-sine acceleration of 8 sampling periods, held at Ts
pulse = 8 * ts  # the held input must last a whole number of hold periods
srs_freq = np.linspace(100.0, 5000.0, 40 if SMALL else 200)
srs = sk.sampled.shock_response_spectrum(
    sk.sampled.half_sine(pulse), ts, srs_freq, 0.01, duration=pulse
)
print(f"largest residual response at {srs_freq[np.argmax(srs.magnitude)]:.0f} Hz")
