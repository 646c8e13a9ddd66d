"""``servokit loopshape``: a fixed-structure controller from the measured FRFs of a plant set."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    PlotOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_controller,
    load_plant,
    plot_target,
    progress_line,
    progress_wanted,
    started,
    warn,
    wrote,
)
from servokit.cli._options import given_on_command_line, refuse_inapplicable
from servokit.errors import (
    ServokitValueError,
    check_count,
    check_input_file,
    check_out_dir,
    check_positive,
)

CONTROLLER_FILE = "controller.toml"
#: JSON keys of ``servokit loopshape --json`` (documented in its help)
JSON_KEYS = (
    "controller_file, structure, order, dt_s, s_max_db, design_time_s, notes, "
    "model_spectral_radii (with --plant, else null), initial {summary}, "
    "summary {n_plants, min_crossover_hz, max_crossover_hz, worst_s_peak_db, "
    "worst_phase_margin_deg, worst_gain_margin_db, all_stable, n_unstable}, plants [{plant, "
    "crossover_hz, phase_margin_deg, gain_margin_db, delay_margin_s, s_peak_db, t_peak_db, "
    "stable, unstable_poles, resolved}], history, plot"
)
_FLAGS = {
    "dt": "--dt",
    "s_max_db": "--s-max-db",
    "order": "--order",
    "t_max_db": "--t-max-db",
    "time_limit_s": "--time-limit",
    "keep_low_gain": "--keep-low-gain",
    "lowpass_hz": "--lowpass",
    "freq_hz": "FRF_FILE",
    # the library asks for its parameter `initial`; the user gives it as --controller
    "a stabilising initial controller": "a stabilising initial controller (--controller)",
}


def _read_set(files: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Read every FRF file; they must share one frequency grid."""
    from servokit.models import read_frf

    if not files:
        raise ServokitValueError("FRF_FILE: give at least one FRF file")
    f0, rows = None, []
    for name in files:
        if not name.strip():
            raise ServokitValueError("FRF_FILE '': give the path of an FRF file")
        check_input_file(name, "FRF_FILE")
        with flag_names({}, prefix="FRF_FILE: "):
            f, r = read_frf(name)
        if f0 is None:
            f0 = f
        elif f.shape != f0.shape or not np.allclose(f, f0, rtol=1e-9, atol=0):
            raise ServokitValueError(
                f"FRF_FILE {name}: its frequency grid differs from {files[0]}'s; "
                "measure (or interpolate) every FRF on one grid"
            )
        rows.append(r)
    return np.asarray(f0), np.vstack(rows)


def _notches(values: list[str]) -> tuple[tuple[float, float], ...] | None:
    if not values:
        return None
    out = []
    for v in values:
        parts = v.split(":")
        try:
            f, z = float(parts[0]), float(parts[1]) if len(parts) == 2 else float("x")
        except (ValueError, IndexError):
            raise ServokitValueError(
                f"--notch {v!r}: give FREQ_HZ:DAMPING, e.g. 4100:0.2"
            ) from None
        out.append(
            (check_positive("--notch FREQ_HZ", f, "Hz"), check_positive("--notch DAMPING", z))
        )
        if z > 1:  # a percentage typed for a ratio would pass as a wide pair of real poles
            raise ServokitValueError(
                f"--notch {v!r}: DAMPING {z:g} is above 1 (two real poles, not a notch); "
                "the damping is a ratio, e.g. 20 % is 0.2 (real poles: --lowpass HZ)"
            )
    return tuple(out)


def _check_numbers(
    s_max_db: float, time_limit: float, keep_low_gain: float, t_max_db: float | None
) -> None:
    check_positive("--s-max-db", s_max_db, "dB")
    if t_max_db is not None:  # |T| is 0 dB wherever |L| is large
        check_positive("--t-max-db", t_max_db, "dB")
    check_positive("--time-limit", time_limit, "s")
    if not 0.0 <= keep_low_gain <= 1.0:
        raise ServokitValueError(f"--keep-low-gain must be in [0, 1] (got {keep_low_gain})")


#: flags that shape only one structure (given with the other they are refused)
_STRUCTURE_APPLIES = {
    "notch": ("--notch", ("pid-notch",)),
    "lowpass": ("--lowpass", ("pid-notch",)),
}


def _structure(structure: str, order: int | None) -> tuple[str, int | None]:
    """``--order N`` implies ``--structure order``; ``order`` needs ``--order``."""
    if structure not in ("pid-notch", "order"):
        raise ServokitValueError(f"--structure must be pid-notch or order (got {structure!r})")
    if order is not None:
        if given_on_command_line("structure") and structure != "order":
            raise ServokitValueError(
                f"--order applies only to --structure order, not {structure}; drop --order"
            )
        return "order", check_count("--order", order, lo=1, hi=40)
    if structure == "order":
        raise ServokitValueError("--structure order needs --order COUNT (controller states)")
    return structure, None


def _print(res: Any) -> None:
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(f"loopshape: {res.structure.name}"))
    for col in (
        "plant",
        "crossover [Hz]",
        "PM [deg]",
        "GM [dB]",
        "delay margin [us]",
        "||S||inf [dB]",
        "stable",
    ):
        table.add_column(escape(col), justify="right")
    for d in res.table.to_dicts():
        table.add_row(
            d["plant"],
            f"{d['crossover_hz']:.1f}",
            f"{d['phase_margin_deg']:.1f}",
            f"{d['gain_margin_db']:.2f}",
            f"{d['delay_margin_s'] * 1e6:.1f}",
            f"{d['s_peak_db']:.2f}",
            "yes" if d["stable"] else "NO",
        )
    console.print(table)
    a, b = res.initial_table, res.table
    console.print(
        f"lowest crossover {a.min_crossover_hz:.1f} -> {b.min_crossover_hz:.1f} Hz, worst "
        f"||S||inf {a.worst_s_peak_db:.3f} -> {b.worst_s_peak_db:.3f} dB, worst PM "
        f"{b.worst_phase_margin_deg:.1f} deg, {len(b.rows)} plants "
        f"{'all stable' if b.all_stable else 'NOT all stable'}, "
        f"{len(res.history) - 1} steps in {res.design_time_s:.1f} s"
    )


@app.command(
    "loopshape",
    epilog=example(
        "servokit loopshape examples/data/stage_frf.csv --dt 2.5e-5 --order 4 --out ctrl",
        "servokit loopshape p1.csv p2.csv --dt 3.7879e-5 --order 12 --out ctrl --plot loops.png",
    )
    + "\n\nWrites OUT/controller.toml (read by every --controller).  JSON: "
    + JSON_KEYS
    + ".",
)
def loopshape_cmd(
    frf_files: Annotated[
        list[str],
        typer.Argument(
            help="measured discrete-time FRFs of the plant set, one grid (.csv/.npz/.mat)",
            metavar="FRF_FILE...",
        ),
    ],
    dt: Annotated[float, typer.Option("--dt", help="controller sampling period [s]")],
    out: Annotated[
        str, typer.Option("--out", help="directory to write controller.toml into", metavar="DIR")
    ],
    s_max_db: Annotated[float, typer.Option("--s-max-db", help="bound on ||S||inf [dB]")] = 6.0,
    structure: Annotated[
        str, typer.Option("--structure", help="pid-notch (fixed denominators) or order (general)")
    ] = "pid-notch",
    order: Annotated[
        int | None, typer.Option("--order", help="controller states of --structure order [count]")
    ] = None,
    notch: Annotated[
        list[str] | None,
        typer.Option(
            "--notch",
            help="notch poles of pid-notch (repeatable; default: FRF peaks)",
            metavar="FREQ_HZ:DAMPING",
        ),
    ] = None,
    lowpass: Annotated[
        list[float] | None,
        typer.Option(
            "--lowpass", help="low-pass / lead pole corner of pid-notch [Hz] (repeatable)"
        ),
    ] = None,
    t_max_db: Annotated[
        float | None, typer.Option("--t-max-db", help="bound on ||T||inf [dB]")
    ] = None,
    models: Annotated[
        list[str] | None,
        typer.Option(
            "--plant",
            help="models of the plant set (e.g. from servokit fit; repeatable): the designed "
            "controller's exact closed loops (ZOH + delay) are checked",
            metavar="NAME_OR_TOML",
        ),
    ] = None,
    controller: Annotated[
        str | None,
        typer.Option(
            "--controller",
            help="stabilising initial controller (book name or .toml)",
            metavar="NAME_OR_TOML",
        ),
    ] = None,
    keep_low_gain: Annotated[
        float,
        typer.Option(
            "--keep-low-gain",
            help="keep |L| >= this x the initial |L| below its crossover (0: off) [1]",
        ),
    ] = 0.9,
    time_limit: Annotated[
        float, typer.Option("--time-limit", help="wall time after which no new step starts [s]")
    ] = 100.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Maximise the lowest crossover over the FRFs under ||S||inf <= --s-max-db, stability
    certified on every FRF (convex-concave iteration, Karimi & Kammer 2017)."""
    from servokit.feedback import loopshape
    from servokit.models import save_controller

    plot = plot_target(plot)
    dt = check_positive("--dt", dt, "s")
    outdir = check_out_dir(out)
    structure, order = _structure(structure, order)
    refuse_inapplicable("--structure", structure, _STRUCTURE_APPLIES)
    _check_numbers(s_max_db, time_limit, keep_low_gain, t_max_db)
    notches = _notches(notch or [])
    lp = tuple(check_positive("--lowpass", v, "Hz") for v in (lowpass or []))
    init = None if controller is None else load_controller(controller, dt)
    plants = [load_plant(m) for m in models or []]
    f, P = _read_set(frf_files)
    names = tuple(Path(n).stem for n in frf_files)
    _announce(f, P, dt, order, time_limit, outdir / CONTROLLER_FILE)
    with flag_names(_FLAGS):
        res = loopshape(
            f, P, dt, s_max_db=s_max_db, structure=structure, order=order, notches=notches,
            lowpass_hz=lp, t_max_db=t_max_db, initial=init, time_limit_s=time_limit,
            keep_low_gain=keep_low_gain or None, names=names,
            progress=_step_lines() if progress_wanted() else None,
        )  # fmt: skip
    outdir.mkdir(parents=True, exist_ok=True)
    path = outdir / CONTROLLER_FILE
    save_controller(res.controller, path)
    wrote(path)
    if plot is not None:
        wrote(_plot(res, f, P, dt, s_max_db, plot))
    radii = _certify(res.controller, plants)
    if json_out:
        emit_json(_data(res, path, dt, s_max_db, plot) | {"model_spectral_radii": radii})
        return
    _print(res)
    _print_certificate(radii, models or [])
    for note in res.notes:
        console.print(f"note: {note}")


def _announce(
    f: np.ndarray, P: np.ndarray, dt: float, order: int | None, time_limit: float, path: Path
) -> None:
    """The FRF grid's checks, then the start line (a refused grid prints one error line)."""
    from servokit.feedback.loopshape_problem import check_frf_set

    with flag_names(_FLAGS):
        check_frf_set(f, P, dt)
    started(
        "loopshape",
        f"{'pid-notch' if order is None else f'order-{order}'} controller for {P.shape[0]} "
        f"FRF(s) of {P.shape[-1]} points, at most {time_limit:g} s -> {path}",
    )


def _step_lines(every_s: float = 1.0) -> Callable[[dict], None]:
    """A progress line per accepted step of the iteration, at most one per ``every_s``."""
    import time

    last = [time.monotonic()]

    def line(entry: dict) -> None:
        if time.monotonic() - last[0] < every_s:
            return
        last[0] = time.monotonic()
        progress_line(
            "loopshape",
            f"step {entry['iteration'] + 1} (phase {entry['phase']}): lowest crossover "
            f"{entry['min_crossover_hz']:.1f} Hz, worst |S| {entry['worst_s_peak_db']:.2f} dB",
        )

    return line


def _plot(res: Any, f: np.ndarray, P: np.ndarray, dt: float, s_max_db: float, plot: Path):
    from servokit.feedback.loopshape_plots import loopshape_plot

    z = np.exp(2j * np.pi * f * dt)
    k = np.asarray(res.controller(z)).ravel()
    return loopshape_plot(
        f,
        P,
        {f"loopshape ({res.structure.name})": k},
        s_max_db=s_max_db,
        path=plot,
        title=f"FRF-set loop shaping, {P.shape[0]} plant{'' if P.shape[0] == 1 else 's'}",
    )


def _certify(controller: Any, plants: list) -> list[float] | None:
    """Largest closed-loop pole modulus of each model with the designed controller."""
    if not plants:
        return None
    from servokit.feedback import certify_models

    return [float(r) for r in certify_models(controller, plants)[0]]


def _print_certificate(radii: list[float] | None, names: list[str]) -> None:
    if radii is None:
        return
    for name, r in zip(names, radii, strict=True):
        verdict = "stable" if r < 1.0 else "UNSTABLE"
        console.print(f"model {name}: largest closed-loop pole |z| = {r:.6f} ({verdict})")
    if max(radii) >= 1.0:
        warn("a model's exact closed loop is unstable: the FRF certificate does not hold on it")


def _data(res: Any, path: Path, dt: float, s_max_db: float, plot: Path | None) -> dict:
    return {
        "controller_file": str(path),
        "structure": res.structure.name,
        "order": res.structure.order,
        "dt_s": dt,
        "s_max_db": s_max_db,
        "design_time_s": res.design_time_s,
        "notes": res.notes,
        "initial": res.initial_table.summary(),
        "summary": res.table.summary(),
        "plants": res.table.to_dicts(),
        "history": res.history,
        "plot": str(plot) if plot else None,
    }
