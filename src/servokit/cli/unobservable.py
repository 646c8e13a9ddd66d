"""``servokit unobservable``: unobservable magnitudes of oscillations (book §4.3, §4.5.3)."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from servokit.cli._app import (
    DampingOpt,
    DtOpt,
    FreqOpt,
    JsonOpt,
    MaxMemoryOpt,
    PlotOpt,
    console,
    emit_json,
    example,
    flag_names,
    plot_target,
    progress,
    sub_app,
    wrote,
)
from servokit.cli._options import old_name, renamed
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
    check_range,
    check_work,
)

unobservable_app = sub_app(
    "unobservable", "Unobservable magnitude of oscillations between samples (eqs. 4.39-4.52)."
)

_FLAGS = {
    "freq_hz": "--freq",
    "dt": "--dt",
    "damping": "--damping",
    "n_samples": "--n-samples",
    "max_samples": "--n-samples-max",
    "level": "--level",
    "fs_range": "--dt-min/--dt-max",
}
# phase-sample evaluations (exp, sin) one request may cost: 2.5e7 per CPU second measured,
# so about twenty seconds
MAX_PHASE_CELLS = 5e8
_PHASES_MAGNITUDE = 720  # phase grid of `magnitude` (library default)
_PHASES_SCAN = 360  # phase grid of `sampling` and `time`
_SCAN_POINTS = 3000  # sampling-frequency grid of `sampling` (library default)
_PLOT_POINTS = 1500
_ARRAYS_PER_CELL = 3  # s, yd and a temporary per phase-sample cell
LevelOpt = Annotated[float, typer.Option("--level", help="acceptable yui [1]")]


def _check_work(n_samples: int, cells: float, flag: str, max_memory_mb: float) -> None:
    """Refuse a request whose largest block or total phase-sample work is too large."""
    check_memory(
        _PHASES_MAGNITUDE * n_samples * _ARRAYS_PER_CELL * 8,
        what=f"{flag} {n_samples}",
        max_memory_mb=max_memory_mb,
    )
    check_work(
        cells, what=f"{flag} {n_samples}", limit=MAX_PHASE_CELLS, about="about twenty seconds"
    )


def _common(freq: float, damping: float) -> None:
    check_positive("--freq", freq, "Hz")
    z = float(check_finite("--damping", damping))
    if not 0 <= z < 1:
        raise ServokitValueError(f"--damping must lie in [0, 1) (got {z:g})")


def _check_level(level: float) -> None:
    if not (float(check_finite("--level", level)) > 0):
        raise ServokitValueError(f"--level must be > 0 (got {level:g})")


@unobservable_app.command(
    "magnitude",
    epilog=example("servokit unobservable magnitude --freq 4000 --dt 25e-6 --json")
    + "\n\nJSON: freq_hz, dt_s, damping, n_samples, worst, worst_sampling_phase, minimum, "
    "minimum_sampling_phase, rms, histogram_edges, histogram_percent, plot (sampling phases "
    "as a fraction of --dt).",
)
def magnitude_cmd(
    freq: FreqOpt,
    dt: DtOpt,
    damping: DampingOpt = 0.0,
    n_samples: Annotated[
        int | None,
        typer.Option("--n-samples", help="judgement samples Ns [count] (omit: steady state)"),
    ] = None,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """yu over the sampling phase, worst case yuw (4.42)/(4.51) and RMS index yui (4.52)."""
    _common(freq, damping)
    check_positive("--dt", dt, "s")
    if n_samples is not None:
        ns = check_count("--n-samples", n_samples)
        _check_work(ns, _PHASES_MAGNITUDE * ns, "--n-samples", max_memory_mb)
    plot = plot_target(plot)
    from servokit.sampled.unobservable import unobservable_magnitude

    with flag_names(_FLAGS):
        r = unobservable_magnitude(freq, dt, damping=damping, n_samples=n_samples)
    _magnitude_render(r, freq, dt, damping, n_samples, plot, json_out)


def _magnitude_render(
    r: Any, freq: float, dt: float, damping: float, n_samples: int | None, plot: Any,
    json_out: bool,
) -> None:  # fmt: skip
    """Figure, JSON or one line of an unobservable magnitude."""
    from servokit.sampled.unobservable import unobservable_plot

    edges, pct = r.histogram(0.1)
    out = {
        "freq_hz": freq,
        "dt_s": dt,
        "damping": damping,
        "n_samples": n_samples,
        "worst": float(r.worst),
        "worst_sampling_phase": float(r.worst_delta_s),
        "minimum": float(r.minimum),
        "minimum_sampling_phase": float(r.minimum_delta_s),
        "rms": float(r.rms),
        "histogram_edges": edges,
        "histogram_percent": pct,
        "plot": str(plot) if plot else None,
    }
    if plot is not None:
        unobservable_plot(
            r.delta_s,
            {"yu": r.yu},
            xlabel="Sampling phase delta_s [-]",
            ylabel="yu [-]",
            title=f"yu at {freq:g} Hz, tau = {dt:g} s",
            path=plot,
        )
        wrote(plot)
    if json_out:
        emit_json(out)
        return
    console.print(
        f"yuw = {out['worst']:.4g} (delta_s = {out['worst_sampling_phase']:.4g}), "
        f"min yu = {out['minimum']:.4g} (delta_s = {out['minimum_sampling_phase']:.4g}), "
        f"yui = {out['rms']:.4g}"
    )


def _sampling_range(
    freq: float, dt_min: float, dt_max: float, fs_min: float | None, fs_max: float | None
) -> tuple[float, float]:
    """The scanned sampling-frequency range [Hz] from --dt-min/--dt-max (0: automatic), or
    from the deprecated --fs-min/--fs-max [Hz]."""
    if fs_min is not None or fs_max is not None:
        old = (fs_min or 0.0, fs_max or 0.0)
        check_finite("--fs-min/--fs-max", old)
        renamed(0.0, 0.0, new_flag="--dt-min/--dt-max", old_flag="--fs-min/--fs-max", default=0.0)
        return check_range(old[0] or freq / 5, old[1] or freq * 4, ("--fs-min", "--fs-max"))
    check_finite("--dt-min/--dt-max", [dt_min, dt_max])
    if dt_min < 0 or dt_max < 0 or (dt_min and dt_max and not dt_min < dt_max):
        raise ServokitValueError(
            f"need 0 < --dt-min < --dt-max [s] (0: automatic; got {dt_min:g}, {dt_max:g})"
        )
    hi = 1.0 / dt_min if dt_min else freq * 4
    lo = 1.0 / dt_max if dt_max else freq / 5
    if not lo < hi:
        raise ServokitValueError(
            f"--dt-min/--dt-max give an empty range {lo:g}..{hi:g} Hz; widen them"
        )
    return lo, hi


@unobservable_app.command(
    "sampling",
    epilog=example("servokit unobservable sampling --freq 4000 --damping 0.01 --n-samples 10")
    + "\n\nJSON: freq_hz, damping, n_samples, level, fs_range_hz, intervals [{low_hz, high_hz, "
    "peak_hz, peak_rms}], plot.",
)
def sampling_cmd(
    freq: FreqOpt,
    damping: DampingOpt = 0.01,
    n_samples: Annotated[
        int, typer.Option("--n-samples", help="judgement samples Ns [count]")
    ] = 10,
    level: LevelOpt = 0.1,
    dt_min: Annotated[
        float, typer.Option("--dt-min", help="shortest sampling period [s] (0: 1/(4 freq))")
    ] = 0.0,
    dt_max: Annotated[
        float, typer.Option("--dt-max", help="longest sampling period [s] (0: 5/freq)")
    ] = 0.0,
    fs_min: old_name("--fs-min") = None,
    fs_max: old_name("--fs-max") = None,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Unacceptable sampling frequencies where yui > level (Figs. 4.24, 4.54)."""
    _common(freq, damping)
    _check_level(level)
    ns = check_count("--n-samples", n_samples)
    lo, hi = _sampling_range(freq, dt_min, dt_max, fs_min, fs_max)
    points = _SCAN_POINTS + (_PLOT_POINTS if plot is not None else 0)
    _check_work(ns, points * _PHASES_SCAN * ns, "--n-samples", max_memory_mb)
    plot = plot_target(plot)
    from servokit.sampled.unobservable import unacceptable_sampling_frequencies

    with flag_names(_FLAGS):
        iv = unacceptable_sampling_frequencies(freq, damping, ns, level, (lo, hi))
    if plot is not None:
        _sampling_plot(freq, damping, ns, level, (lo, hi), plot)
    rows = [
        {"low_hz": i.low_hz, "high_hz": i.high_hz, "peak_hz": i.peak_hz, "peak_rms": i.peak_rms}
        for i in iv
    ]
    request = {"freq_hz": freq, "damping": damping, "n_samples": ns, "level": level}
    _sampling_render(request, [lo, hi], rows, plot, json_out)


def _sampling_plot(
    freq: float, damping: float, ns: int, level: float, span: tuple[float, float], plot: Any
) -> None:
    """yui over the scanned sampling frequencies, the level drawn (Figs. 4.24, 4.54)."""
    import numpy as np

    from servokit.sampled.unobservable import unobservable_plot, unobservable_rms

    fs = np.geomspace(*span, _PLOT_POINTS)
    rms = unobservable_rms(freq, 1 / fs, damping=damping, n_samples=ns, n_phases=_PHASES_SCAN)
    unobservable_plot(
        fs,
        {f"Ns = {ns}": rms},
        xlabel="Sampling frequency [Hz]",
        ylabel="yui [-]",
        title=f"yui vs sampling frequency ({freq:g} Hz)",
        level=level,
        path=plot,
        logx=True,
    )
    wrote(plot)


def _sampling_render(
    request: dict, span: list[float], rows: list[dict], plot: Any, json_out: bool
) -> None:
    """JSON or the table of unacceptable sampling-frequency bands."""
    if json_out:
        emit_json(
            {**request, "fs_range_hz": span, "intervals": rows,
             "plot": str(plot) if plot else None}
        )  # fmt: skip
        return
    from rich.table import Table

    level, freq, ns = request["level"], request["freq_hz"], request["n_samples"]
    table = Table(title=f"sampling frequencies with yui > {level:g} ({freq:g} Hz, Ns = {ns})")
    for col in ("from [Hz]", "to [Hz]", "peak at [Hz]", "peak yui"):
        table.add_column(col, justify="right")
    for r in rows:
        table.add_row(*(f"{r[k]:.4g}" for k in ("low_hz", "high_hz", "peak_hz", "peak_rms")))
    console.print(table)


@unobservable_app.command(
    "time",
    epilog=example("servokit unobservable time --freq 4000 --dt 25e-6 --damping 0.01")
    + "\n\nJSON: freq_hz, dt_s, damping, level, n_samples (null if not reached), time_s, "
    "crossing_time_s, rms, plot.",
)
def time_cmd(
    freq: FreqOpt,
    dt: DtOpt,
    damping: DampingOpt = 0.01,
    level: LevelOpt = 0.1,
    n_samples_max: Annotated[
        int, typer.Option("--n-samples-max", help="largest Ns examined [count]")
    ] = 100,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Measurement time tau x Ns needed for yui <= level (Figs. 4.25, 4.55)."""
    _common(freq, damping)
    _check_level(level)
    check_positive("--dt", dt, "s")
    n_max = check_count("--n-samples-max", n_samples_max)
    # Ns = 1..n_max each cost P x Ns cells: P n_max^2 / 2 in all
    _check_work(n_max, _PHASES_SCAN * n_max * (n_max + 1) / 2, "--n-samples-max", max_memory_mb)
    plot = plot_target(plot)
    from servokit.sampled.unobservable import required_measurement_time

    # Ns costs ~Ns: the bar advances by Ns so that it tracks the time left
    with (
        flag_names(_FLAGS),
        progress(n_max * (n_max + 1) // 2, "Ns scan", enabled=not json_out) as advance,
    ):
        req = required_measurement_time(
            freq, dt, damping, level, max_samples=n_max, on_sample=advance
        )
    _time_render(req, freq, dt, damping, level, n_max, plot, json_out)


def _time_render(
    req: Any, freq: float, dt: float, damping: float, level: float, n_max: int, plot: Any,
    json_out: bool,
) -> None:  # fmt: skip
    """Figure, JSON or one line of a measurement-time requirement."""
    if plot is not None:
        import numpy as np

        from servokit.sampled.unobservable import unobservable_plot

        ns = np.arange(1, req.rms.size + 1)
        unobservable_plot(
            ns * dt * 1e3,
            {f"tau = {dt * 1e6:.4g} us": req.rms},
            xlabel="Measurement time tau x Ns [ms]",
            ylabel="yui [-]",
            title=f"yui vs measurement time ({freq:g} Hz)",
            level=level,
            path=plot,
        )
        wrote(plot)
    if json_out:
        emit_json({
            "freq_hz": freq, "dt_s": dt, "damping": damping, "level": level,
            "n_samples": req.n_samples, "time_s": req.time_s,
            "crossing_time_s": req.crossing_time_s, "rms": req.rms,
            "plot": str(plot) if plot else None,
        })  # fmt: skip
        return
    if req.n_samples is None:
        console.print(f"yui stays above {level:g} up to Ns = {n_max}; raise --n-samples-max")
        return
    console.print(
        f"Ns >= {req.n_samples} (tau x Ns = {req.time_s * 1e3:.4g} ms); "
        f"the yui curve crosses {level:g} at {req.crossing_time_s * 1e3:.4g} ms"
    )
