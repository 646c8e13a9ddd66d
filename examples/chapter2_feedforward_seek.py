"""Chapter 2: a fast track seek on the HDD benchmark with FSC and frequency-shaped FSC.

Read top to bottom; run with ``python examples/chapter2_feedforward_seek.py [OUTDIR]``.

1. Take the HDD benchmark plant (book Table 2.2) and its 18 perturbed variants (Table 2.3).
2. Design two 1-track seek inputs on the rigid-body model, held at Ts = 37.879 us:
   Design 1, the minimum-jerk final-state control (2.40)-(2.42), and Design 2, the
   frequency-shaped FFSC that also penalises the input spectrum in the resonance bands of
   Table 2.4 (2.74)-(2.75).
3. Apply each, without feedback, to all 18 plants and read the worst seek time: the time
   after which the head stays within +-0.1 track of the target (book §2.4.1).
4. Export the Design 2 table as a C header for the drive's firmware.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # write files, never open windows
import matplotlib.pyplot as plt
import numpy as np

import servokit as sk
from servokit._figures import save_figure
from servokit.export import feedforward_tables, write_export
from servokit.seek import table_2_4_weights

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"  # the test suite runs small sizes
out = Path(sys.argv[1] if len(sys.argv) > 1 else "example_out")
out.mkdir(parents=True, exist_ok=True)

# 1. the plant set; the book's numbers are for the input reaching the plant at t = 0,
#    so the 10 us input delay is left out here (see servokit.cases.hdd_seek)
plants = [p.replace(delay=0.0) for p in sk.models.hdd_benchmark_variants()]
if SMALL:
    plants = plants[:3]
nominal = plants[0]
ts = sk.models.HDD_BENCHMARK_TS

# 2. the two designs of §2.4.2 for a 1-track seek (the book's N: 12 and 10 steps)
design1 = sk.feedforward.fsc_input(nominal, ts, 12, 1.0, model="rigid-body")
design2 = sk.feedforward.fsc_input(
    nominal, ts, 10, 1.0, band_weights=table_2_4_weights(1.0), model="rigid-body"
)

# 3. worst seek time over the plant set (position read on a Ts/10 grid)
fig, ax = plt.subplots(figsize=(7, 4))
for label, ff in (("Design 1 (FSC)", design1), ("Design 2 (FFSC)", design2)):
    worst_ms = 1e3 * float(np.max(sk.simulate.seek_time(plants, ff, 1.0, band=0.1)))
    print(f"{label}: N = {ff.N}, worst seek time {worst_ms:.3f} ms")
    res = sk.simulate.seek_response(plants[0], ff)
    ax.plot(res.t * 1e3, res.yc[0], label=f"{label}, nominal plant")
ax.axhspan(0.9, 1.1, color="0.9", label="+-0.1 track band")
ax.set_xlabel("time [ms]")
ax.set_ylabel("head position [track]")
ax.set_title("1-track seek, FSC vs FFSC (cf. book Figs. 2.14 and 2.18)")
ax.legend()
print("wrote", save_figure(fig, out / "ch2_seek.png"))

# 4. firmware: the held samples of Design 2 as a Q15 table with its scale and error bound
for path in write_export(feedforward_tables(design2.u, ts, "u"), out, "seek_ffsc", precision="q15"):
    print("wrote", path)
