"""``servokit filter ...`` and ``servokit margins``: resonance-compensation filters (§5.3)
and stability margins on the exact loop frequency response (``servokit identify`` is in
:mod:`servokit.cli.identify`)."""

from __future__ import annotations

from contextlib import AbstractContextManager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
import typer

from servokit.cli._app import (
    ControllerOpt,
    DampingOpt,
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
    sub_app,
    wrote,
)
from servokit.cli._options import (
    check_state_size,
    controller_states,
    discrete_states,
    load_controller_data,
    load_variations,
    old_name,
    renamed,
    variation_corners,
)
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
)

if TYPE_CHECKING:
    import control

    _Filter = control.TransferFunction | tuple[np.ndarray, np.ndarray]

filter_app = sub_app("filter", "Resonance-compensation filters of book §5.3 (continuous/Tustin).")

FreqOpt = Annotated[float, typer.Option("--freq", help="filter / mode frequency [Hz]")]
DtOpt = Annotated[
    float | None,
    typer.Option("--dt", help="also give the Tustin discretisation prewarped at --freq [s]"),
]
_JSON_HELP = (
    " JSON keys: num, den (descending powers of s), zeros_hz, poles_hz (natural frequencies), "
    "zero_dampings, pole_dampings, and with --dt: dt_s, num_z, den_z."
)


def _flags(**names: str) -> AbstractContextManager[None]:
    """Re-raise a library error naming the flags the user typed (:func:`flag_names`)."""
    return flag_names(names)


def _natural(roots: np.ndarray) -> tuple[list[float], list[float]]:
    w = np.abs(roots)
    zeta = np.where(w > 0, -np.real(roots) / np.where(w > 0, w, 1.0), 1.0)
    return (w / (2 * np.pi)).tolist(), zeta.tolist()


def _describe(tf: _Filter, freq: float, dt: float | None) -> dict[str, Any]:
    # numpy only: a notch given as (num, den) never imports python-control (start-up)
    num, den = tf if isinstance(tf, tuple) else (tf.num[0][0], tf.den[0][0])
    num, den = np.asarray(num, dtype=float), np.asarray(den, dtype=float)
    zf, zd = _natural(np.roots(num))
    pf, pd = _natural(np.roots(den))
    out: dict[str, Any] = {
        "num": num,
        "den": den,
        "zeros_hz": zf,
        "zero_dampings": zd,
        "poles_hz": pf,
        "pole_dampings": pd,
    }
    if num.shape == den.shape and np.allclose(num, den, rtol=1e-12, atol=0.0):
        # asked for (no lag, zero = pole): correct, but say so rather than look like a bug
        out["note"] = "num = den: with these flags the filter is the identity (gain 1, no phase)"
    if dt is not None:
        from servokit.feedback.filters import tustin_coefficients

        with _flags(freq_hz=f"--freq (with --dt {dt:g} s)", dt="--dt"):
            num_z, den_z = tustin_coefficients(num, den, check_positive("--dt", dt, "s"), freq)
        out.update(dt_s=dt, num_z=num_z, den_z=den_z)
    return out


def _show(
    name: str,
    tf: _Filter,
    freq: float,
    dt: float | None,
    plot: Any,
    json_out: bool,
) -> None:
    target = plot_target(plot)
    info = _describe(tf, freq, dt)
    if target is not None:
        import control

        tf = control.tf(*tf) if isinstance(tf, tuple) else tf
        from servokit.feedback.plots import bode_responses_plot
        from servokit.models.frequency_grid import frequency_grid

        f = frequency_grid(tf, freq / 100, min(freq * 100, 1e6), 2000)
        systems: dict[str, Any] = {f"{name} (continuous)": tf}
        if dt is not None:
            from servokit.feedback import discretize_filter

            f = f[f < 0.5 / dt]
            systems[f"{name} (Tustin, dt = {dt:g} s)"] = discretize_filter(tf, dt, freq)
        wrote(bode_responses_plot(systems, f, path=target, title=f"{name} filter (book §5.3)"))
    if json_out:
        emit_json({"filter": name, **info})
        return
    console.print(f"{name}: num = {np.array2string(info['num'], precision=6)}")
    console.print(f"{' ' * len(name)}  den = {np.array2string(info['den'], precision=6)}")
    for kind in ("zero", "pole"):
        pairs = zip(info[f"{kind}s_hz"], info[f"{kind}_dampings"], strict=True)
        console.print(f"  {kind}s: " + ", ".join(f"{f:.6g} Hz (ζ {z:.4g})" for f, z in pairs))
    if "note" in info:
        console.print(f"  note: {info['note']}")
    if dt is not None:
        console.print(f"  Tustin at dt = {dt:g} s, prewarped at {freq:g} Hz:")
        console.print(f"    num_z = {np.array2string(np.asarray(info['num_z']), precision=8)}")
        console.print(f"    den_z = {np.array2string(np.asarray(info['den_z']), precision=8)}")


@filter_app.command(
    "notch",
    epilog=example("servokit filter notch --freq 4449 --damping 0.09 --filter-damping 0.7"),
    help="Notch N(s) of eq. (5.14) cancelling a mode (fR, ζR); fD > fR: high-pass notch."
    + _JSON_HELP,
)
def notch_cmd(
    freq: FreqOpt,
    damping: DampingOpt,
    filter_freq: Annotated[
        float | None, typer.Option("--filter-freq", help="pole frequency fD [Hz] (default fR)")
    ] = None,
    filter_damping: Annotated[
        float, typer.Option("--filter-damping", help="pole damping ζD, √2/2..1 [1]")
    ] = 0.7,
    dt: DtOpt = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    from servokit.feedback.filters import notch_coefficients

    with _flags(
        freq_hz="--freq",
        damping="--damping",
        filter_freq_hz="--filter-freq",
        filter_damping="--filter-damping",
    ):
        tf = notch_coefficients(
            freq, damping, filter_freq_hz=filter_freq, filter_damping=filter_damping
        )
    _show("notch", tf, freq, dt, plot, json_out)


@filter_app.command(
    "peak",
    epilog=example("servokit filter peak --freq 4449 --damping 0.015 --gain 0.1778 --phi 2.5414"),
    help="Peak filter F(s) = K s (s cos φ + ω1 sin φ)/(s² + 2ζ1ω1 s + ω1²), eq. (5.17)."
    + _JSON_HELP,
)
def peak_cmd(
    freq: FreqOpt,
    damping: DampingOpt,
    gain: Annotated[float, typer.Option("--gain", help="filter gain K [1]")],
    phi: Annotated[float, typer.Option("--phi", help="zero-placement phase φ [rad]")],
    dt: DtOpt = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    from servokit.feedback.filters import peak_filter_coefficients

    with _flags(freq_hz="--freq", damping="--damping", gain="--gain", phi="--phi"):
        tf = peak_filter_coefficients(freq, damping, gain, phi)
    _show("peak", tf, freq, dt, plot, json_out)


@filter_app.command(
    "lag",
    epilog=example("servokit filter lag --freq 6900 --damping 0.1 --phase 1.1519"),
    help="Complex lag Clag(s) of eqs. (5.92)-(5.94): phase lag 2φm at fm." + _JSON_HELP,
)
def lag_cmd(
    freq: FreqOpt,
    damping: DampingOpt,
    phase: Annotated[float, typer.Option("--phase", help="half the lag φm at --freq [rad]")],
    dt: DtOpt = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    from servokit.feedback.filters import complex_lag_coefficients

    with _flags(freq_hz="--freq", damping="--damping", phase_rad="--phase"):
        tf = complex_lag_coefficients(freq, damping, phase)
    _show("complex lag", tf, freq, dt, plot, json_out)


@filter_app.command(
    "inverse",
    epilog=example("servokit filter inverse --zero-freq 4449 --pole-freq 4775"),
    help="Inverse-compensation zero/pole pair of §5.3.2 (unit DC gain)." + _JSON_HELP,
)
def inverse_cmd(
    zero_freq: Annotated[float, typer.Option("--zero-freq", help="zero frequency [Hz]")],
    pole_freq: Annotated[float, typer.Option("--pole-freq", help="pole frequency [Hz]")],
    zero_damping: Annotated[float, typer.Option("--zero-damping", help="zero damping [1]")] = 0.05,
    pole_damping: Annotated[float, typer.Option("--pole-damping", help="pole damping [1]")] = 0.05,
    dt: DtOpt = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    from servokit.feedback.filters import inverse_pair_coefficients

    with _flags(
        zero_hz="--zero-freq",
        pole_hz="--pole-freq",
        zero_damping="--zero-damping",
        pole_damping="--pole-damping",
    ):
        tf = inverse_pair_coefficients(
            zero_freq, pole_freq, zero_damping=zero_damping, pole_damping=pole_damping
        )
    _show("inverse pair", tf, zero_freq, dt, plot, json_out)


_FILTER_FORMS = {
    "notch": ("notch:FREQ:DAMPING[:FILTER_FREQ:FILTER_DAMPING]", (2, 4)),
    "peak": ("peak:FREQ:DAMPING:GAIN:PHI", (4, 4)),
    "lag": ("lag:FREQ:DAMPING:PHASE", (3, 3)),
    "inverse": ("inverse:ZERO_FREQ:POLE_FREQ[:ZERO_DAMPING:POLE_DAMPING]", (2, 4)),
}


def parse_filter(spec: str) -> tuple[control.TransferFunction, float]:
    """A ``--filter`` spec such as ``notch:4449:0.09`` -> (continuous filter, its frequency)."""
    from servokit import feedback as fb

    kind, *fields = spec.split(":")
    if kind not in _FILTER_FORMS:
        raise ServokitValueError(
            f"--filter {spec}: unknown kind {kind!r}; use one of "
            + ", ".join(form for form, _ in _FILTER_FORMS.values())
        )
    form, (lo, hi) = _FILTER_FORMS[kind]
    try:
        x = [float(v) for v in fields]
    except ValueError:
        raise ServokitValueError(f"--filter {spec}: numbers expected, as in {form}") from None
    if not lo <= len(x) <= hi or len(x) == 3 and hi == 4 and lo == 2:
        raise ServokitValueError(f"--filter {spec}: write it as {form}")
    with _flags(**{p: f"--filter {spec}: {p}" for p in _PARAMS}):
        return _build(fb, kind, x)


_PARAMS = (
    "freq_hz",
    "damping",
    "filter_freq_hz",
    "filter_damping",
    "gain",
    "phi",
    "phase_rad",
    "zero_hz",
    "pole_hz",
    "zero_damping",
    "pole_damping",
)


def _build(fb: Any, kind: str, x: list[float]) -> tuple[control.TransferFunction, float]:
    if kind == "notch":
        kw = {"filter_freq_hz": x[2], "filter_damping": x[3]} if len(x) == 4 else {}
        return fb.notch(x[0], x[1], **kw), x[0]
    if kind == "peak":
        return fb.peak_filter(*x), x[0]
    if kind == "lag":
        return fb.complex_lag(*x), x[0]
    kw = {"zero_damping": x[2], "pole_damping": x[3]} if len(x) == 4 else {}
    return fb.inverse_pair(x[0], x[1], **kw), x[0]


@app.command(
    "margins",
    epilog=example(
        "servokit margins --plant hdd-sampled-data --controller eq-4.69",
        "servokit margins --plant vcm-dual-stage --controller table-5.2 --json",
        "servokit margins --plant vcm-dual-stage --controller table-5.2 --variations box.toml",
    ),
    help="Gain, phase, delay and modulus margins and the closed-loop stability of the digital"
    " loop P(z) C(z) F(z) (P discretised exactly under a ZOH, filters by prewarped Tustin);"
    " every crossover is found on a grid packed around every pole and zero, refined"
    " adaptively and verified on the exact response; the extra delay is exact. Stability"
    " comes from the Nyquist winding count; an unstable loop gets one warning line."
    " --variations FILE: margins over the corners of a variation file, worst plant named."
    " JSON keys: closed_loop_stable, gain_margin_db, phase_margin_deg, gm_freq_hz,"
    " pm_freq_hz, delay_margin_s, modulus_margin, modulus_margin_freq_hz,"
    " second_phase_margin_deg, gain_crossovers_hz, phase_margins_deg, delay_margins_s,"
    " phase_crossovers_hz, gain_margins_db, plant, controller, dt_s (with --variations:"
    " all_stable, worst_index, worst_plant, min_*_margin_* and their *_index, plants).",
)
def margins_cmd(
    plant: PlantOpt,
    controller: ControllerOpt,
    filters: Annotated[
        list[str] | None,
        typer.Option(
            "--filter",
            help="add a filter in series (repeatable): notch:F:Z[:FD:ZD], peak:F:Z:K:PHI,"
            " lag:F:Z:PHI, inverse:FZ:FP[:ZZ:ZP] [Hz, 1, rad]",
        ),
    ] = None,
    delay: Annotated[float, typer.Option("--loop-delay", help="extra loop delay [s]")] = 0.0,
    delay_old: old_name("--delay") = None,
    n_freq: Annotated[
        int, typer.Option("--n-freq", help="background grid points (packed and refined)", min=16)
    ] = 500,
    variations: Annotated[
        Path | None,
        typer.Option(
            "--variations", help="variation file (.toml): margins over its corners", metavar="FILE"
        ),
    ] = None,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    from servokit.feedback import stability_margins

    target = plot_target(plot)
    delay, delay_flag = _loop_delay(delay, delay_old)
    check_count("--n-freq", n_freq, lo=16, hi=_MARGINS_MAX_FREQ)
    p = load_plant(plant)
    ctrl = load_controller_data(controller)
    dt = float(ctrl.dt)
    _check_delay(delay, dt, delay_flag)
    chain = [ctrl, *_filter_chain(filters, dt)]
    _check_margins_size(p, plant, dt, chain, n_freq, max_memory_mb)
    if variations is not None:
        _margins_over_file(p, chain, variations, delay, n_freq, json_out, controller, dt)
        return
    loop: list[Any] = [p.discretize_data(dt), *chain]
    m = stability_margins(loop, delay, n_freq=n_freq)
    if target is not None:
        _margins_plot(loop, m, dt, target)
    _warn_unstable(m.closed_loop_stable, p.name)
    _margins_render(m, p.name, controller, dt, json_out)


def _loop_delay(delay: float, delay_old: float | None) -> tuple[float, str]:
    """--loop-delay (or the deprecated --delay) [s], finite and >= 0, and the flag typed."""
    delay_flag = "--loop-delay" if delay_old is None else "--delay"
    delay = renamed(delay, delay_old, new_flag="--loop-delay", old_flag="--delay", default=0.0)
    if not float(check_finite(delay_flag, delay)) >= 0:
        raise ServokitValueError(f"{delay_flag} must be >= 0 s (got {delay:g})")
    return delay, delay_flag


def _filter_chain(filters: list[str] | None, dt: float) -> list[Any]:
    """The --filter specs as discrete filters at ``dt`` (prewarped Tustin)."""
    from servokit.feedback import discretize_filter

    chain = []
    for spec in filters or []:
        tf, f0 = parse_filter(spec)
        with _flags(freq_hz=f"--filter {spec}: FREQ", dt="the loop's dt"):  # not --freq
            chain.append(discretize_filter(tf, dt, f0))
    return chain


#: Complex values held per background grid point and loop factor (responses, packed and
#: refined grids, crossing searches): ~550 bytes per point measured for two factors.
_MARGINS_VALUES_PER_POINT = 12


def _check_margins_size(
    p: Any, plant: str, dt: float, chain: list[Any], n_freq: int, max_memory_mb: float
) -> None:
    """The plant's discrete model and the frequency grids, estimated before building."""
    n_states = discrete_states(p, dt, sum(controller_states(c) for c in chain))
    check_state_size(n_states, what=f"--plant {plant}", max_memory_mb=max_memory_mb)
    check_memory(
        16.0 * _MARGINS_VALUES_PER_POINT * n_freq * (len(chain) + 2),
        what=f"--n-freq {n_freq}",
        max_memory_mb=max_memory_mb,
    )


def _margins_render(m: Any, name: str, controller: str, dt: float, json_out: bool) -> None:
    """JSON or the margins and every crossover of one loop."""
    if json_out:
        emit_json({"plant": name, "controller": controller, "dt_s": dt, **m.to_dict()})
        return
    console.print(
        f"{name} with {controller} (dt = {dt:g} s): GM {m.gain_margin_db:.4g} dB at "
        f"{m.gm_freq_hz:.5g} Hz, PM {m.phase_margin_deg:.4g} deg at {m.pm_freq_hz:.5g} Hz, "
        f"delay margin {m.delay_margin_s * 1e6:.4g} us"
        + (" (the closed loop is already unstable)" if m.closed_loop_stable is False else "")
        + f", modulus margin {m.modulus_margin:.4g} at {m.modulus_margin_freq_hz:.5g} Hz"
    )
    # a crossover's delay margin is the extra delay that moves it to -180 deg: for an
    # unstable loop it is no margin (the headline says 0), so the rows say so
    unstable = m.closed_loop_stable is False
    for f, pm, dm in zip(m.gain_crossovers_hz, m.phase_margins_deg, m.delay_margins_s, strict=True):
        delay = f"{'n/a':>8}" if unstable else f"{dm * 1e6:8.4g} us"
        console.print(
            f"  gain crossover {f:10.5g} Hz  phase margin {pm:8.4g} deg  delay margin {delay}"
        )
    for f, gm in zip(m.phase_crossovers_hz, m.gain_margins_db, strict=True):
        console.print(f"  phase crossover {f:9.5g} Hz  gain margin {gm:8.4g} dB")


#: Largest extra loop delay ``margins`` accepts, in sampling periods.
_MARGINS_MAX_DELAY_SAMPLES = 100


def _check_delay(delay: float, dt: float, flag: str = "--loop-delay") -> None:
    if delay > _MARGINS_MAX_DELAY_SAMPLES * dt:
        raise ServokitValueError(
            f"{flag} {delay:g} s is {delay / dt:.3g} sampling periods; a loop delay that"
            f" large is not a margin question: give at most {_MARGINS_MAX_DELAY_SAMPLES} dt"
            f" = {_MARGINS_MAX_DELAY_SAMPLES * dt:g} s (the delay is in seconds)"
        )


def _warn_unstable(stable: bool | None, name: str) -> None:
    if stable is False:
        typer.echo(
            f"servokit: warning: the closed loop with {name} is UNSTABLE (Nyquist count);"
            " its margins do not describe a working loop",
            err=True,
        )


def _margins_plot(loop: list[Any], m: Any, dt: float, target: Any) -> None:
    from servokit.feedback.plots import bode_responses_plot
    from servokit.models.frequency_grid import frequency_grid

    f = frequency_grid(loop, 10.0, 0.5 / dt, 3000)
    title = (
        f"open loop L: PM {m.phase_margin_deg:.3g}° at {m.pm_freq_hz:.4g} Hz, "
        f"GM {m.gain_margin_db:.3g} dB at {m.gm_freq_hz:.4g} Hz"
    )
    # continuous phase: the -180° crossings read off the curve, no jumps at resonances
    wrote(bode_responses_plot({"L = P C F": loop}, f, path=target, title=title, unwrap=True))


def _margins_over_file(
    p: Any, chain: list[Any], path: str, delay: float, n_freq: int, json_out: bool,
    controller: str, dt: float,
) -> None:
    from servokit.feedback import margins_over_set

    # the file's plant, else --plant (a typed --plant must agree with the file's); the
    # corners refused above MAX_CORNERS before any is built, as in seek and simulate
    vset = load_variations(path, fallback=p)
    plants = variation_corners(vset)
    p = vset.nominal
    with progress(len(plants), f"margins of {len(plants)} plants") as advance:
        res = margins_over_set(chain, plants, delay, n_freq=n_freq, progress=advance)
    worst = plants[res.worst_index]
    _warn_unstable(False if res.all_stable is False else None, f"plant {res.worst_index}")
    if json_out:
        emit_json(
            {
                "plant": p.name,
                "controller": controller,
                "dt_s": dt,
                "worst_plant": str(worst),
                **res.to_dict(),
            }
        )
        return
    m = res.worst
    console.print(
        f"{len(plants)} plants of {path} with {controller}: worst plant {res.worst_index}"
        f" ({worst}): GM {m.gain_margin_db:.4g} dB, PM {m.phase_margin_deg:.4g} deg,"
        f" modulus margin {m.modulus_margin:.4g}, stable {m.closed_loop_stable}"
    )
    console.print(
        f"  smallest GM {res.min_gain_margin_db:.4g} dB (plant {res.min_gain_margin_index}),"
        f" PM {res.min_phase_margin_deg:.4g} deg (plant {res.min_phase_margin_index}),"
        f" delay margin {res.min_delay_margin_s * 1e6:.4g} us"
        f" (plant {res.min_delay_margin_index})"
    )


#: Largest --n-freq of ``margins`` (the library's limit).
_MARGINS_MAX_FREQ = 10_000_000
