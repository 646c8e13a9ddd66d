"""§5.5.2-§5.5.3: the dual-stage HDD design example (Table 5.4, Figs. 5.38-5.41).

Three DMS designs (gain stabilisation, inverse compensation, phase stabilisation) on the
Table 5.1 VCM and the Table 5.3 PZT, built from every printed parameter
(:mod:`servokit.feedback.dual_stage_design`).  The unknowns the book omits are those
:func:`~servokit.feedback.dual_stage_design.fit_unknowns` found (stored in
:data:`~servokit.feedback.dual_stage_fitted.FITTED`, re-found by a slow test); each row
says which it rests on.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.cases import register
from servokit.feedback.dual_stage_design import (
    BOOK_TABLE_5_4,
    METHODS,
    SEARCH_BOUNDS,
    DesignResponses,
    DesignRow,
    Unknowns,
    design_responses,
    evaluate_design,
)
from servokit.feedback.dual_stage_fitted import (
    FIT_FREE,
    FITTED,
    JOINT_FIT,
    MAX_GM_DB,
    fitted_unknowns,
    joint_unknowns,
)
from servokit.feedback.dual_stage_plots import METHOD_LABELS as _LABEL
from servokit.feedback.dual_stage_plots import bode_figure, sensitivity_figure
from servokit.feedback.dual_stage_plots import finish_magnitude_figure as _finish
from servokit.feedback.dual_stage_search import BOOK_RANGES, JOINT_NAMES, pzt_phase_span
from servokit.models.lti_response import lti_response
from servokit.report import CaseResult, Comparison

__all__ = ["FITTED", "run", "bode_figure", "sensitivity_figure", "fitted_unknowns"]


#: the columns computed with the joint fit of :mod:`servokit.feedback.dual_stage_search`
JOINT_METHODS = ("gain", "inverse")


def _box_text(bounds: dict[str, tuple[float, float]]) -> str:
    return ", ".join(
        f"{n} {lo * 1e6:g}-{hi * 1e6:g} us" if n.startswith("delay") else f"{n} {lo:g}-{hi:g}"
        for n, (lo, hi) in bounds.items()
    )


def _joint_note(key: str, book: str, value: float, wide: float) -> str:
    """The search evidence of a gain/inverse row: inside and outside the book's ranges."""
    out = JOINT_FIT["outside"]
    note = (
        f"joint differential evolution over {', '.join(JOINT_NAMES)} on the gain and inverse "
        f"columns together: inside the book's ranges ({_box_text(BOOK_RANGES)}) the best fit "
        f"gives {value:.4g}; in wide ranges (notch_damping 0.1-1.5, delays 0-100 us) it "
        f"gives {wide:.4g} at ζD = {out['notch_damping']:.3g}"
        f"{' (outside √2/2 < ζD <= 1)' if out['notch_damping'] < 0.7071 else ''}; book {book}"
    )
    if key == "gain_margin_db":
        note += (
            f"; the largest gain margin of the gain column a search finds is "
            f"{MAX_GM_DB['inside']} dB inside the book's ranges and {MAX_GM_DB['outside']} dB "
            "in the wide ones"
        )
    return note


def _miss(method: str, key: str, book: str, value: float, wide: float) -> dict[str, str]:
    """``miss_class``/``miss_note`` of a Table 5.4 row: the search that could not reach it."""
    if method in JOINT_METHODS:
        return {"miss_class": "under_determined", "miss_note": _joint_note(key, book, value, wide)}
    free = ", ".join(
        f"{n} {SEARCH_BOUNDS[n][0]:g}-{SEARCH_BOUNDS[n][1]:g}" for n in FIT_FREE[method]
    )
    note = (
        f"the book omits the notch/pair dampings, notch ratio and actuator delays; "
        f"differential evolution over {free} (delays 0-100 us from the inverse column) "
        f"best gives {value:.4g} vs {book}"
    )
    if key == "phi_pzt_deg":
        span = pzt_phase_span(np.linspace(0.0, 1e-4, 101), np.array([0.05]))
        note += (
            f"; arg T(j w1) - 90 deg of the baseline PZT loop (KCM = 0.1737 and the pair "
            f"printed) spans only {span['min_deg']:.1f}-{span['max_deg']:.1f} deg over PZT "
            f"delays 0-100 us (the largest at no delay): {book} deg is unreachable"
        )
    if not 0.7071 < FITTED[method].get("notch_damping", 1.0) <= 1.0:
        note += f" (fitted ζD = {FITTED[method]['notch_damping']:.4g} is outside the book's range)"
    return {"miss_class": "under_determined", "miss_note": note}


_ROWS = (
    ("handoff_hz", "hand-off frequency", "Hz"),
    ("phase_difference_deg", "phase difference at hand-off", "deg"),
    ("crossover_hz", "gain crossover frequency", "Hz"),
    ("gain_margin_db", "gain margin", "dB"),
    ("phase_margin_deg", "phase margin", "deg"),
    ("s_inf_db", "||S||inf", "dB"),
    ("second_phase_margin_deg", "second phase margin", "deg"),
    ("phi_vcm_deg", "VCM peak-filter phase phi = arg T0(j w1) - 90 deg", "deg"),
    ("phi_pzt_deg", "PZT peak-filter phase phi = arg T0(j w1) - 90 deg", "deg"),
)
#: the issue's tolerances: 5 % for frequencies, 1 dB, 5 deg
_ABS_TOL = {"Hz": 0.05, "dB": 1.0, "deg": 5.0}
_TOL_TEXT = {"Hz": "5 %", "dB": "1 dB", "deg": "5 deg"}


_SHARED = "; delays taken from the inverse column"


def _row_tolerance(book: float, unit: str) -> float:
    return _ABS_TOL[unit] if unit == "Hz" else _ABS_TOL[unit] / abs(book)


def _unknowns(method: str) -> Unknowns:
    """Gain and inverse columns: the joint fit inside the book's ranges; phase: FITTED."""
    return joint_unknowns("inside") if method in JOINT_METHODS else fitted_unknowns(method)


def _fit_text(method: str) -> str:
    if method in JOINT_METHODS:
        values = ", ".join(f"{k} = {v:.4g}" for k, v in JOINT_FIT["inside"].items())
        return f"unknowns {values} (joint fit of the gain and inverse columns, book's ranges)"
    values = ", ".join(f"{k} = {v:.4g}" for k, v in FITTED[method].items())
    return f"unknowns {values} (searched: {', '.join(FIT_FREE[method])}{_SHARED})"


def _comparisons(method: str, row: DesignRow, wide: DesignRow | None) -> list[Comparison]:
    book = BOOK_TABLE_5_4[method]
    out = [
        Comparison.printed(
            f"order of {name} ({_LABEL[method]})",
            book[key],
            float(getattr(row, key)),
            source="Table 5.4",
            kind="reproduced",
            note="count of the printed filters' states",
        )
        for key, name in (("order_cv", "CV"), ("order_cm", "CM"))
    ]
    for key, name, unit in _ROWS:
        if key not in book:
            continue
        b = float(book[key])
        out.append(
            Comparison(
                f"{name} ({_LABEL[method]})",
                b,
                float(getattr(row, key)),
                unit,
                rel_tol=_row_tolerance(b, unit),
                source="§5.5.2 (printed in rad)" if key.startswith("phi") else "Table 5.4",
                kind="fitted",
                note=f"DMS, continuous loop; {_fit_text(method)}; "
                f"tolerance {_TOL_TEXT[unit]} as the issue states, looser than the printed "
                "digits: the loop rests on unknowns the book omits",
                book_text=book[key],
                **_miss(
                    method,
                    key,
                    book[key],
                    float(getattr(row, key)),
                    float("nan") if wide is None else float(getattr(wide, key)),
                ),
            )
        )
    return out


def figures(responses: dict[str, DesignResponses], outdir: Path) -> list[Path]:
    """Figs. 5.38-5.41 into ``outdir``."""
    return [
        bode_figure(responses, "vcm_loop", "Fig. 5.38: VCM loop CV PV", outdir / "fig5_38.png"),
        bode_figure(responses, "pzt_loop", "Fig. 5.39: PZT loop CM PM", outdir / "fig5_39.png"),
        bode_figure(responses, "open_loop", "Fig. 5.40: DMS open loop LD", outdir / "fig5_40.png"),
        sensitivity_figure(responses, outdir / "fig5_41.png"),
    ]


@register("dual-stage", order=350)
def run(outdir: Path) -> CaseResult:
    """Table 5.4 book vs servokit and Figs. 5.38-5.41.

    Parameters
    ----------
    outdir : pathlib.Path
        Directory for the figures (must exist; :func:`servokit.cases.run_all` creates it).

    Returns
    -------
    CaseResult
        Per method, the controller orders (reproduced) and the Table 5.4 rows (for the
        phase method also the §5.5.2 peak-filter phases) computed with the :data:`FITTED`
        unknowns on the DMS structure with refined margins (fitted); Figs. 5.38-5.41;
        extras ``rows``, ``fitted_unknowns`` and ``runtime_s``.
    """
    import time

    t0 = time.perf_counter()
    rows, responses, comparisons = {}, {}, []
    for method in METHODS:
        u = _unknowns(method)
        rows[method] = evaluate_design(method, u, refine=True)
        responses[method] = design_responses(method, u, np.geomspace(10.0, 5.0e4, 4000))
        wide = None
        if method in JOINT_METHODS:
            wide = evaluate_design(method, joint_unknowns("outside"), refine=True)
        comparisons += _comparisons(method, rows[method], wide)
    figs = figures(responses, outdir)
    return CaseResult(
        "dual-stage",
        "Dual-stage DMS design example (Table 5.4, Figs. 5.38-5.41)",
        comparisons,
        figs,
        extra={
            "rows": {m: r.as_dict() for m, r in rows.items()},
            "fitted_unknowns": {**FITTED, **{m: JOINT_FIT["inside"] for m in JOINT_METHODS}},
            "joint_fit": JOINT_FIT,
            "max_gain_margin_db": MAX_GM_DB,
            "runtime_s": time.perf_counter() - t0,
        },
        chapter=5,
    )


# ------------------------------------------------------------------ §5.4: SSA
def _amd_figure(plant, cd, path: Path) -> Path:
    import control
    import matplotlib.pyplot as plt

    from servokit.models.frequency_grid import frequency_grid

    f = frequency_grid([plant, cd], 1e3, 3e4, 3000)
    s = 2j * np.pi * f
    p = lti_response(plant, s).ravel()
    damped = lti_response(control.feedback(plant, cd), s).ravel()
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    ax.semilogx(f, 20 * np.log10(np.abs(p)), label="PM (Table 5.3)")
    ax.semilogx(f, 20 * np.log10(np.abs(damped)), "--", label="PM / (1 + CD PM) (5.68)")
    title = "cf. Fig. 5.31: active mode damping (5.67) on the Table 5.3 PZT"
    return _finish(fig, ax, "magnitude [dB]", title, path)


def _adaptive_figure(run, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig, (ax_y, ax_v) = plt.subplots(2, 1, figsize=(7.5, 5.5), sharex=True)
    ax_y.plot(run.t * 1e3, run.y * 1e6, lw=0.8, label="tip displacement yM")
    ax_y.set(ylabel="yM [um]", title="Adaptive SSA control (5.73)-(5.75): run and V of (5.76)")
    ax_v.plot(run.t * 1e3, run.V / run.V[0], label="V / V(0)")
    ax_v.set(xlabel="time [ms]", ylabel="V / V(0) [1]")
    for ax in (ax_y, ax_v):
        ax.grid(True, alpha=0.3)
        ax.legend()
    return save_figure(fig, path)


@register("ssa", order=360)
def run_ssa(outdir: Path) -> CaseResult:
    """Self-sensing bridges (5.59)-(5.66), active mode damping (5.67)-(5.69) and the
    adaptive controller (5.73)-(5.78): identities and simulations (no printed numbers
    on these models besides the bridge gain 1/2 of (5.62))."""
    import time

    from servokit.feedback.adaptive import AdaptiveGains, cantilever_beam, simulate_adaptive
    from servokit.feedback.ssa import amd_controller, ddssa_bridge, idssa_bridge, mode_damping
    from servokit.models import pzt_active_suspension

    t0 = time.perf_counter()
    cp, w = 2e-9, 2j * np.pi * 1e3
    dd = ddssa_bridge(cp, cp, cp, cp)
    idb = idssa_bridge((cp,) * 4, cp, cp, (1e4,) * 4 + (1e3, 2e3, 2e3, 1e3))
    wc = 2j * np.pi * idb.fc_hz
    modes = [(5461, 2.0, 10.0), (6074, 2.0, 10.0), (9103, 2.0, 10.0)]
    plant, cd = pzt_active_suspension().to_statespace(), amd_controller(modes)
    amd = mode_damping(plant, cd, [m[0] for m in modes])
    run = simulate_adaptive(cantilever_beam(3), AdaptiveGains(), duration=2e-3, n_out=2000)
    # the same run without the adaptive strain term: how much the add-on contributes
    base = simulate_adaptive(
        cantilever_beam(3), AdaptiveGains(adaptive=False), duration=2e-3, n_out=2000
    )
    rows = [
        Comparison(
            "DDSSA balanced vs/vM (C1 = C2 = C3 = CPZT)",
            0.5,
            abs(complex(dd.from_vm(w))),
            rel_tol=1e-12,
            source="eq. (5.62)",
            note="printed as vM/2 (exact); bridge (5.59)-(5.61) with the uM sign of (5.61) "
            "corrected, checked against a nodal analysis in the tests",
        ),
        Comparison(
            "DDSSA balanced |vs/uM|",
            0.0,
            abs(complex(dd.from_um(w))),
            rel_tol=1e-12,
            source="eq. (5.62)",
            kind="consistency",
        ),
        Comparison(
            "IDSSA balanced |vS/vM| at fc / (k / 2 zeta)",
            1.0,
            abs(complex(idb.from_vm(wc))) * 2 * idb.damping / idb.gain,
            rel_tol=1e-9,
            source="eq. (5.66)",
            kind="consistency",
            note="(5.63)-(5.64) with (5.65) give the high-pass (5.66)",
        ),
        Comparison(
            "adaptive: largest relative increase of V",
            0.0,
            run.max_increase(),
            rel_tol=1e-9,
            source="eq. (5.78)",
            kind="consistency",
            note="modal cantilever, first mode 5.4 kHz (Fig. 5.33); assumed gains",
        ),
    ]
    figs = [
        _amd_figure(plant, cd, outdir / "fig5_31_amd.png"),
        _adaptive_figure(run, outdir / "ssa_adaptive.png"),
    ]
    return CaseResult(
        "ssa",
        "Self-sensing actuation, active mode damping, adaptive control (§5.4)",
        rows,
        figs,
        extra={
            "amd_modes_hz": amd.freq_hz,
            "amd_attenuation_db": amd.attenuation_db,
            "amd_stable": amd.stable,
            "adaptive_amplitude_ratio": run.amplitude_ratio(),
            "pi_only_amplitude_ratio": base.amplitude_ratio(),
            "runtime_s": time.perf_counter() - t0,
        },
        chapter=5,
    )
