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


def _worst(ours, ref) -> float:
    """Largest relative difference of two crossing lists (inf if their counts differ)."""
    ours, ref = np.sort(np.asarray(ours, float)), np.sort(np.asarray(ref, float))
    if ours.size != ref.size:
        return float("inf")
    return float(np.max(np.abs(ours - ref) / np.abs(ref), initial=0.0))


def accuracy() -> dict:
    """Crossings and gain margins against mpmath references (tests/_mp_reference.py):
    worst relative error per case. All-pole loops from polynomial roots at 50 digits
    (frequencies and gain margins); the dual-stage and IEEJ loops from secant roots of
    the 40-digit loop at each reported crossing."""
    import mpmath
    from _mp_reference import all_pole_reference, mp_loop, mp_root

    from servokit.models import vcm_controller_table_5_2, vcm_dual_stage

    out = {}
    clusters = {
        "triple_pole_4e-3": [12.0, 12.5, 12.546875],
        "quadruple_pole_1e-3": [1.0, 1.0, 1.0, 1.001],
        "triple_pole_1e-6_plus_two": [10.0, 10.00001, 10.00002, 3.0, 30.0],
    }
    for name, poles in clusters.items():
        den = np.poly(-np.array(poles))
        k0 = abs(np.polyval(den, 1j * 0.5 * poles[0]))
        for form, sys in (("tf", control.tf([k0], den)), ("ss", control.ss(control.tf([k0], den)))):
            m = stability_margins(sys)
            w180, gms, wc = all_pole_reference(den, k0)
            out[f"{name}_{form}"] = max(
                _worst(m.phase_crossovers_hz, w180),
                _worst(10 ** (np.asarray(m.gain_margins_db) / 20), gms),
                _worst(m.gain_crossovers_hz, wc),
            )
    ctrl = vcm_controller_table_5_2()
    ieej = ieej_benchmark_loop()
    for name, systems in (
        ("dual_stage_table_5_2", [vcm_dual_stage().discretize(ctrl.dt), ctrl]),
        ("ieej_loop", ieej),
    ):
        m = stability_margins(systems)
        ref_c = [mp_root(systems, f, "gain") for f in m.gain_crossovers_hz]
        ref_p = [mp_root(systems, f, "phase") for f in m.phase_crossovers_hz]
        with mpmath.workdps(40):
            l180 = [abs(complex(mp_loop(systems, mpmath.mpf(f)))) for f in ref_p]
        out[name] = max(
            _worst(m.gain_crossovers_hz, ref_c),
            _worst(m.phase_crossovers_hz, ref_p),
            _worst(10 ** (-np.asarray(m.gain_margins_db) / 20), l180),
        )
    out["worst_relative_error"] = max(out.values())
    return out
