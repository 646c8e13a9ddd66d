"""``servokit identify``: a continuous plant identified above the Nyquist frequency from a
simulated closed-loop measurement (book §5.2.1.2)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    ControllerOpt,
    JsonOpt,
    MaxMemoryOpt,
    PlantOpt,
    PlotOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_plant,
    plot_target,
    progress,
    wrote,
)
from servokit.cli._options import (
    check_state_size,
    controller_states,
    discrete_states,
    load_controller_data,
    old_name,
    renamed,
)
from servokit.errors import ServokitValueError, check_finite, check_positive, check_work

#: Most excitation frequencies ``identify`` accepts (~40 ms each: about an hour).
_IDENTIFY_MAX_FREQ = 100_000


@app.command(
    "identify",
    epilog=example(
        "servokit identify --plant vcm-dual-stage --controller table-5.2 "
        "--fmax 60e3",
        "servokit identify --plant pzt-active-suspension --loop-plant vcm-dual-stage "
        "--controller table-5.2 --json",
    ),
    help="Identify a continuous plant above the Nyquist frequency from a simulated"
    " closed-loop measurement (book §5.2.1.2, eqs. 5.10-5.11): Sd measured with a T-held"
    " sinusoid, the plant with a sinusoid held at T/--substeps. Frequencies whose alias is 0"
    " or Nyquist are excluded. JSON keys: plant, controller, fs_hz, freq_hz, aliased_hz,"
    " magnitude_db, phase_deg, sd_magnitude_db, sd_phase_deg, excluded_hz, dt_s,"
    " max_error_db, max_error_deg (against the plant model).",
)
def identify_cmd(
    plant: PlantOpt,
    controller: ControllerOpt,
    dt: Annotated[
        float | None, typer.Option("--dt", help="PES sampling period [s] (default 1/30 kHz)")
    ] = None,
    fs_old: old_name("--fs") = None,
    fmin: Annotated[float, typer.Option("--fmin", help="first excitation frequency [Hz]")] = 50.0,
    fmax: Annotated[float, typer.Option("--fmax", help="last excitation frequency [Hz]")] = 60e3,
    step: Annotated[float, typer.Option("--freq-step", help="excitation spacing [Hz]")] = 50.0,
    loop_plant: Annotated[
        str | None,
        typer.Option("--loop-plant", help="actuator the loop is closed around, if not --plant"),
    ] = None,
    substeps: Annotated[
        int, typer.Option("--substeps", help="excitation steps per PES period", min=1)
    ] = 12,
    max_memory_mb: MaxMemoryOpt = 2000.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    target = plot_target(plot)
    fs, typed = _identify_rate(dt, fs_old)
    freq = _excitation_grid(fmin, fmax, step)
    p = load_plant(plant)
    lp = None if loop_plant is None else load_plant(loop_plant, "--loop-plant")
    ctrl = _identify_controller(controller, fs, typed)
    for flag, name, q in (("--plant", plant, p), ("--loop-plant", loop_plant, lp)):
        if q is not None:  # simulated at T/--substeps: the plant's model at that step
            n_states = discrete_states(q, 1.0 / (fs * substeps), controller_states(ctrl))
            check_state_size(n_states, what=f"{flag} {name}", max_memory_mb=max_memory_mb)
    res = _identify(p, ctrl, freq, substeps, max_memory_mb, lp)
    _identify_render(res, p, controller, fs, (fmin, fmax), target, json_out)


def _identify_rate(dt: float | None, fs_old: float | None) -> tuple[float, str]:
    """The PES sampling rate [Hz] from --dt (or the deprecated --fs) and how it was typed."""
    if fs_old is not None:
        check_positive("--fs", fs_old, "Hz")
        dt = renamed(dt, 1.0 / fs_old, new_flag="--dt", old_flag="--fs")
    fs = 1.0 / check_positive("--dt", 1.0 / 30e3 if dt is None else dt, "s")
    return fs, (f"--fs {fs:g} Hz" if fs_old is not None else f"--dt {1 / fs:g} s")


def _excitation_grid(fmin: float, fmax: float, step: float) -> np.ndarray:
    """The excitation frequencies [Hz], refused before any work when there are too many."""
    from servokit.sampled.identification import excitation_frequencies

    check_finite("--fmin/--fmax/--freq-step", [fmin, fmax, step])
    if not 0 < fmin <= fmax or step <= 0:
        raise ServokitValueError(
            f"need 0 < --fmin <= --fmax and --freq-step > 0 (got {fmin}, {fmax}, {step})"
        )
    n_exc = np.floor((fmax - fmin) / step + 1e-9) + 1
    # about 40 ms per frequency (1200 frequencies of the default take ~50 s)
    check_work(
        n_exc,
        what=f"--fmin {fmin:g} --fmax {fmax:g} --freq-step {step:g} ({n_exc:.3g} frequencies)",
        limit=_IDENTIFY_MAX_FREQ,
        about="about an hour",
    )
    return excitation_frequencies(fmin, fmax, step)


def _identify_controller(controller: str, fs: float, typed: str) -> Any:
    """The controller at the PES period 1/fs; a period it cannot take names the flag typed
    (numpy coefficients: python-control left unloaded, issue 23)."""
    from servokit.models import get_discrete_rational

    load_controller_data(controller)  # an unknown name or a bad file names --controller
    try:
        return get_discrete_rational(controller, dt=1.0 / fs)
    except ServokitValueError as exc:
        raise ServokitValueError(f"{typed}: {exc}") from None


def _identify(p: Any, ctrl: Any, freq: np.ndarray, substeps: int, max_mb: float, lp: Any) -> Any:
    """:func:`~servokit.sampled.identification.identify_above_nyquist` with a progress bar."""
    from servokit.sampled.identification import identify_above_nyquist

    chunk = 150
    n_chunks = int(np.ceil(freq.size / chunk))
    with progress(n_chunks, "identifying", enabled=freq.size > chunk) as tick:
        with flag_names({"substeps": "--substeps", "freq_hz": "--fmin/--fmax"}):
            return identify_above_nyquist(
                p, ctrl, freq, substeps=substeps, chunk=chunk, max_memory_mb=max_mb,
                loop_plant=lp, progress=lambda n: tick(1),
            )  # fmt: skip


def _identify_render(
    res: Any, p: Any, controller: str, fs: float, span: tuple[float, float],
    target: Path | None, json_out: bool,
) -> None:  # fmt: skip
    """Figure, JSON or the per-band error table of an identification."""
    from servokit.sampled.identification import identification_plot

    true = p.freqresp(res.freq_hz)
    db, deg = res.errors(true)
    if target is not None:
        title = f"{p.name} identified from PES sampled at {fs:g} Hz"
        wrote(identification_plot(res, true, path=str(target), title=title))
    if json_out:
        emit_json({
            "plant": p.name, "controller": controller, "fs_hz": fs,
            "max_error_db": float(np.max(np.abs(db))),
            "max_error_deg": float(np.max(np.abs(deg))), **res.to_dict(),
        })  # fmt: skip
        return
    f, (fmin, fmax) = res.freq_hz, span
    excluded = ", ".join(f"{x:g}" for x in res.excluded_hz) or "none"
    console.print(
        f"{p.name}: {f.size} frequencies {fmin:g}-{fmax:g} Hz identified at "
        f"fs = {fs:g} Hz; excluded {excluded} Hz"
    )
    for lo, hi in ((0, fs / 2), (fs / 2, fs), (fs, 1.5 * fs), (1.5 * fs, np.inf)):
        band = (f > lo) & (f <= hi)
        if band.any():
            console.print(
                f"  {lo:8.0f}-{min(hi, fmax):8.0f} Hz: max error "
                f"{np.max(np.abs(db[band])):.3g} dB, {np.max(np.abs(deg[band])):.3g} deg"
                " against the model"
            )
