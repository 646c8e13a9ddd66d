"""``servokit srs``: shock response spectrum of an acceleration input (book §4.4)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import (
    DampingOpt,
    FmaxOpt,
    FminOpt,
    JsonOpt,
    MaxMemoryOpt,
    NFreqOpt,
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
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_finite,
    check_input_file,
    check_memory,
    check_positive,
    check_range,
    check_work,
)

_FLAGS = {
    "dt_hold": "--dt",
    "duration": "--duration",
    "damping": "--damping",
    "N": "--n-samples",
    "freq_hz": "--fmin/--fmax",
    "accel": "--input",
    "kind": "--kind",
    "target": "--target",
}
_CHUNK = 500  # oscillators per call: one progress step
_ARRAYS_PER_FREQ = 12  # complex arrays per oscillator (lam, states, peaks, ...)
_BLOCK_BYTES = 4_000_000 * 16 * 3  # the library's time blocks (complex cells)
# oscillator x hold-sample (or x Gauss node) updates one request may cost: 1e8 per CPU
# second measured, so about twenty seconds
MAX_CELLS = 2e9
_GL_NODES = 12  # Gauss-Legendre nodes per panel of a continuous input (library)
_PANEL_OVERHEAD = 1000  # a panel's Python step, in oscillator-node updates (measured)
_JSON_KEYS = (
    "input, dt_s, duration_s, damping, kind, freq_hz, magnitude_ratio, peaks_hz, "
    "at [{freq_hz, magnitude_ratio}], plot"
)


def _read_samples(path: str) -> object:
    from pathlib import Path

    import numpy as np

    if not Path(path).exists():
        raise ServokitValueError(
            f"--input {path!r} is neither 'half-sine', 'polynomial' nor an existing file"
        )
    p = check_input_file(path, "--input")
    try:
        data = np.loadtxt(p, delimiter="," if p.suffix == ".csv" else None, ndmin=1)
    except ValueError as exc:
        first = str(exc).splitlines()[0]
        raise ServokitValueError(f"--input {path}: not a column of numbers ({first})") from None
    return check_finite(f"--input {path}", np.ravel(data))


@app.command(
    "srs",
    epilog=example("servokit srs --input half-sine --duration 0.5e-3 --dt 25e-6 --plot srs.png")
    + f"\n\nJSON: {_JSON_KEYS}.",
)
def srs_cmd(
    input_: Annotated[
        str,
        typer.Option(
            "--input", help="'half-sine', 'polynomial' (eq. 4.60) or a file of held samples"
        ),
    ] = "half-sine",
    dt: Annotated[
        float | None,
        typer.Option("--dt", help="hold period Tzoh [s] (omit for a continuous half-sine)"),
    ] = None,
    duration: Annotated[
        float, typer.Option("--duration", help="half-sine width Tsrs [s]")
    ] = 0.5e-3,
    n_samples: Annotated[int, typer.Option("--n-samples", help="polynomial length N [count]")] = 40,
    target: Annotated[
        float, typer.Option("--target", help="polynomial move Pt [output unit]")
    ] = 1.0,
    damping: DampingOpt = 0.0,
    kind: Annotated[
        str, typer.Option("--kind", help="'residual' (4.57) or 'initial' (4.56)")
    ] = "residual",
    fmin: FminOpt = 100.0,
    fmax: FmaxOpt = 100e3,
    n_freq: NFreqOpt = 5000,
    at: Annotated[
        list[float] | None,
        typer.Option("--freq", help="also report gsrs exactly at this frequency [Hz] (repeatable)"),
    ] = None,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Shock response spectrum on the relative-acceleration model (eqs. 4.53-4.61)."""
    import numpy as np

    fmin, fmax = check_range(fmin, fmax)
    n = check_count("--n-freq", n_freq, lo=2)
    at = _check_at(at)
    if dt is not None:
        check_positive("--dt", dt, "s")
    kind_of_input = input_ if input_ in ("half-sine", "polynomial") else "FILE"
    if kind_of_input == "FILE" and not Path(input_).exists():
        _read_samples(input_)  # a misspelt input name: say so before the flags' rules
    refuse_inapplicable("--input", kind_of_input, _INPUT_APPLIES)
    size = (n, fmax, kind, at, max_memory_mb)
    accel, dur = _input(input_, dt, duration, n_samples, target, size)
    plot = plot_target(plot)
    freq = np.linspace(fmin, fmax, n)
    with flag_names(_FLAGS):
        spec = _spectrum(accel, dt, freq, damping, kind, dur, show=not json_out)
        # exact values at the requested frequencies, not interpolated from the grid
        exact = _spectrum(accel, dt, np.asarray(at), damping, kind, dur, show=False) if at else None
    _srs_render(spec, exact, input_, dt, plot, json_out)


def _check_at(at: list[float] | None) -> list[float]:
    """The --freq values (finite, > 0 Hz)."""
    if at:
        check_finite("--freq", at)
        if min(at) <= 0:
            raise ServokitValueError("--freq must be > 0 Hz")
    return [float(f) for f in at or []]


def _srs_render(spec, exact, input_: str, dt, plot, json_out: bool) -> None:  # noqa: ANN001
    """Figure, JSON or the table of peaks of a shock response spectrum."""
    from servokit.sampled.srs import spectrum_peaks

    peaks = spectrum_peaks(spec.freq_hz, spec.magnitude)
    values = (
        []
        if exact is None
        else [
            {"freq_hz": float(f), "magnitude_ratio": float(m)}
            for f, m in zip(exact.freq_hz, exact.magnitude, strict=True)
        ]
    )
    marks = [] if exact is None else list(exact.freq_hz)
    if plot is not None:
        from servokit.sampled.srs import srs_plot

        srs_plot(spec, [f"{input_}, zeta = {spec.damping:g}"], path=plot, marks_hz=marks)
        wrote(plot)
    if json_out:
        emit_json(
            {
                "input": input_,
                "dt_s": dt,
                "duration_s": spec.duration,
                "damping": spec.damping,
                "kind": spec.kind,
                "freq_hz": spec.freq_hz,
                "magnitude_ratio": spec.magnitude,
                "peaks_hz": peaks,
                "at": values,
                "plot": str(plot) if plot else None,
            }
        )
        return
    _print(spec, input_, spec.kind, peaks, values)


def _check_size(n: int, length: float, steps: float, max_memory_mb: float) -> None:
    """Memory and work of ``n`` oscillators over ``length`` held samples / ``steps`` updates."""
    check_memory(
        n * _ARRAYS_PER_FREQ * 16 + _BLOCK_BYTES + length * 8 * 4,
        what=f"--n-freq {n} with {length:.3g} input samples",
        max_memory_mb=max_memory_mb,
    )
    check_work(
        n * steps,
        what=f"--n-freq {n} x {steps:.3g} input steps (--n-samples, --input or --duration)",
        limit=MAX_CELLS,
        about="about twenty seconds",
    )


def _check_panels(n: int, fmax: float, at: list[float], duration: float, kind: str) -> None:
    """Work of a continuous input: each spectrum call integrates on panels of its fastest
    oscillator (--fmax for the grid, the largest --freq for the exact values), 64 per
    period for the initial spectrum, 2 for the residual one (the library's rule), each
    panel an update of every oscillator plus a Python step."""
    per_period = 64 if kind == "initial" else 2
    work, panels = 0.0, 0.0
    for n_osc, top in ((n, fmax), (len(at), max(at, default=0.0))):
        if n_osc:
            p = max(32.0, math.ceil(per_period * top * duration))
            work += p * (n_osc * _GL_NODES + _PANEL_OVERHEAD)
            panels = max(panels, p)
    top = max([fmax, *at])
    check_work(
        work,
        what=f"--fmax/--freq {top:g} Hz with --duration {duration:g} s and --kind {kind} "
        f"({panels:.3g} integration panels)",
        limit=MAX_CELLS,
        about="about twenty seconds",
    )


#: flags that shape one kind of --input (given with another they are refused)
_INPUT_APPLIES = {
    "duration": ("--duration", ("half-sine",)),
    "n_samples": ("--n-samples", ("polynomial",)),
    "target": ("--target", ("polynomial",)),
}


def _input(input_: str, dt, duration, n_samples, target, size):  # noqa: ANN001
    """The input as (accel, duration or None); its size is checked before it is built.

    ``size`` is ``(n_freq, fmax, kind, the --freq values, max_memory_mb)``.
    """
    from servokit.sampled.srs import half_sine, polynomial_wave

    n, fmax, kind, at, max_mb = size
    n_at = len(at)
    if input_ == "half-sine":
        check_positive("--duration", duration, "s")
        if dt is None:
            _check_size(n + n_at, 0, 0, max_mb)
            _check_panels(n, fmax, at, duration, kind)
            return half_sine(duration), duration
        steps = duration / dt
        _check_size(n + n_at, steps, steps, max_mb)
        return half_sine(duration), duration
    u = None if input_ == "polynomial" else _read_samples(input_)
    if dt is None:
        raise ServokitValueError("--dt is required for held samples (the hold period [s])")
    if u is not None:
        _check_size(n + n_at, u.size, u.size, max_mb)
        return u, None
    length = check_count("--n-samples", n_samples)
    _check_size(n + n_at, length, length, max_mb)
    with flag_names(_FLAGS):
        return polynomial_wave(length, dt, float(check_finite("--target", target))), None


def _spectrum(accel, dt, freq, damping, kind, dur, *, show: bool):  # noqa: ANN001
    """The spectrum over ``freq`` in chunks of oscillators, with a progress bar."""
    import numpy as np

    from servokit.sampled.srs import spectrum_in_chunks

    n_chunks = int(np.ceil(freq.size / _CHUNK))
    with progress(n_chunks, "shock response spectrum", enabled=show) as advance:
        return spectrum_in_chunks(
            accel, dt, freq, damping, kind=kind, duration=dur, chunk=_CHUNK, progress=advance
        )


def _print(spec, input_: str, kind: str, peaks, values: list[dict]) -> None:  # noqa: ANN001
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=escape(f"{kind} SRS of {input_} (Tsrs = {spec.duration * 1e3:.4g} ms)"))
    table.add_column("peak at [Hz]", justify="right")
    table.add_column("gsrs", justify="right")
    for f in peaks:
        table.add_row(f"{f:.5g}", f"{spec.at(f):.4g}")
    console.print(table)
    for v in values:
        console.print(f"gsrs({v['freq_hz']:g} Hz) = {v['magnitude_ratio']:.4g}")
