"""``servokit dual-stage``: the §5.5.2 dual-stage design, one Table 5.4 column."""

from __future__ import annotations

from dataclasses import replace
from typing import Annotated

import numpy as np
import typer
from rich.table import Table

from servokit.cli._app import (
    JsonOpt,
    PlotOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    plot_target,
    progress,
    wrote,
)
from servokit.cli._options import refuse_inapplicable
from servokit.errors import ServokitValueError, check_count

#: Unknowns field -> the flag that sets it
_FLAGS = {
    "notch_damping": "--notch-damping",
    "notch_depth_damping": "--notch-depth-damping",
    "notch_freq_ratio": "--notch-freq-ratio",
    "extra_notch_depth_damping": "--extra-notch-depth-damping",
    "pair_pole_damping": "--pair-pole-damping",
    "kcv_phase": "--kcv-phase",
    "kcm_phase": "--kcm-phase",
    "delay_vcm_s": "--delay-vcm",
    "delay_pzt_s": "--delay-pzt",
}

_HELP = """The DMS dual-stage HDD design example of book §5.5.2 (VCM of Table 5.1, PZT of
Table 5.3) with gain stabilisation, inverse compensation or phase stabilisation, and the
Table 5.4 row it gives (hand-off, crossover, margins, ||S||inf, controller orders).
Unstated parameters default to the values fitted to Table 5.4 (--fit searches again).
JSON keys: structure, method, unknowns, row (order_cv, order_cm, handoff_hz,
phase_difference_deg, crossover_hz, gain_margin_db, phase_margin_deg, s_inf_db,
second_phase_margin_deg), book (the printed row), plot."""


def _unknowns(method: str, overrides: dict[str, float | None]):
    """The fitted unknowns of ``method`` with the flags the user gave (errors name flags)."""
    from servokit.feedback.dual_stage_fitted import fitted_unknowns

    chosen = {k: v for k, v in overrides.items() if v is not None}
    with flag_names(_FLAGS):  # whole names only (notch_depth_damping in extra_...)
        return replace(fitted_unknowns(method), **chosen)


def _check_choices(method: str, structure: str, maxiter: int) -> None:
    from servokit.feedback.dual_stage import STRUCTURES
    from servokit.feedback.dual_stage_design import METHODS

    if method not in METHODS:
        raise ServokitValueError(f"--method must be one of {', '.join(METHODS)} (got {method!r})")
    if structure not in STRUCTURES:
        raise ServokitValueError(
            f"--structure must be one of {', '.join(STRUCTURES)} (got {structure!r})"
        )
    check_count("--maxiter", maxiter, lo=1, hi=1000)
    refuse_inapplicable("--method", method, _METHOD_APPLIES)


#: the unknowns that enter one method's controllers only (given with another: refused)
_METHOD_APPLIES = {
    "kcv_phase": ("--kcv-phase", ("phase",)),
    "kcm_phase": ("--kcm-phase", ("phase",)),
    "pair_pole_damping": ("--pair-pole-damping", ("inverse",)),
}


def _render(method: str, structure: str, u, row, target, json_out: bool) -> None:  # noqa: ANN001
    """Figure (Fig. 5.40), JSON or the Table 5.4 column of a dual-stage design."""
    from servokit.feedback.dual_stage_design import BOOK_TABLE_5_4, design_responses

    if target is not None:
        from servokit.feedback.dual_stage_plots import bode_figure

        r = design_responses(method, u, np.geomspace(10.0, 5.0e4, 4000), structure)
        title = f"Fig. 5.40: {structure.upper()} open loop LD"
        wrote(bode_figure({method: r}, "open_loop", title, target))
    book = BOOK_TABLE_5_4[method]
    if json_out:
        emit_json(
            {
                "structure": structure,
                "method": method,
                "unknowns": u.__dict__,
                "row": row.as_dict(),
                "book": {k: float(v) for k, v in book.items()},
                "plot": str(target) if target else None,
            }
        )
        return
    _print_row(row, book, u, structure)


def _fit(method: str, start, maxiter: int):
    """Search the unknowns the reproduce case searched (FIT_FREE), the others held."""
    from servokit.feedback.dual_stage_design import fit_unknowns
    from servokit.feedback.dual_stage_fitted import FIT_FREE

    with progress(maxiter, f"searching the unknowns of the {method} design") as advance:
        res = fit_unknowns(
            method, free=FIT_FREE[method], start=start, maxiter=maxiter, on_generation=advance
        )
    return res.unknowns


def _print_row(row, book: dict[str, str], u, structure: str) -> None:
    table = Table(title=f"Table 5.4, {row.method} ({structure.upper()})")
    for col in ("quantity", "book", "servokit"):
        table.add_column(col, justify="right")
    for key, value in row.as_dict().items():
        if key == "method":
            continue
        shown = f"{value:.4g}" if isinstance(value, float) else str(value)
        table.add_row(key, book.get(key, "-"), shown)
    console.print(table)
    console.print("unknowns: " + ", ".join(f"{k} = {v:.4g}" for k, v in u.__dict__.items()))


@app.command(
    "dual-stage",
    help=_HELP,
    epilog=example(
        "servokit dual-stage --method inverse --json",
        "servokit dual-stage --method phase --plot ds.png",
    ),
)
def dual_stage_cmd(
    method: Annotated[
        str, typer.Option("--method", help="gain | inverse | phase (resonance compensation)")
    ] = "gain",
    structure: Annotated[
        str,
        typer.Option("--structure", help="parallel | cms | dms (the book's Table 5.4 uses dms)"),
    ] = "dms",
    notch_damping: Annotated[
        float | None,
        typer.Option("--notch-damping", help="notch pole damping zeta_D of (5.14) [1]"),
    ] = None,
    notch_depth_damping: Annotated[
        float | None,
        typer.Option(
            "--notch-depth-damping", help="notch zero damping [1] (0: the mode's damping)"
        ),
    ] = None,
    notch_freq_ratio: Annotated[
        float | None,
        typer.Option("--notch-freq-ratio", help="notch pole frequency fD / fR of (5.14) [1]"),
    ] = None,
    extra_notch_depth_damping: Annotated[
        float | None,
        typer.Option(
            "--extra-notch-depth-damping",
            help="zero damping of notches at no tabulated mode (3800, 13120 Hz) [1]",
        ),
    ] = None,
    pair_pole_damping: Annotated[
        float | None,
        typer.Option(
            "--pair-pole-damping",
            help="pole damping of inverse pairs at no model zero (4775, 9549 Hz) [1]",
        ),
    ] = None,
    kcv_phase: Annotated[
        float | None,
        typer.Option("--kcv-phase", help="KCV of the phase-stabilised VCM controller [1]"),
    ] = None,
    kcm_phase: Annotated[
        float | None,
        typer.Option("--kcm-phase", help="KCM of the phase-stabilised PZT controller [1]"),
    ] = None,
    delay_vcm: Annotated[
        float | None, typer.Option("--delay-vcm", help="VCM input delay [s]")
    ] = None,
    delay_pzt: Annotated[
        float | None, typer.Option("--delay-pzt", help="PZT input delay [s]")
    ] = None,
    fit: Annotated[
        bool,
        typer.Option(
            "--fit",
            help="search the unknowns again (differential evolution, ~1 min); the plant "
            "delays are searched with --method inverse and held otherwise",
        ),
    ] = False,
    maxiter: Annotated[
        int, typer.Option("--maxiter", help="generations of the --fit search [count]")
    ] = 60,
    json_out: JsonOpt = False,
    plot: PlotOpt = None,
) -> None:
    from servokit.feedback.dual_stage_design import DEFAULT_GRID_HZ, evaluate_design

    _check_choices(method, structure, maxiter)
    target = plot_target(plot)
    u = _unknowns(
        method,
        dict(
            notch_damping=notch_damping,
            notch_depth_damping=notch_depth_damping,
            notch_freq_ratio=notch_freq_ratio,
            extra_notch_depth_damping=extra_notch_depth_damping,
            pair_pole_damping=pair_pole_damping,
            kcv_phase=kcv_phase,
            kcm_phase=kcm_phase,
            delay_vcm_s=delay_vcm,
            delay_pzt_s=delay_pzt,
        ),
    )
    if fit:
        u = _fit(method, u, maxiter)
    row = evaluate_design(method, u, DEFAULT_GRID_HZ, structure, refine=True)
    _render(method, structure, u, row, target, json_out)
