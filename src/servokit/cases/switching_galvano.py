"""Reference switching with IVC: galvano back-and-forth positioning (book §3.5).

The galvano scanner of the catalogue (rigid body, 3020 Hz and 6240 Hz modes, 15.5 us
delay; residues, damping and the gain 3000 m/s^2/A illustrative, as in the §2.5 case)
sampled at 20 us (book), with an assumed I-PD controller (integral on r - y, P and D on
-y; rigid-body poles at 600 Hz, damping 0.6) and notches at both modes (the book's
gains are not printed). The loop then has the book's 13 closed-loop roots, and the r'
compensators n_k/d are 12th order with d[z] = (z - 0.5)^12 (book §3.5.1.3).

Back-and-forth steps of 1.5 mm every 1.50 ms and 1.16 ms. The scatter is the largest
difference between a later motion's error and the first motion's (which starts from
rest), forward and backward motions mirrored. Compensated at each switch: the residual
of the previous motion (state minus its equilibrium) in the first mode's two states (the
book's choice) or in all closed-loop states. The assumed loop settles more slowly than
the book's (1.1 ms to 1 % instead of 0.9 ms), so the scatter is mostly unsettled
rigid-body and integrator motion, which mode-1 IVC does not address. The scatter is read
after the book's 0.9 ms settling time.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from servokit.cases import register
from servokit.models import galvano_scanner
from servokit.report import CaseResult, Comparison
from servokit.switching import (
    SwitchedLoop,
    ivc_additional_input,
    reference_switching_response,
    switched_loop,
)
from servokit.switching.design import ipd_controller, notch
from servokit.switching.plots import transient_plot

__all__ = ["switching_galvano_case", "galvano_loop"]

DT = 20e-6  # s (book)
STROKE_M = 1.5e-3
INTERVALS_S = (1.50e-3, 1.16e-3)
N_MOTIONS = 8
MODE1_STATES = (2, 3)  # modal states of the 3020 Hz mode (rigid body first)
SETTLE_S = 0.9e-3  # scatter read after the book's settling time


def galvano_loop() -> SwitchedLoop:
    """Galvano plant at 20 us with an I-PD of 600 Hz bandwidth and notches at both modes."""
    plant = galvano_scanner().replace(gain=3000.0).discretize(DT)
    notches = notch(DT, 3020.0, 0.02, 0.3) * notch(DT, 6240.0, 0.02, 0.3)
    fb, Bcr, Dcr = ipd_controller(
        DT, 3000.0, 600.0, damping=0.6, derivative_hz=20e3, filters=notches
    )
    return dataclasses.replace(switched_loop(plant, fb), Bcr=Bcr, Dcr=Dcr)


def _scatter(loop: SwitchedLoop, n_int: int, design, states) -> tuple[float, np.ndarray]:
    ref = np.concatenate(
        [np.zeros(5)] + [np.full(n_int, STROKE_M * (i % 2 == 0)) for i in range(N_MOTIONS)]
    )
    res = reference_switching_response(loop, ref, design, states=states)
    err = ref - res.y
    segs = np.array(
        [err[k : k + n_int] * (1 if i % 2 == 0 else -1) for i, k in enumerate(res.switches)]
    )
    late = np.arange(n_int) * DT >= SETTLE_S
    return float(np.max(np.abs(segs[1:, late] - segs[0, late]))), segs


@register("switching-galvano", order=130)
def switching_galvano_case(outdir: Path) -> CaseResult:
    """Repetitive 1.5 mm positioning with and without r' IVC at each reference switch."""
    start = time.perf_counter()
    loop = galvano_loop()
    g = loop.n + loop.m - 1
    design = ivc_additional_input(loop, 0.5, denominator=np.poly([0.5] * g))
    variants = {
        "without IVC": (None, ()),
        "IVC, first mode (book)": (design, MODE1_STATES),
        "IVC, all states": (design, tuple(range(loop.n + loop.m))),
    }
    rows, figs, scatter = [], [], {}
    for interval in INTERVALS_S:
        n_int = int(round(interval / DT))
        panels = []
        for label, (d, states) in variants.items():
            sc, segs = _scatter(loop, n_int, d, states)
            scatter[f"{interval * 1e3:.2f} ms, {label}"] = sc
            diff = {f"motion {i + 2}": (s - segs[0]) * 1e6 for i, s in enumerate(segs[1:])}
            panels.append((label, diff))
        t = np.arange(n_int) * DT * 1e3
        fig_no = "3.39/3.43" if interval > 1.3e-3 else "3.40/3.44"
        figs.append(
            transient_plot(
                t,
                panels,
                xlabel="Time after the reference switch [ms]",
                ylabel="Error minus the first motion's [um]",
                title=f"Figs. {fig_no}: back-and-forth 1.5 mm every {interval * 1e3:.2f} ms "
                "(assumed loop)",
                path=outdir / f"fig3_galvano_{int(round(interval * 1e5))}.png",
            )
        )
        key = f"{interval * 1e3:.2f} ms, "
        base = scatter[key + "without IVC"]
        full = scatter[key + "IVC, all states"]
        mode1 = scatter[key + "IVC, first mode (book)"] / base
        rows.append(
            Comparison(
                f"scatter with IVC / without, {interval * 1e3:.2f} ms interval",
                0.0,
                full / base,
                "",
                0.02,
                "Figs. 3.43/3.44",
                kind="assumed",
                note="book: no scattered responses (Figs. 3.43/3.44; read as < 2 % of the "
                "scatter without IVC after the 0.9 ms settling time); residual of all plant and "
                "controller states compensated, the d = (z - 0.5)^12 tail remains; compensating "
                f"the first mode only (the book's choice) leaves {mode1:.2g} of the scatter here: "
                "in this assumed loop the unsettled rigid-body and integrator residual dominates",
            )
        )
    extra = {
        "scatter_m": scatter,
        "closed_loop_roots": loop.n + loop.m,
        "compensator_order": g,
        "runtime_s": time.perf_counter() - start,
    }
    return CaseResult(
        name="switching-galvano",
        title="Reference switching with IVC: galvano back-and-forth (§3.5)",
        comparisons=rows,
        figures=figs,
        extra=extra,
        chapter=3,
    )
