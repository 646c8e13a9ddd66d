"""``servokit feedforward``: sampled-data polynomials (Table 2.1) and minimum jerk (§2.2)."""

from __future__ import annotations

from typing import Annotated

import typer

from servokit.cli._app import (
    DtOpt,
    JsonOpt,
    MaxMemoryOpt,
    NSamplesOpt,
    PlotOpt,
    console,
    emit_json,
    example,
    flag_names,
    plot_target,
    sub_app,
    wrote,
)
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_memory,
    check_positive,
)

feedforward_app = sub_app("feedforward", "Feedforward inputs of chapter 2 (rigid body).")

TargetOpt = Annotated[float, typer.Option("--target", help="target position r [output unit]")]
# float arrays one sample long that sampled_polynomial / minimum_jerk_zoh_response hold
_ARRAYS_PER_SAMPLE = 8


@feedforward_app.command(
    "polynomial",
    epilog=example("servokit feedforward polynomial --order 3 --n-samples 40 --dt 25e-6 --json")
    + "\n\nJSON: order, n_samples, dt_s, target_out, formula, peak_input, u (u[0..N]).",
)
def polynomial_cmd(
    n_samples: NSamplesOpt,
    dt: DtOpt,
    order: Annotated[int, typer.Option("--order", help="polynomial order 3..8 (Table 2.1)")] = 3,
    target: TargetOpt = 1.0,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    json_out: JsonOpt = False,
    plot: PlotOpt = None,
) -> None:
    """Acceleration sampled-data polynomial u[0..N] (eq. 2.24, Table 2.1)."""
    check_positive("--dt", dt, "s")
    n = check_count("--n-samples", n_samples)
    check_memory(
        (n + 1) * 8 * _ARRAYS_PER_SAMPLE, what=f"--n-samples {n}", max_memory_mb=max_memory_mb
    )
    plot = plot_target(plot)
    import numpy as np

    from servokit.feedforward.polynomial import polynomial_formula, sampled_polynomial

    with flag_names({"order": "--order", "N": "--n-samples", "dt": "--dt", "target": "--target"}):
        u = sampled_polynomial(order, n, dt, target)  # numpy: the formula needs sympy
    if plot is not None:
        _polynomial_plot(u, n, dt, order, plot)
    peak = float(np.abs(u).max())
    if not json_out:  # the first line before sympy's derivation (start-up, issue 23)
        console.print(f"order {order}, N = {n}, dt = {dt:g} s, target = {target:g}")
    formula = f"({polynomial_formula(order)}) * r / tau**2"
    if json_out:
        emit_json(
            {
                "order": order,
                "n_samples": n,
                "dt_s": dt,
                "target_out": target,
                "formula": formula,
                "peak_input": peak,
                "u": u,
            }
        )
        return
    console.print(f"u[n] = {formula}")
    console.print(f"peak |u| = {peak:.6g} (target units/s^2)")


def _polynomial_plot(u, n: int, dt: float, order: int, path) -> None:  # noqa: ANN001
    import matplotlib.pyplot as plt
    import numpy as np

    from servokit._figures import save_figure

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.stairs(u[:-1], np.arange(n + 1) * dt * 1e3, label=f"order {order}, N = {n}")
    ax.set_xlabel("time [ms]")
    ax.set_ylabel("input u [target units/s$^2$]")
    ax.set_title("Sampled-data polynomial (Table 2.1)")
    ax.legend()
    ax.grid(True, alpha=0.3)
    save_figure(fig, path)
    wrote(path)


@feedforward_app.command(
    "minimum-jerk",
    epilog=example("servokit feedforward minimum-jerk --move-time 1 --dt 0.1 --json")
    + "\n\nJSON: move_time_s, dt_s, target_out, final_error, final_velocity_per_s, n_samples.",
)
def minimum_jerk_cmd(
    dt: DtOpt,
    move_time: Annotated[
        float, typer.Option("--move-time", help="move time T of (2.14) [s]")
    ] = 1.0,
    target: TargetOpt = 1.0,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    json_out: JsonOpt = False,
    plot: PlotOpt = None,
) -> None:
    """Final error of the sampled-and-held minimum-jerk input (2.14), Figs. 2.9-2.10."""
    T = check_positive("--move-time", move_time, "s")
    tau = check_positive("--dt", dt, "s")
    if tau > T:
        raise ServokitValueError(
            f"--dt {tau:g} s is longer than --move-time {T:g} s: the held input would be a "
            "single sample; use --dt <= --move-time"
        )
    n = T / tau
    check_memory(
        n * 8 * _ARRAYS_PER_SAMPLE,
        what=f"--move-time {T:g} / --dt {tau:g} ({n:.3g} samples)",
        max_memory_mb=max_memory_mb,
    )
    plot = plot_target(plot)
    from servokit.feedforward.minimum_jerk import minimum_jerk_zoh_plot, minimum_jerk_zoh_response

    with flag_names({"T": "--move-time", "tau": "--dt", "target": "--target"}):
        res = minimum_jerk_zoh_response(T, target, tau)
    if plot is not None:
        from servokit._figures import save_figure

        save_figure(minimum_jerk_zoh_plot([res]), plot)
        wrote(plot)
    data = {
        "move_time_s": T,
        "dt_s": tau,
        "target_out": target,
        "final_error": res.final_error,
        "final_velocity_per_s": res.final_velocity,
        "n_samples": int(res.u.size),
    }
    if json_out:
        emit_json(data)
        return
    console.print(f"minimum jerk T = {T:g} s, dt = {tau:g} s: y(T) - r = {res.final_error:.6g}")
