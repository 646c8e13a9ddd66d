"""``servokit simulate``: step or held-input response of a plant (set), optional feedback.

Flags -> :func:`simulate_job` (checked plants, inputs, actuator, memory) -> the simulator
(:func:`servokit.simulate.simulate`, or :func:`~servokit.simulate.simulate_saturated` with
a limited actuator) -> :func:`render_simulate`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
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
    variation_corners,
    wrote,
)
from servokit.cli._options import Output, SlewMaxOpt, u_max_option
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


VariantsOpt = Annotated[
    bool, typer.Option("--variants", help="run the 18 HDD benchmark variants (hdd-benchmark only)")
]
SubstepsOpt = Annotated[
    int, typer.Option("--substeps", help="fine steps per period for the continuous output [count]")
]
StepOpt = Annotated[
    float | None,
    typer.Option(
        "--step",
        help="step amplitude [output unit with a controller, input unit without]: reference "
        "step with a controller, held input step without",
    ),
]
InputOpt = Annotated[
    Path | None,
    typer.Option("--input", help="text file of held input samples, one per line", metavar="FILE"),
]
SimControllerOpt = Annotated[
    str | None,
    typer.Option(
        "--controller", help="'eq-4.69' or a controller .toml file", metavar="NAME_OR_TOML"
    ),
]
UMaxOpt = u_max_option("the actuator's clamp (the output is then sampled)")
AntiWindupOpt = Annotated[
    bool,
    typer.Option(
        "--anti-windup/--no-anti-windup",
        help="with --u-max/--slew-max and a controller: observer anti-windup",
    ),
]


@dataclass(frozen=True)
class SimulateFlags:
    """The flags of ``servokit simulate`` as typed."""

    dt: float
    duration: float
    plant: str
    variants: bool
    variations: Path | None
    substeps: int
    step: float | None
    input_file: Path | None
    controller: str | None
    settle_band: float
    u_max: float | None
    slew_max: float | None
    anti_windup: bool
    max_memory_mb: float
    plot: Path | None
    json_out: bool


@dataclass(frozen=True)
class SimulateJob:
    """A checked simulation: plants, held samples, inputs, actuator and output flags."""

    plants: list
    dt: float
    n_samples: int
    substeps: int
    controller: Any
    inputs: dict
    target: float
    settle_band: float
    actuator: Any
    output: Output


def _check_flags(f: SimulateFlags) -> int:
    """The flags checkable before a file is read; returns ``--substeps``."""
    if (f.step is None) == (f.input_file is None):
        raise ServokitValueError("give exactly one of --step AMP or --input FILE")
    check_positive("--dt", f.dt, "s")
    check_positive("--duration", f.duration, "s")
    check_positive("--settle-band", f.settle_band)
    substeps = check_count("--substeps", f.substeps)
    if f.duration < f.dt:
        raise ServokitValueError(
            f"--duration {f.duration:g} s is shorter than one --dt {f.dt:g} s; simulate at "
            "least one sampling period"
        )
    if f.variants and f.plant != "hdd-benchmark":
        raise ServokitValueError("--variants is only defined for --plant hdd-benchmark")
    if f.variants and f.variations is not None:
        raise ServokitValueError("give --variants or --variations FILE, not both")
    if f.input_file is not None:
        check_input_file(f.input_file, "--input")
    return substeps


def simulate_job(f: SimulateFlags) -> SimulateJob:
    """``servokit simulate``'s flags -> the checked simulation (memory estimated first).

    Parameters
    ----------
    f : SimulateFlags
        The flags as typed.

    Returns
    -------
    SimulateJob
    """
    substeps = _check_flags(f)
    output = Output.checked(f.plot, f.json_out)
    n_periods = f.duration / f.dt
    plants = _plants(f.plant, f.variants, f.variations)
    n_states = max(p.order for p in plants) + 4
    check_memory(
        n_periods * substeps * len(plants) * (n_states + _ARRAYS_PER_FINE_STEP) * 8,
        what=f"--duration {f.duration:g} / --dt {f.dt:g} x --substeps {substeps} "
        f"x {len(plants)} plant(s)",
        max_memory_mb=f.max_memory_mb,
    )
    K = int(np.ceil(n_periods))
    ctrl = None if f.controller is None else load_controller(f.controller, f.dt)
    kw, target = _inputs(f.step, f.input_file, ctrl, K)
    actuator = _actuator(f.u_max, f.slew_max, f.anti_windup and ctrl is not None)
    return SimulateJob(plants, f.dt, K, substeps, ctrl, kw, target, f.settle_band, actuator,
                       output)  # fmt: skip


@app.command(
    "simulate",
    epilog=example(
        "servokit simulate --plant hdd-sampled-data --dt 153.5e-6 --duration 0.02 --step 1 "
        "--controller eq-4.69 --json"
    )
    + "\n\n--variations FILE simulates every corner of the file's box (nominal, low, high of "
    "each range); --u-max/--slew-max limit the actuator (anti-windup for the controller; the "
    "output is then sampled).  JSON: plants, final_out, peak_out, settling_time_s, "
    "worst_plant, worst_settling_time_s (null: does not settle), reason, peak_input, u_max, "
    "plot.",
)
def simulate_cmd(
    dt: DtOpt,
    duration: DurationOpt,
    plant: PlantOpt = "hdd-benchmark",
    variants: VariantsOpt = False,
    variations: VariationsOpt = None,
    substeps: SubstepsOpt = 10,
    step: StepOpt = None,
    input_file: InputOpt = None,
    controller: SimControllerOpt = None,
    settle_band: SettleBandOpt = 0.1,
    u_max: UMaxOpt = None,
    slew_max: SlewMaxOpt = None,
    anti_windup: AntiWindupOpt = True,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Simulate the continuous output of a plant (set) on a fine grid."""
    job = simulate_job(SimulateFlags(**locals()))
    with flag_names(_FLAGS):
        res, met = _respond(job)
    render_simulate(job, res, met)


def _respond(job: SimulateJob) -> tuple[Any, Any]:
    """The simulator's response and its step metrics (the library calls of the command)."""
    from servokit.simulate import SimulationResult, simulate, simulate_saturated, step_metrics

    common = {"dt": job.dt, "n_samples": job.n_samples, "controller": job.controller}
    if job.actuator is not None:  # a limited actuator: the loop at the samples
        r = simulate_saturated(job.plants, actuator=job.actuator, **common, **job.inputs)
        res = SimulationResult(r.td, r.yd, r.td, r.yd, r.u, 1)
    else:
        res = simulate(job.plants, substeps=job.substeps, **common, **job.inputs)
    # open loop: the target is the final value of the (median) response
    target = job.target if job.controller is not None else float(np.median(res.yc[:, -1]))
    return res, step_metrics(res.t, res.yc, target, job.settle_band)


def render_simulate(job: SimulateJob, res: Any, met: Any) -> None:
    """Plot, print or emit the JSON of a simulation.

    Parameters
    ----------
    job : SimulateJob
        The checked simulation.
    res : servokit.simulate.SimulationResult
        The response.
    met : servokit.simulate.StepMetrics
        Its step metrics.
    """
    plants, plot = job.plants, job.output.plot
    if plot is not None:
        _plot(res, plants, job.dt, res.substeps, plot)
    times, reason = _settled(np.atleast_1d(met.settling_time), float(res.t[-1]))
    worst = None if reason else float(max(times))
    data = {
        "plants": [p.name for p in plants],
        "final_out": res.yc[:, -1],
        "peak_out": met.peak,
        "settling_time_s": times,
        "worst_plant": plants[met.worst].name,
        "worst_settling_time_s": worst,
        "reason": reason,
        "peak_input": float(np.max(np.abs(res.u))),
        "u_max": None if job.actuator is None or np.isinf(job.actuator.u_max)
        else job.actuator.u_max,
        "plot": str(plot) if plot else None,
    }  # fmt: skip
    if job.output.json_out:
        emit_json(data)
        return
    settle = (
        f"does not settle: {reason};" if reason else f"worst settling time {worst * 1e3:.4g} ms"
    )
    console.print(
        f"{len(plants)} plant(s); {settle} ({plants[met.worst].name}); "
        f"final value {np.median(res.yc[:, -1]):.6g}"
    )


#: A response counts as settled only if it stays in the band for at least this last
#: fraction of the simulated time: a diverging output "settles" at its last sample
#: otherwise (its own final value is the target of an open-loop run).
_SETTLED_TAIL = 0.1


def _settled(times: Any, t_end: float) -> tuple[list[float | None], str | None]:
    """Settling times [s] with None where the response does not settle, and the reason."""
    limit = (1 - _SETTLED_TAIL) * t_end
    out = [float(t) if np.isfinite(t) and t <= limit else None for t in times]
    if all(t is not None for t in out):
        return out, None
    return out, (
        f"the output is still outside the settling band in the last {_SETTLED_TAIL:.0%} "
        "of --duration (diverging or slower than --duration)"
    )


def _actuator(u_max: float | None, slew_max: float | None, anti_windup: bool) -> Any:
    """The checked ``--u-max``/``--slew-max`` actuator, or None without either."""
    from servokit.simulate import Actuator

    if u_max is None and slew_max is None:
        return None
    if u_max is not None:
        check_positive("--u-max", u_max)
    if slew_max is not None:
        check_positive("--slew-max", slew_max)
    return Actuator(
        u_max=float("inf") if u_max is None else u_max, slew_max=slew_max, anti_windup=anti_windup
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
