"""Margins of the IEEJ benchmark tracking loop of issue 20 (``ieej_benchmark_loop``: 25
states, the benchmark file's plant discretised exactly with its 10 us delay, PID, three
notches, low-pass): servokit's full ``stability_margins`` (every
crossing, delay and modulus margins, Nyquist verdict) against python-control's
``stability_margins`` on the same loop, in the same process.

``servokit_s`` is a repeated call on the same factors (each factor's reduced form is
cached, as in a plant-set, gain-sweep or loop-shaping run); ``servokit_cold_s`` clears
that cache before every call (the first call on new systems)."""

from __future__ import annotations

import control
import numpy as np
from _timing import interleaved_best

from servokit.feedback import stability_margins
from servokit.feedback.factor_response import clear_factor_cache
from servokit.models import ieej_benchmark_loop


def margins(rounds: int = 7) -> dict:
    factors = ieej_benchmark_loop()
    full = control.ss(factors[0])
    for c in factors[1:]:
        full = full * control.ss(c)

    def ours():
        return stability_margins(factors)

    def cold():
        clear_factor_cache()
        return stability_margins(factors)

    def theirs():
        return control.stability_margins(full, returnall=True)

    m, pc = ours(), theirs()
    best = interleaved_best({"servokit": ours, "cold": cold, "python_control": theirs}, rounds)
    n_pc_wc = int(np.size(pc[4]))
    return {
        "states": int(full.nstates),
        "servokit_s": best["servokit"],
        "python_control_s": best["python_control"],
        "servokit_cold_s": best["cold"],
        "speedup_vs_python_control": best["python_control"] / best["servokit"],
        "cold_speedup_vs_python_control": best["python_control"] / best["cold"],
        "phase_margin_deg": m.phase_margin_deg,
        "gain_margin_db": m.gain_margin_db,
        "delay_margin_us": m.delay_margin_s * 1e6,
        "gain_crossovers": len(m.gain_crossovers_hz),
        "python_control_gain_crossovers": n_pc_wc,
        "closed_loop_stable": str(m.closed_loop_stable),
    }
