"""``servokit simulate``: step or held-input response of a plant (set), optional feedback."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer

from servokit._figures import save_figure
from servokit.cli._app import app, console, emit_json
from servokit.errors import ServokitValueError
from servokit.models import get_discrete_controller, get_plant, hdd_benchmark_variants
from servokit.simulate import simulate, step_metrics


@app.command("simulate")
def simulate_cmd(
    plant: str = typer.Option("hdd-benchmark", help="catalogue name or .toml plant file"),
    variants: bool = typer.Option(
        False, help="run the 18 HDD benchmark variants (hdd-benchmark only)"
    ),
    dt: float = typer.Option(..., help="sampling / hold period [s]"),
    duration: float = typer.Option(..., help="simulated time [s]"),
    substeps: int = typer.Option(10, help="fine steps per period for the continuous output"),
    step: float | None = typer.Option(
        None, help="step amplitude: reference step with a controller, held input step without"
    ),
    input_file: Path | None = typer.Option(None, "--input", help="text file of held input samples"),
    controller: str | None = typer.Option(None, help="'eq-4.69' or a controller .toml file"),
    band: float = typer.Option(0.1, help="settling band around the final target"),
    plot: Path | None = typer.Option(None, "--plot", help="write the response plot here"),
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
) -> None:
    """Simulate the continuous output of a plant (set) on a fine grid."""
    if (step is None) == (input_file is None):
        raise ServokitValueError("give exactly one of --step AMP or --input FILE")
    if dt <= 0 or duration <= 0:
        raise ServokitValueError("--dt and --duration must be > 0")
    plants = hdd_benchmark_variants() if variants else [get_plant(plant)]
    if variants and plant != "hdd-benchmark":
        raise ServokitValueError("--variants is only defined for --plant hdd-benchmark")
    K = int(np.ceil(duration / dt))
    ctrl = None if controller is None else get_discrete_controller(controller, dt)
    kw: dict = {}
    target = 0.0
    if step is not None and ctrl is not None:
        kw["reference"] = np.full(K, step)
        target = step
    elif step is not None:
        kw["feedforward"] = np.full(K, step)
    else:
        try:
            samples = np.loadtxt(input_file, ndmin=1)
        except (OSError, ValueError) as exc:
            raise ServokitValueError(f"--input {input_file}: cannot read samples ({exc})") from None
        kw["feedforward"] = samples
    res = simulate(plants, dt=dt, n_samples=K, substeps=substeps, controller=ctrl, **kw)
    if ctrl is None:
        target = float(np.median(res.yc[:, -1]))
    met = step_metrics(res.t, res.yc, target, band)
    if plot is not None:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(7, 4))
        for p, y in zip(plants, res.yc, strict=True):
            ax.plot(res.t * 1e3, y, lw=0.9, label=p.name if len(plants) < 5 else None)
        ax.set_xlabel("Time [ms]")
        ax.set_ylabel("Output [plant units]")
        ax.set_title(f"Response on a {dt / substeps * 1e6:.3g} us grid")
        ax.grid(alpha=0.3)
        if len(plants) < 5:
            ax.legend()
        save_figure(fig, plot, dpi=120)
    data = {
        "plants": [p.name for p in plants],
        "final": res.yc[:, -1],
        "peak": met.peak,
        "settling_time_s": met.settling_time,
        "worst_plant": plants[met.worst].name,
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"{len(plants)} plant(s); worst settling time {met.worst_settling_time * 1e3:.4g} ms "
        f"({plants[met.worst].name}); final value {np.median(res.yc[:, -1]):.6g}"
    )
