"""Generate examples/data/stage_frf.csv: a "measured" FRF of a positioning stage.

The stage is the one of issue 22 (a rigid body with resonances near 2.1, 5.4 and
9.8 kHz and a 15 us delay); input V, output um.  Its damping ratios and residues below
appear nowhere in the tests, and the noise (1.5 % complex, seed 20261125) is not one the
tests draw.  The file uses the mag_db/phase_deg columns a network analyser exports.

Run:  python examples/data/make_stage_frf.py [OUT.csv]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from servokit._io import write_atomic
from servokit.models import ModalPlant, Mode

STAGE = ModalPlant(
    gain=4.0e6,  # um / (V s^2)
    modes=(
        Mode(0.0, 0.0, 1.0),
        Mode(2130.0, 0.025, -0.42),
        Mode(5370.0, 0.012, 0.18),
        Mode(9840.0, 0.035, -0.25),
    ),
    delay=15e-6,
    name="example-stage",
    source="examples/data/make_stage_frf.py",
)
NOISE, SEED = 0.015, 20261125


def main(out: Path) -> None:
    """Write the FRF (2000 log-spaced points, 10 Hz - 20 kHz) as CSV."""
    f = np.geomspace(10.0, 20e3, 2000)
    rng = np.random.default_rng(SEED)
    e = (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size)) / np.sqrt(2)
    H = STAGE.freqresp(f) * (1.0 + NOISE * e)
    rows = [
        f"{a:.6f},{20 * np.log10(abs(h)):.6f},{np.degrees(np.angle(h)):.5f}"
        for a, h in zip(f, H, strict=True)
    ]
    header = "# example stage FRF (synthetic; see make_stage_frf.py)\nfreq_hz,mag_db,phase_deg\n"
    write_atomic(out, header + "\n".join(rows) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("stage_frf.csv"))
