"""``servokit feedforward``: sampled-data polynomials (Table 2.1) and minimum jerk (§2.2)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from servokit.cli._app import app, console, emit_json

feedforward_app = typer.Typer(help="Feedforward inputs of chapter 2 (rigid body).")
app.add_typer(feedforward_app, name="feedforward")


@feedforward_app.command("polynomial")
def polynomial_cmd(
    order: int = typer.Option(3, "--order", help="Polynomial order 3..8 (Table 2.1)."),
    N: int = typer.Option(..., "--N", help="Number of steps N."),
    dt: float = typer.Option(..., "--dt", help="Sampling period tau [s]."),
    target: float = typer.Option(1.0, "--target", help="Target position r."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output."),
    plot: Path | None = typer.Option(None, "--plot", help="Write a PNG of u[n] to FILE."),
) -> None:
    """Acceleration sampled-data polynomial u[0..N] (eq. 2.24, Table 2.1)."""
    from servokit.feedforward.polynomial import polynomial_formula, sampled_polynomial

    u = sampled_polynomial(order, N, dt, target)
    formula = f"({polynomial_formula(order)}) * r / tau**2"
    if plot is not None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        ax.stairs(u[:-1], np.arange(N + 1) * dt * 1e3, label=f"order {order}, N = {N}")
        ax.set_xlabel("time [ms]")
        ax.set_ylabel("input u [target units/s$^2$]")
        ax.set_title("Sampled-data polynomial (Table 2.1)")
        ax.legend()
        ax.grid(True, alpha=0.3)
        fig.tight_layout()
        fig.savefig(plot)
        plt.close(fig)
    if json_out:
        emit_json({"order": order, "N": N, "dt": dt, "target": target, "formula": formula, "u": u})
        return
    console.print(f"order {order}, N = {N}, dt = {dt:g} s, target = {target:g}")
    console.print(f"u[n] = {formula}")
    console.print(f"peak |u| = {np.abs(u).max():.6g} (target units/s^2)")


@feedforward_app.command("minimum-jerk")
def minimum_jerk_cmd(
    T: float = typer.Option(1.0, "--T", help="Move time T [s]."),
    tau: float = typer.Option(..., "--tau", help="Sampling period of the ZOH [s]."),
    target: float = typer.Option(1.0, "--target", help="Target position r."),
    json_out: bool = typer.Option(False, "--json", help="Machine-readable output."),
    plot: Path | None = typer.Option(None, "--plot", help="Write Fig. 2.10-style PNG to FILE."),
) -> None:
    """Final error of the sampled-and-held minimum-jerk input (2.14), Figs. 2.9-2.10."""
    from servokit.feedforward.minimum_jerk import minimum_jerk_zoh_plot, minimum_jerk_zoh_response

    res = minimum_jerk_zoh_response(T, target, tau)
    if plot is not None:
        import matplotlib.pyplot as plt

        fig = minimum_jerk_zoh_plot([res])
        fig.savefig(plot)
        plt.close(fig)
    data = {
        "T": T,
        "tau": tau,
        "target": target,
        "final_error": res.final_error,
        "final_velocity": res.final_velocity,
        "n_samples": int(res.u.size),
    }
    if json_out:
        emit_json(data)
        return
    console.print(f"minimum jerk T = {T:g} s, tau = {tau:g} s: y(T) - r = {res.final_error:.6g}")
