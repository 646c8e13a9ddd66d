"""``servokit simulate``: step or held-input response of a plant (set), optional feedback."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import (
    DtOpt,
    DurationOpt,
    JsonOpt,
    MaxMemoryOpt,
    PlantOpt,
    PlotOpt,
    SettleBandOpt,
    VariationsOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_controller,
    load_plant,
    load_variations,
    plot_target,
    variation_corners,
    wrote,
)
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_input_file,
    check_memory,
    check_positive,
)

_FLAGS = {
    "dt": "--dt",
    "n_samples": "--duration",
    "substeps": "--substeps",
    "feedforward": "--input",
    "controller": "--controller",
    "band": "--settle-band",
}
# yc, t and the modal state history are kept per fine step and plant
_ARRAYS_PER_FINE_STEP = 3


@app.command(
    "simulate",
    epilog=example(
        "servokit simulate --plant hdd-sampled-data --dt 153.5e-6 --duration 0.02 --step 1 "
        "--controller eq-4.69 --json"
    )
    + "  --variations FILE simulates every corner of the file's box (nominal, low, high of "
    "each range).  JSON: plants, final, peak, settling_time_s, worst_plant, "
    "worst_settling_time_s, plot.",
)
def simulate_cmd(
    dt: DtOpt,
    duration: DurationOpt,
    plant: PlantOpt = "hdd-benchmark",
    variants: Annotated[
        bool,
        typer.Option("--variants", help="run the 18 HDD benchmark variants (hdd-benchmark only)"),
    ] = False,
    variations: VariationsOpt = None,
    substeps: Annotated[
        int,
        typer.Option("--substeps", help="fine steps per period for the continuous output [count]"),
    ] = 10,
    step: Annotated[
        float | None,
        typer.Option(
            "--step",
            help="step amplitude [output unit with a controller, input unit without]: "
            "reference step with a controller, held input step without",
        ),
    ] = None,
    input_file: Annotated[
        Path | None,
        typer.Option(
            "--input", help="text file of held input samples, one per line", metavar="FILE"
        ),
    ] = None,
    controller: Annotated[
        str | None,
        typer.Option(
            "--controller", help="'eq-4.69' or a controller .toml file", metavar="NAME_OR_TOML"
        ),
    ] = None,
    settle_band: SettleBandOpt = 0.1,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Simulate the continuous output of a plant (set) on a fine grid."""
    if (step is None) == (input_file is None):
        raise ServokitValueError("give exactly one of --step AMP or --input FILE")
    check_positive("--dt", dt, "s")
    check_positive("--duration", duration, "s")
    check_positive("--settle-band", settle_band)
    substeps = check_count("--substeps", substeps)
    if duration < dt:
        raise ServokitValueError(
            f"--duration {duration:g} s is shorter than one --dt {dt:g} s; simulate at least "
            "one sampling period"
        )
    if variants and plant != "hdd-benchmark":
        raise ServokitValueError("--variants is only defined for --plant hdd-benchmark")
    if variants and variations is not None:
        raise ServokitValueError("give --variants or --variations FILE, not both")
    if input_file is not None:
        check_input_file(input_file, "--input")
    plot = plot_target(plot)
    n_periods = duration / dt
    plants = _plants(plant, variants, variations)
    n_states = max(p.order for p in plants) + 4
    check_memory(
        n_periods * substeps * len(plants) * (n_states + _ARRAYS_PER_FINE_STEP) * 8,
        what=f"--duration {duration:g} / --dt {dt:g} x --substeps {substeps} "
        f"x {len(plants)} plant(s)",
        max_memory_mb=max_memory_mb,
    )
    import numpy as np

    K = int(np.ceil(n_periods))
    ctrl = None if controller is None else load_controller(controller, dt)
    kw, target = _inputs(step, input_file, ctrl, K)
    with flag_names(_FLAGS):
        from servokit.simulate import simulate, step_metrics

        res = simulate(plants, dt=dt, n_samples=K, substeps=substeps, controller=ctrl, **kw)
        if ctrl is None:
            target = float(np.median(res.yc[:, -1]))
        met = step_metrics(res.t, res.yc, target, settle_band)
    if plot is not None:
        _plot(res, plants, dt, substeps, plot)
    data = {
        "plants": [p.name for p in plants],
        "final": res.yc[:, -1],
        "peak": met.peak,
        "settling_time_s": met.settling_time,
        "worst_plant": plants[met.worst].name,
        "worst_settling_time_s": met.worst_settling_time,
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"{len(plants)} plant(s); worst settling time {met.worst_settling_time * 1e3:.4g} ms "
        f"({plants[met.worst].name}); final value {np.median(res.yc[:, -1]):.6g}"
    )


def _plants(plant: str, variants: bool, variations: Path | None) -> list:
    if variations is not None:  # every range at nominal / low / high (gain included)
        return variation_corners(load_variations(variations, fallback=load_plant(plant)))
    if variants:
        from servokit.models import hdd_benchmark_variants

        return hdd_benchmark_variants()
    return [load_plant(plant)]


def _inputs(step: float | None, input_file: Path | None, ctrl, K: int) -> tuple[dict, float]:  # noqa: ANN001
    """Reference or held feedforward samples, and the step target (0 if open loop)."""
    import numpy as np

    from servokit.errors import check_finite

    if step is not None:
        step = float(check_finite("--step", step))
        return (
            ({"reference": np.full(K, step)}, step)
            if ctrl is not None
            else ({"feedforward": np.full(K, step)}, 0.0)
        )
    try:
        samples = np.loadtxt(input_file, ndmin=1)
    except (OSError, ValueError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ServokitValueError(f"--input {input_file}: cannot read samples ({first})") from None
    if samples.ndim != 1 or samples.size == 0:
        raise ServokitValueError(f"--input {input_file}: give one number per line")
    check_finite(f"--input {input_file}", samples)
    return {"feedforward": samples}, 0.0


def _plot(res, plants, dt: float, substeps: int, path: Path) -> None:  # noqa: ANN001
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    fig, ax = plt.subplots(figsize=(7, 4))
    for p, y in zip(plants, res.yc, strict=True):
        ax.plot(res.t * 1e3, y, lw=0.9, label=p.name if len(plants) < 5 else None)
    ax.set_xlabel("Time [ms]")
    ax.set_ylabel("Output [plant units]")
    ax.set_title(f"Response on a {dt / substeps * 1e6:.3g} us grid")
    ax.grid(alpha=0.3)
    if len(plants) < 5:
        ax.legend()
    save_figure(fig, path, dpi=120)
    wrote(path)
