"""Chapter 6: the waterbed effect — the Bode sensitivity integral of a discrete loop.

Read top to bottom; run with ``python examples/chapter6_bode_integral.py [OUTDIR]``.

For a stable, strictly proper discrete open loop L(z) (no unstable poles), the Bode
integral says the average of ln|S| over the frequency axis up to Nyquist is zero:

    (1/pi) * integral_0^pi ln|S(e^{j theta})| d theta = sum ln|p_i|  (unstable p_i of L) = 0.

Whatever disturbance rejection the loop buys at low frequency (|S| < 1) it pays back as
amplification (|S| > 1) elsewhere below Nyquist.  We check the identity numerically on
the VCM loop of chapter 5 and show where the area goes.
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

ts = sk.models.VCM_PES_TS
loop = sk.models.vcm_controller_table_5_2() * sk.models.vcm_dual_stage().discretize(ts)
# the controller's integrator sits on the unit circle (|p| = 1 to rounding): not unstable
unstable = [p for p in loop.poles() if abs(p) > 1 + 1e-6]
print(f"unstable open-loop poles: {len(unstable)}")

# ln|S| on a fine grid of theta in (0, pi); the trapezoid rule is accurate once the
# grid resolves the lightly damped resonances
theta = np.linspace(1e-6, np.pi, 20_001 if SMALL else 200_001)
log_s = -np.log(np.abs(1.0 + loop(np.exp(1j * theta))))
integral = np.trapezoid(log_s, theta) / np.pi
expected = float(np.sum(np.log(np.abs(unstable)))) if unstable else 0.0
print(f"(1/pi) * integral of ln|S| = {integral:+.2e}, Bode's theorem: {expected:+.2e}")
below = np.trapezoid(np.minimum(log_s, 0.0), theta) / np.pi
print(f"area of attenuation {below:+.4f}, paid back by amplification {-below:+.4f}")

freq_hz = theta / (2 * np.pi * ts)
fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(freq_hz / 1e3, log_s, lw=0.8, label="ln|S|")
ax.fill_between(freq_hz / 1e3, log_s, 0.0, where=log_s < 0, alpha=0.3, label="attenuation")
ax.fill_between(freq_hz / 1e3, log_s, 0.0, where=log_s > 0, alpha=0.3, label="amplification")
ax.set_xlabel("frequency [kHz] (linear axis: equal areas)")
ax.set_ylabel("ln|S| [neper]")
ax.set_title("Waterbed effect: Bode sensitivity integral of the VCM loop (book ch. 6)")
ax.legend()
print("wrote", save_figure(fig, out / "ch6_bode_integral.png"))
