"""``servokit limits``: waterbed bound, Bode integrals and the variance bound (book §6.3)."""

from __future__ import annotations

from typing import Annotated

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlotOpt,
    console,
    emit_json,
    example,
    flag_names,
    plot_target,
    started,
    sub_app,
    wrote,
)
from servokit.cli._options import old_name, renamed
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_memory,
    check_positive,
)

limits_app = sub_app("limits", "Performance limits: waterbed, Bode integrals, variance (§6.3).")

NumOpt = Annotated[
    str, typer.Option("--num", help="loop numerator, comma-separated, highest power first")
]
DenOpt = Annotated[str, typer.Option("--den", help="loop denominator, comma-separated")]
DtOpt = Annotated[
    float | None, typer.Option("--dt", help="sampling period [s] (omit for a continuous loop)")
]


def _coeffs(text: str, flag: str) -> np.ndarray:
    if any(not v.strip() for v in text.split(",")) and text.strip():
        raise ServokitValueError(
            f"{flag} {text!r}: an entry is empty; give numbers, comma-separated"
        )
    try:
        vals = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise ServokitValueError(f"{flag} {text!r}: give comma-separated numbers") from None
    if vals.size == 0 or not np.all(np.isfinite(vals)) or vals[0] == 0:
        raise ServokitValueError(f"{flag} {text!r}: give finite numbers, first one non-zero")
    return vals


def _loop(num: str, den: str, dt: float | None, flags: tuple[str, str] = ("--num", "--den")):
    """The loop as numpy coefficients: no python-control object (start-up, issue 23)."""
    from servokit.limits import RationalLoop

    n, d = _coeffs(num, flags[0]), _coeffs(den, flags[1])
    if dt is not None:
        dt = check_positive("--dt", dt, "s")
    return RationalLoop(n, d, dt)


def _lti(loop):  # noqa: ANN001, ANN202
    """The python-control transfer function of a RationalLoop, for the plots."""
    import control

    return (
        control.tf(loop.num, loop.den)
        if loop.dt is None
        else control.tf(loop.num, loop.den, loop.dt)
    )



def _check_waterbed_range(alpha_db: float, ratio: float, freq: float) -> None:
    """Refuse an --alpha-db / --freq pair whose (6.20) bound ``-alpha_db * ratio`` [dB] no
    float holds (near Nyquist the ratio phi1 / (pi - phi1) grows without limit)."""
    if alpha_db < -6000:
        raise ServokitValueError(f"--alpha-db must be >= -6000 dB (got {alpha_db:g})")
    bound_db = -alpha_db * ratio
    if bound_db > 6000:
        raise ServokitValueError(
            f"--alpha-db {alpha_db:g} up to --freq {freq:g} Hz bounds ||S|| by {bound_db:.4g} dB, "
            "beyond any float (no loop meets it); relax --alpha-db or lower --freq"
        )

@limits_app.command(
    "waterbed",
    epilog=example("servokit limits waterbed --alpha-db -40 --freq 1000 --dt 4e-5"),
)
def waterbed_cmd(
    alpha_db: float = typer.Option(
        -40.0, "--alpha-db", help="bound of |S| below the bandwidth [dB]"
    ),
    freq: float = typer.Option(1000.0, "--freq", help="sensitivity bandwidth [Hz]"),
    dt: float = typer.Option(4e-5, "--dt", help="sampling period [s]"),
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Lower bound of ||S||inf from eq. (6.20).  JSON: phi1_rad, bound, bound_db."""
    from servokit.limits import waterbed_lower_bound, waterbed_phi1

    plot = plot_target(plot)
    if not alpha_db < 0:
        raise ServokitValueError(f"--alpha-db must be < 0 dB (got {alpha_db})")
    dt = check_positive("--dt", dt, "s")
    freq = check_positive("--freq", freq, "Hz")
    if freq >= 0.5 / dt:
        raise ServokitValueError(
            f"--freq {freq:g} Hz must be below the Nyquist frequency {0.5 / dt:g} Hz of --dt"
        )
    phi1 = waterbed_phi1(freq, 1.0 / dt)
    _check_waterbed_range(alpha_db, phi1 / (np.pi - phi1), freq)
    alpha = 10 ** (alpha_db / 20)
    bound = waterbed_lower_bound(alpha, phi1)
    if plot is not None:
        from servokit.limits.plots import waterbed_plot

        wrote(waterbed_plot(alpha, 1.0 / dt, plot, mark_hz=freq))
    data = {"phi1_rad": phi1, "bound": bound, "bound_db": 20 * np.log10(bound)}
    if json_out:
        emit_json(data)
        return
    console.print(
        f"|S| <= {alpha_db:g} dB up to {freq:g} Hz at {1 / dt:g} Hz sampling: "
        f"||S||inf >= {bound:.4f} ({data['bound_db']:.3f} dB)"
    )


#: complex arrays of --n-freq points the discrete Bode integral holds (response, ln|S|, ...)
_BODE_ARRAYS = 8


@limits_app.command(
    "bode-integral",
    epilog=example("servokit limits bode-integral --num 0.5,0.1 --den 1,-0.5,0.1 --dt 1e-4"),
)
def bode_integral_cmd(
    num: NumOpt,
    den: DenOpt,
    dt: DtOpt = None,
    n_freq: int = typer.Option(1 << 16, "--n-freq", help="number of frequency points", min=64),
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Integral of ln|S| against (6.17) / (6.18).  JSON: integral, theory, limit_gain, corollary."""
    from servokit.limits import continuous_bode_integral, discrete_bode_integral

    plot = plot_target(plot)
    loop = _loop(num, den, dt)
    if dt is not None:
        n_freq = check_count("--n-freq", n_freq, lo=64, hi=1 << 24)
        check_memory(
            _BODE_ARRAYS * 16.0 * n_freq, what=f"--n-freq {n_freq}", max_memory_mb=max_memory_mb
        )
    res = discrete_bode_integral(loop, n_freq=n_freq) if dt else continuous_bode_integral(loop)
    if plot is not None:
        from servokit.limits.plots import bode_integral_plot

        wrote(bode_integral_plot(_lti(loop), plot))
    data = {
        "integral": res.integral,
        "theory": res.theory,
        "limit_gain": res.limit_gain,
        "corollary": res.corollary,
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"integral of ln|S| = {res.integral:.6g} (theory {res.theory:.6g}; "
        f"{'Kz' if dt else 'Ks'} = {res.limit_gain:.6g}): {res.corollary}"
    )


@limits_app.command(
    "variance",
    epilog=example(
        "servokit limits variance --num 40000 --den 1,300,0 --dist-num 1 --dist-den 0.01,1"
    ),
)
def variance_cmd(
    num: NumOpt,
    den: DenOpt,
    dist_num: str = typer.Option(..., "--dist-num", help="disturbance filter numerator"),
    dist_den: str = typer.Option(..., "--dist-den", help="disturbance filter denominator"),
    dt: DtOpt = None,
    delta: float = typer.Option(0.5, "--delta", help="roll-off constant delta of (6.14)"),
    k: int = typer.Option(1, "--rolloff-order", help="roll-off order k of (6.14) [count]"),
    k_old: old_name("--k", int) = None,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Output variance (6.13) against its lower bound (6.16, corrected).

    JSON: bandwidth_hz, variance_out2, bound_out2, bound_low_out2, bound_high_out2, beta,
    gamma, printed_bound_out2 (variances in the output unit squared, for unit white noise
    into the disturbance filter).
    """
    from servokit.limits import variance_against_bound

    plot = plot_target(plot)
    delta, k = _rolloff(delta, k, k_old)
    loop = _loop(num, den, dt)
    dist = _disturbance(dist_num, dist_den, dt)
    with flag_names(_VARIANCE_FLAGS):
        res = variance_against_bound(
            loop, dist, delta=delta, k=k, started=lambda what: started("limits variance", what)
        )
    if plot is not None:
        from servokit.limits.plots import variance_plot

        wrote(variance_plot(_lti(loop), _lti(dist), res.bandwidth_hz, plot))
    _variance_render(res, json_out)


_VARIANCE_FLAGS = {
    "delta": "--delta",
    "k": "--rolloff-order",
    "disturbance and loop": "--dist-num/--dist-den and --num/--den",
}


def _rolloff(delta: float, k: int, k_old: int | None) -> tuple[float, int]:
    """--delta in (0, 1) and --rolloff-order (or the deprecated --k) in 1..50."""
    delta = check_positive("--delta", delta)
    if delta >= 1:
        raise ServokitValueError(f"--delta must be < 1 (got {delta:g}); the book uses 0.5")
    k = renamed(k, k_old, new_flag="--rolloff-order", old_flag="--k", default=1)
    return delta, check_count("--rolloff-order", k, lo=1, hi=50)


def _disturbance(dist_num: str, dist_den: str, dt: float | None):  # noqa: ANN202
    """The disturbance filter; a continuous one must be strictly proper."""
    dist = _loop(dist_num, dist_den, dt, ("--dist-num", "--dist-den"))
    if dt is None and len(dist_num.split(",")) >= len(dist_den.split(",")):
        raise ServokitValueError(
            "--dist-num/--dist-den: a continuous disturbance filter must be strictly proper "
            "(fewer --dist-num than --dist-den coefficients): white noise through it has "
            "unbounded variance"
        )
    poles = np.roots(_coeffs(dist_den, "--dist-den"))
    unstable = poles[np.abs(poles) > 1 + 1e-12] if dt is not None else poles[poles.real > 1e-12]
    if unstable.size:  # white noise through it grows without bound
        raise ServokitValueError(
            f"--dist-den: the disturbance filter has an unstable pole at {unstable[0]:.4g}; "
            "a stationary disturbance needs a stable filter (mirror the pole: same spectrum)"
        )
    return dist


def _variance_render(res, json_out: bool) -> None:  # noqa: ANN001
    vb, var, omega_hz = res.bound, res.variance, res.bandwidth_hz
    if json_out:
        emit_json({
            "bandwidth_hz": omega_hz, "variance_out2": var, "bound_out2": vb.bound,
            "bound_low_out2": vb.low, "bound_high_out2": vb.high, "beta": vb.beta,
            "gamma": vb.gamma, "printed_bound_out2": vb.printed,
        })  # fmt: skip
        return
    console.print(
        f"Omega = {omega_hz:.4g} Hz; var(y) = {var:.5g} >= bound {vb.bound:.5g} "
        f"(printed form {vb.printed:.5g}); ratio var/bound = {var / vb.bound:.3f}"
    )


@limits_app.command(
    "dynamic-range",
    epilog=example("servokit limits dynamic-range --stroke-m 0.03 --accuracy-m 3e-9"),
)
def dynamic_range_cmd(
    stroke_m: float = typer.Option(..., "--stroke-m", help="actuator stroke [m]"),
    accuracy_m: float = typer.Option(..., "--accuracy-m", help="positioning accuracy [m]"),
    json_out: JsonOpt = False,
) -> None:
    """Dynamic range accuracy/stroke of §6.1.1 (Fig. 6.1).  JSON: dynamic_range."""
    from servokit.limits import dynamic_range

    stroke_m = check_positive("--stroke-m", stroke_m, "m")
    accuracy_m = check_positive("--accuracy-m", accuracy_m, "m")
    if accuracy_m > stroke_m:
        raise ServokitValueError(
            f"--accuracy-m ({accuracy_m:g}) must not exceed --stroke-m ({stroke_m:g})"
        )
    value = dynamic_range(stroke_m, accuracy_m)
    if json_out:
        emit_json({"dynamic_range": value})
        return
    console.print(f"dynamic range = {value:.3g}")
