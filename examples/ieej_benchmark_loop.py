"""The IEEJ HDD benchmark's track-following loop: exact margins, the sampled-data delay
margin, and a fit of the filter data the benchmark does not publish.

Read top to bottom; run with ``python examples/ieej_benchmark_loop.py [OUTDIR]``.

The loop: the benchmark plant (rigid body + six modes, exact ZOH with its 10 us delay,
Ts = 37.879 us), the PID of the benchmark's ``followdemo.m``, notches at 4.1/5/7 kHz and
a second-order 8 kHz low-pass (25 states). ``followdemo.m`` publishes the PID, its gain
and the 1 kHz zero-cross target; the notch pole dampings and the low-pass damping of the
v2 loop are not public (see ``servokit.models.ieej_example_controller``). Issue 20 quotes
PM 35.17 deg, GM 4.11 dB at 1626 Hz and a delay margin of 97.68 us for its version of
the loop; the last part fits the unknown dampings and the crossover to those numbers and
prints what stays unexplained: on the book's plant (rigid body) no damping explains the
1626 Hz phase crossover; on the plant of the benchmark's own parameter file (first mode
90 Hz, damping 0.5) two fitted numbers explain all four.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import control
import numpy as np
from scipy.optimize import brentq

from servokit.feedback import (
    IEEJ_ISSUE_20_NUMBERS,
    IeejLoopFit,
    fit_ieej_loop,
    stability_margins,
)
from servokit.models import (
    HDD_BENCHMARK_TS,
    hdd_benchmark,
    ieej_benchmark_loop,
    ieej_benchmark_plant,
    ieej_example_controller,
)

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"
out = Path(sys.argv[1] if len(sys.argv) > 1 else "example_out")
out.mkdir(parents=True, exist_ok=True)

ts = HDD_BENCHMARK_TS
plant = hdd_benchmark()
pd = plant.discretize(ts)
ctrl = ieej_example_controller()  # assumed dampings 0.5 (the library default)
m = stability_margins([pd, *ctrl])
print(
    f"default loop: PM {m.phase_margin_deg:.2f} deg at {m.pm_freq_hz:.1f} Hz, "
    f"GM {m.gain_margin_db:.3f} dB at {m.gm_freq_hz:.1f} Hz, "
    f"delay margin {m.delay_margin_s * 1e6:.2f} us, stable {m.closed_loop_stable}"
)

# --- the delay margin of the sampled-data loop, by exact re-discretisation -------------
# stability_margins applies an extra delay as e^{-j w tau} on the discrete loop; the
# physical loop delays the continuous plant input, whose exact ZOH model (a fractional
# delay: extra delay states) aliases differently. The closed-loop poles decide.
c_ss = control.ss(ctrl[0])
for c in ctrl[1:]:
    c_ss = c_ss * control.ss(c)


def spectral_radius(extra_delay: float) -> float:
    """Largest closed-loop pole modulus with the plant delay grown by ``extra_delay``."""
    p = plant.replace(delay=plant.delay + extra_delay).discretize(ts)
    return float(np.max(np.abs(control.feedback(control.ss(p) * c_ss, 1).poles())))


tau = m.delay_margin_s
exact = brentq(lambda x: spectral_radius(x) - 1.0, 0.9 * tau, 1.1 * tau, xtol=1e-12)
print(
    f"closed-loop pole radius at 0.999x / 1.001x the delay margin: "
    f"{spectral_radius(0.999 * tau):.6f} / {spectral_radius(1.001 * tau):.6f}"
)
print(
    f"exact sampled-data critical delay {exact * 1e6:.3f} us "
    f"({exact / ts:.3f} samples) = {exact / tau:.5f} x the e^(-j w tau) delay margin"
)

# --- what the issue's numbers ask of the filters ----------------------------------------
pm_target = IEEJ_ISSUE_20_NUMBERS["phase_margin_deg"]
dm_target = IEEJ_ISSUE_20_NUMBERS["delay_margin_s"]
f180 = IEEJ_ISSUE_20_NUMBERS["gm_freq_hz"]
pid = control.tf([72.0, -141.95, 70.0], [1.0, -1.0, 0.0], ts)
phase = {}
for f in (1000.0, f180):
    z = np.exp(2j * np.pi * f * ts)
    phase[f] = np.degrees(np.angle(complex(pd(z)) * complex(pid(z))))
need_1k, need_f180 = -180 + pm_target - phase[1000.0], -180 - phase[f180]
print(
    f"with 0 dB at 1 kHz (PM/DM = {pm_target / 360 / dm_target:.1f} Hz) the filters "
    f"must lag {-need_1k:.2f} deg at 1 kHz and {-need_f180:.2f} deg at {f180:.0f} Hz "
    f"(ratio {need_f180 / need_1k:.3f}; a lag growing linearly with f gives {f180 / 1e3:.3f})"
)


# --- fits: the unknown filter data against the issue's numbers --------------------------
# servokit.feedback.fit_ieej_loop (least squares on residuals scaled by the quoted digits):
# (a) notch pole damping 0.5, low-pass damping and crossover fitted to the PM and the delay
#     margin only; the gain margin and the phase crossover are then predictions (on the
#     benchmark file's plant this is the library's IEEJ_FITTED_* constants).
# (b) on the book's plant, all three dampings and the crossover fitted to all four numbers.


def show(label: str, fit: IeejLoopFit) -> None:
    r, got = fit.residuals, fit.numbers
    values = ", ".join(f"{x:.4g}" for x in (*fit.notch_pole_damping[:2], fit.lowpass_damping))
    values += f", {fit.crossover_hz:.2f} Hz"
    print(
        f"{label}: notch 4.1k, 5/7k, low-pass dampings, crossover {values} -> "
        f"PM {got['phase_margin_deg']:.2f} deg, GM {got['gain_margin_db']:.3f} dB at "
        f"{got['gm_freq_hz']:.1f} Hz, DM {got['delay_margin_s'] * 1e6:.2f} us; unexplained "
        f"{r['phase_margin_deg']:+.2f} deg, {r['gain_margin_db']:+.3f} dB, "
        f"{r['gm_freq_hz']:+.1f} Hz, {r['delay_margin_s'] * 1e6:+.2f} us"
    )


for label, model in (
    ("book plant (rigid body)", plant),
    ("benchmark file (90 Hz)", ieej_benchmark_plant()),
):
    show(f"(a) fitted on the {label}", fit_ieej_loop(plant=model))

starts = [(0.5, 0.5, 0.5, 1000.0)]
if not SMALL:
    starts += [(1.0, 0.3, 0.3, 1000.0), (0.3, 1.0, 0.8, 1000.0)]
for method in ("tustin",) if SMALL else ("tustin", "matched"):
    best = fit_ieej_loop(
        plant=plant,
        fit_to=tuple(IEEJ_ISSUE_20_NUMBERS),
        fit_notches=True,
        method=method,
        starts=starts,
        max_nfev=40 if SMALL else 200,
        diff_step=1e-4,
    )
    show(f"(b) fitted on the book plant, {method}", best)

loop = ieej_benchmark_loop()
m = stability_margins(loop)
print(
    f"ieej_benchmark_loop(): PM {m.phase_margin_deg:.2f} deg at {m.pm_freq_hz:.2f} Hz, "
    f"GM {m.gain_margin_db:.3f} dB at {m.gm_freq_hz:.1f} Hz, "
    f"delay margin {m.delay_margin_s * 1e6:.2f} us"
)
