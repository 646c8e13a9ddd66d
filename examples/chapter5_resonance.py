"""Chapter 5, part 1: resonance-compensation filters, exact margins, identification above
Nyquist and the LTV peak filter. Run: PYTHONPATH=src python examples/chapter5_resonance.py"""

from __future__ import annotations

import numpy as np

import servokit as sk
from servokit.feedback.ltv import LtvPeakFilter, decay_time, simulate_peak_filter_loop
from servokit.sampled.identification import identify_above_nyquist


def main() -> None:
    fb = sk.feedback
    # filters as python-control objects (5.14), (5.17), (5.92)
    notch = fb.notch(4449.0, 0.09, filter_damping=0.7)
    lag = fb.complex_lag(6900.0, 0.1, 1.1519)
    print("complex lag phase at 6900 Hz [rad]:", np.angle(complex(lag(2j * np.pi * 6900.0))))

    # margins of the Table 5.2 VCM loop on the exact response (plus a notch, prewarped Tustin)
    plant = sk.models.vcm_dual_stage()
    ctrl = sk.models.vcm_controller_table_5_2()
    loop = [plant.discretize(ctrl.dt), ctrl]
    m = fb.stability_margins(loop)
    print(
        f"VCM loop: PM {m.phase_margin_deg:.1f} deg at {m.pm_freq_hz:.0f} Hz, "
        f"GM {m.gain_margin_db:.2f} dB at {m.gm_freq_hz:.0f} Hz"
    )
    m2 = fb.stability_margins(loop + [fb.discretize_filter(notch, ctrl.dt, 4449.0)])
    print(
        f"  with a 4449 Hz notch: PM {m2.phase_margin_deg:.1f} deg, GM {m2.gain_margin_db:.2f} dB"
    )

    # identification above Nyquist (5.10)-(5.11): every 1 kHz here (the book: every 50 Hz)
    res = identify_above_nyquist(plant, ctrl, np.arange(500.0, 45001.0, 1000.0))
    db, deg = res.errors(plant.freqresp(res.freq_hz))
    print(
        f"identified {res.freq_hz.size} points to 45 kHz: max error "
        f"{np.max(np.abs(db)):.3g} dB, {np.max(np.abs(deg)):.3g} deg"
    )

    # LTV peak filter against a 7913 Hz output disturbance (Fig. 5.25 setting, assumed arm)
    from servokit.cases.ltv import arm_loop

    pd, cd = arm_loop()
    z = np.exp(2j * np.pi * 7913.0 * cd.dt)
    phi = fb.peak_filter_phase(complex((pd * cd)(z) / (1 + (pd * cd)(z))))
    d = np.sin(2 * np.pi * 7913.0 * cd.dt * np.arange(600))
    for name, flt in (
        ("LTI", LtvPeakFilter.lti(7913.0, 0.01, 0.5, phi)),
        ("LTV", LtvPeakFilter(7913.0, phi, (2.0, 0.5), (0.1, 0.01), 3000.0)),
    ):
        r = simulate_peak_filter_loop(pd, cd, flt, d)
        print(f"{name} peak filter: time to 10 % = {decay_time(r, 7913.0) * 1e3:.2f} ms")


if __name__ == "__main__":
    main()
