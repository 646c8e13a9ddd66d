"""``servokit switching ...``: initial value compensation and admissible sets (book ch. 3)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlantOpt,
    PlotOpt,
    console,
    emit_json,
    example,
    flag_names,
    load_plant,
    plot_target,
    started,
    sub_app,
    wrote,
)
from servokit.cli._options import (
    check_state_size,
    controller_states,
    discrete_states,
    load_controller_data,
    refuse_inapplicable,
)
from servokit.errors import (
    ServokitValueError,
    check_count,
    check_finite,
    check_memory,
    check_positive,
)

if TYPE_CHECKING:
    from servokit.switching import SwitchedLoop

switching_app = sub_app(
    "switching", "Mode switching: initial value compensation and admissible sets (book ch. 3)."
)

ControllerOpt = Annotated[
    str,
    typer.Option(
        "--controller",
        help="book controller (e.g. eq-4.69), discrete .toml, or 'lead-lag' (crossover --freq)",
        metavar="NAME_OR_TOML",
    ),
]
FreqOpt = Annotated[
    float, typer.Option("--freq", help="crossover of the 'lead-lag' controller [Hz]")
]
DtOpt = Annotated[
    float | None,
    typer.Option("--dt", help="sampling period [s] (default: the controller's)"),
]


#: Samples per cycle of the lead-lag crossover --freq accepted with --dt (below: beyond
#: Nyquist margin; above: the discretisation is numerically singular).
_MIN_SAMPLES_PER_CYCLE = 4
_MAX_SAMPLES_PER_CYCLE = 1e5


def _build_loop(
    plant: str, controller: str, freq: float, dt: float | None, max_memory_mb: float
) -> SwitchedLoop:
    """Discretise the plant at the controller's (or --dt) period and close the loop; a
    plant whose discrete loop would not fit --max-memory-mb is refused before it is built.

    Plant, controller and lead-lag are numpy data (the plant's exact ZOH by
    ``scipy.linalg.expm``, as :meth:`~servokit.models.ModalPlant.discretize`): the same
    matrices bit for bit, python-control left unloaded (start-up, issue 23)."""
    from servokit.switching import switched_loop
    from servokit.switching.design import lead_lag_data

    if dt is not None:
        check_positive("--dt", dt, "s")
    p = load_plant(plant)
    if controller == "lead-lag":
        if dt is None:
            raise ServokitValueError("--controller lead-lag needs --dt [s]")
        dt = check_positive("--dt", dt, "s")
        freq = check_positive("--freq", freq, "Hz")
        if not _MIN_SAMPLES_PER_CYCLE <= 1.0 / (dt * freq) <= _MAX_SAMPLES_PER_CYCLE:
            # outside this the discretised lead-lag is singular to double precision (poles
            # at 1 - 1e-7 and closer) and LAPACK's eigenvalue search may not return
            raise ServokitValueError(
                f"--dt {dt:g} s gives {1.0 / (dt * freq):.3g} samples per cycle of --freq "
                f"{freq:g} Hz; use {_MIN_SAMPLES_PER_CYCLE}..{_MAX_SAMPLES_PER_CYCLE:.0e}"
            )
        n = discrete_states(p, dt, _LEAD_LAG_STATES)
        check_state_size(n, what=f"--plant {plant} at --dt {dt:g}", max_memory_mb=max_memory_mb)
        pd = p.discretize_data(dt)
        return switched_loop(pd, lead_lag_data(pd, freq))
    refuse_inapplicable("--controller", controller, {"freq": ("--freq", ("lead-lag",))})
    ctrl = load_controller_data(controller, dt)
    n = discrete_states(p, float(ctrl.dt), controller_states(ctrl))
    check_state_size(n, what=f"--plant {plant}", max_memory_mb=max_memory_mb)
    return switched_loop(p.discretize_data(float(ctrl.dt)), ctrl)


#: States of the 'lead-lag' controller (a lead, a lag and an integrator at most).
_LEAD_LAG_STATES = 3


def _parse_complex(flag: str, text: str) -> list[complex]:
    try:
        values = [complex(v.replace(" ", "")) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ServokitValueError(
            f"{flag} must be comma-separated numbers such as 0.905,0.954 or 0.5+0.4j (got {text!r})"
        ) from None
    if not all(np.isfinite(v) for v in values):
        raise ServokitValueError(f"{flag} must be finite numbers (got {text!r})")
    return values


def _weight(loop: SwitchedLoop, spec: str) -> dict:
    """--weight: 'position' (Q = C^T C), 'input' (Q = Cu^T Cu, (3.91)) or a diagonal list."""
    if spec == "position":
        return {"output_weight": loop.C}
    if spec == "input":
        return {"output_weight": loop.Cu}
    diag = [c.real for c in _parse_complex("--weight", spec)]
    if len(diag) != loop.n + loop.m:
        raise ServokitValueError(
            f"--weight needs {loop.n + loop.m} diagonal entries (plant then controller "
            f"states), 'position' or 'input' (got {len(diag)})"
        )
    return {"Q": np.diag(diag)}


_INPUT_FLAGS = {
    "pole": "--pole",
    "order": "--order",
    "input_weight": "--input-weight",
    "jerk_weight": "--jerk-weight",
}


def _poles_json(poles: np.ndarray) -> list[dict]:
    return [{"re": float(p.real), "im": float(p.imag)} for p in np.sort_complex(poles)]


@switching_app.command(
    "ivc",
    epilog=example(
        "servokit switching ivc --plant hdd-sampled-data --controller eq-4.69 --method jmin",
        "servokit switching ivc --plant hdd-benchmark --controller lead-lag --freq 500 "
        "--dt 3.7879e-5 --method input --pole 0.6 --json",
    ),
)
def ivc_cmd(
    plant: PlantOpt = "hdd-sampled-data",
    controller: ControllerOpt = "eq-4.69",
    freq: FreqOpt = 500.0,
    dt: DtOpt = None,
    method: Annotated[
        str, typer.Option("--method", help="jmin (3.22), pole-zero (3.37) or input (3.46)")
    ] = "jmin",
    weight: Annotated[
        str, typer.Option("--weight", help="jmin: position, input or diagonal list of Q")
    ] = "position",
    poles: Annotated[
        str, typer.Option("--poles", help="pole-zero: closed-loop poles to cancel, comma list")
    ] = "",
    pole: Annotated[float, typer.Option("--pole", help="input: assigned pole of d[z] [1]")] = 0.6,
    order: Annotated[
        int | None, typer.Option("--order", help="input: degree g of n_k (default n + m - 1)")
    ] = None,
    input_weight: Annotated[
        float, typer.Option("--input-weight", help="input, g > n+m-1: weight q1 of |u|^2 (3.61)")
    ] = 0.0,
    jerk_weight: Annotated[
        float, typer.Option("--jerk-weight", help="input, g > n+m-1: weight q2 of |du|^2 (3.61)")
    ] = 0.0,
    n_samples: Annotated[
        int, typer.Option("--n-samples", help="samples of the plotted transient", min=2)
    ] = 200,
    max_memory_mb: MaxMemoryOpt = 2000.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Initial value compensation gain of a discrete loop (book §3.3.1-§3.3.2).

    JSON keys: method, dt_s, n_plant_states, n_controller_states, closed_loop_poles,
    gain (K, m x n: xc[0] = K xp[0]) or numerators/denominator (input: r' = n_k/d xp_k[0]),
    zeros_position (zeros of xp_1[0] -> y after IVC, without the factor z).
    """
    plot = plot_target(plot)
    _check_ivc_request(method, poles, n_samples, input_weight, jerk_weight)
    loop = _build_loop(plant, controller, freq, dt, max_memory_mb)
    out, K, design = _ivc_design(
        loop, method, weight, poles, pole, order, input_weight, jerk_weight
    )
    if plot is not None:
        _ivc_plot(loop, K, design, n_samples, plot)
        out["plot"] = str(plot)
    _ivc_render(out, loop, K, design, json_out)


def _check_ivc_request(
    method: str, poles: str, n_samples: int, input_weight: float, jerk_weight: float
) -> None:
    """The ivc flags that need no loop, checked before it is built."""
    check_count("--n-samples", n_samples, lo=2, hi=1_000_000)
    for flag, w in (("--input-weight", input_weight), ("--jerk-weight", jerk_weight)):
        if float(check_finite(flag, w)) < 0:
            raise ServokitValueError(f"{flag} must be >= 0 (got {w})")
    if method not in ("jmin", "pole-zero", "input"):
        raise ServokitValueError(f"--method must be jmin, pole-zero or input (got {method!r})")
    if method == "pole-zero" and not poles:
        raise ServokitValueError("--method pole-zero needs --poles, e.g. --poles 0.905,0.954")
    refuse_inapplicable("--method", method, _IVC_APPLIES)


#: the ivc flags that belong to one method (given with another they are refused)
_IVC_APPLIES = {
    "weight": ("--weight", ("jmin",)),
    "poles": ("--poles", ("pole-zero",)),
    "pole": ("--pole", ("input",)),
    "order": ("--order", ("input",)),
    "input_weight": ("--input-weight", ("input",)),
    "jerk_weight": ("--jerk-weight", ("input",)),
}


def _ivc_design(
    loop: SwitchedLoop, method: str, weight: str, poles: str, pole: float,
    order: int | None, input_weight: float, jerk_weight: float,
) -> tuple[dict, np.ndarray | None, object]:
    """The IVC of ``method``: (JSON data, gain K or None, additional-input design or None)."""
    from servokit.switching import ivc_additional_input, ivc_jmin, ivc_pole_zero, ivc_zeros

    out: dict = {
        "method": method,
        "dt_s": loop.dt,
        "n_plant_states": loop.n,
        "n_controller_states": loop.m,
        "closed_loop_poles": _poles_json(loop.poles()),
    }
    if method != "input":
        if method == "jmin":
            K = ivc_jmin(loop, None, **_weight(loop, weight))
        else:
            K = ivc_pole_zero(loop, None, _parse_complex("--poles", poles))
        return out | {"gain": K, "zeros_position": _poles_json(ivc_zeros(loop, K, 0))}, K, None
    if not abs(pole) < 1:
        raise ServokitValueError(f"--pole must lie inside the unit circle (got {pole})")
    unweighted = input_weight <= 0 and jerk_weight <= 0
    if order is not None and order > loop.n + loop.m - 1 and unweighted:
        raise ServokitValueError("--order above n + m - 1 needs --input-weight or --jerk-weight")
    with flag_names(_INPUT_FLAGS):
        design = ivc_additional_input(
            loop, pole, order=order, input_weight=input_weight, jerk_weight=jerk_weight
        )
    return out | {"numerators": design.num, "denominator": design.den}, None, design


def _ivc_render(
    out: dict, loop: SwitchedLoop, K: np.ndarray | None, design: object, json_out: bool
) -> None:
    if json_out:
        emit_json(out)
        return
    console.print(f"closed loop: {loop.n} plant + {loop.m} controller states, dt = {loop.dt:g} s")
    if K is not None:
        console.print(
            f"IVC gain K (xc[0] = K xp[0]), {out['method']}:\n{np.array2string(K, precision=5)}"
        )
    else:
        console.print(f"r' = n_k/d xp_k[0]; d = {np.array2string(design.den, precision=5)}")


def _ivc_plot(loop, K, design, n: int, path) -> None:
    from servokit.switching import additional_input_response, free_response
    from servokit.switching.plots import transient_plot

    xp = np.eye(loop.n)[0]
    y0 = free_response(loop.A, loop.C, loop.stack(np.zeros((loop.m, loop.n))) @ xp, n)[:, 0]
    if K is not None:
        y1 = free_response(loop.A, loop.C, loop.stack(K) @ xp, n)[:, 0]
    else:
        y1 = additional_input_response(loop, design, xp, n)[0]
    t = np.arange(n) * loop.dt * 1e3
    transient_plot(
        t,
        [("unit initial plant state 1", {"with IVC": y1, "zero reset": y0})],
        xlabel="Time [ms]",
        ylabel="Output [plant output unit]",
        title="Free response after switching (cf. Figs. 3.6, 3.8)",
        path=path,
    )
    wrote(path)


@switching_app.command(
    "admissible-set",
    epilog=example(
        "servokit switching admissible-set --plant hdd-benchmark --controller lead-lag "
        "--freq 500 --dt 3.7879e-5 --u-max 0.02 --condition -16:3.9e4 --plot set.png"
    ),
)
def admissible_cmd(
    plant: PlantOpt = "hdd-benchmark",
    controller: ControllerOpt = "lead-lag",
    freq: FreqOpt = 500.0,
    dt: DtOpt = 60.0 / 7200.0 / 220.0,
    u_max: Annotated[float, typer.Option("--u-max", help="input bound |u| <= u_max [A]")] = 0.02,
    condition: Annotated[
        list[str] | None,
        typer.Option(
            "--condition",
            help="switching condition POSITION:VELOCITY [output unit, output unit/s] (repeatable)",
        ),
    ] = None,
    t_max: Annotated[
        int, typer.Option("--t-max", help="largest horizon tried [samples]", min=1)
    ] = 500,
    max_memory_mb: MaxMemoryOpt = 2000.0,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Maximal output admissible set of the loop for |u| <= u_max, with J-min IVC
    (J = sum u^2, (3.91)) and with zero reset (book §3.3.3, (3.82)-(3.92)).

    The 2-D slice is over the first two plant states (rigid-body position and velocity
    of a catalogue plant), the others at rest. JSON keys: t_star, n_inequalities,
    polygon_ivc, polygon_zero_reset (vertices [position, velocity]), conditions (position_out,
    velocity_out_per_s, admissible_ivc, admissible_zero_reset, needed_u_ivc, needed_u_zero_reset).
    """
    from servokit.switching import admissible_conditions

    plot = plot_target(plot)
    u_max = check_positive("--u-max", u_max)
    pts = [_parse_condition(c) for c in condition or []]
    loop = _build_loop(plant, controller, freq, dt, max_memory_mb)
    N = loop.n + loop.m
    check_memory(
        8.0 * 2 * t_max * N * (N + 2),
        what=f"--t-max {t_max} with {N} states",
        max_memory_mb=max_memory_mb,
    )
    # the LPs take a second or more: say so once every argument has passed its checks
    started("switching admissible-set", f"O_inf of {N} states, horizons up to {t_max} samples")
    res = admissible_conditions(loop, u_max, pts, t_max=t_max)
    _admissible_render(res, pts, u_max, plot, json_out)


def _admissible_render(res: object, pts: list, u_max: float, plot: object, json_out: bool) -> None:
    out = {
        "t_star": res.t_star,
        "n_inequalities": res.n_inequalities,
        "polygon_ivc": res.ivc.polygon(),
        "polygon_zero_reset": res.zero_reset.polygon(),
        "conditions": res.conditions,
    }
    if plot is not None:
        from servokit.switching.plots import admissible_plot

        admissible_plot(
            {"O_inf with IVC": res.ivc, "O_inf with zero reset": res.zero_reset},
            points={f"condition {i + 1}": p for i, p in enumerate(pts)},
            xlabel="Position [plant output unit]",
            ylabel="Velocity [unit/s]",
            title=f"Maximal output admissible sets, |u| <= {u_max:g} (cf. Fig. 3.16)",
            path=plot,
        )
        wrote(plot)
        out["plot"] = str(plot)
    if json_out:
        emit_json(out)
        return
    console.print(f"O_inf determined at t* = {res.t_star} ({res.n_inequalities} inequalities)")
    for i, r in enumerate(res.conditions):
        console.print(
            f"condition {i + 1} ({r['position_out']:g}, {r['velocity_out_per_s']:g}): "
            f"IVC {'admissible' if r['admissible_ivc'] else 'violates'} "
            f"(needs {r['needed_u_ivc']:.4g}), zero reset "
            f"{'admissible' if r['admissible_zero_reset'] else 'violates'} "
            f"(needs {r['needed_u_zero_reset']:.4g})"
        )


def _parse_condition(text: str) -> np.ndarray:
    try:
        pos, vel = (float(v) for v in text.split(":"))
    except ValueError:
        raise ServokitValueError(
            f"--condition must be POSITION:VELOCITY, e.g. -16:3.9e4 (got {text!r})"
        ) from None
    if not (np.isfinite(pos) and np.isfinite(vel)):
        raise ServokitValueError(f"--condition must be finite (got {text!r})")
    return np.array([pos, vel])


@switching_app.command(
    "cost-map",
    epilog=example(
        "servokit switching cost-map --plant hdd-benchmark --controller lead-lag --freq 500 "
        "--dt 3.7879e-5 --position -60 --vel-range -1e5:1e5 --acc-range -1e9:1e9 --json"
    ),
)
def cost_map_cmd(
    plant: PlantOpt = "hdd-benchmark",
    controller: ControllerOpt = "lead-lag",
    freq: FreqOpt = 500.0,
    dt: DtOpt = 60.0 / 7200.0 / 220.0,
    position: Annotated[
        float, typer.Option("--position", help="plant state 1 at the switch [output unit]")
    ] = -60.0,
    vel_range: Annotated[
        str, typer.Option("--vel-range", help="LOW:HIGH of plant state 2 [output unit/s]")
    ] = "-1e5:1e5",
    acc_range: Annotated[
        str, typer.Option("--acc-range", help="LOW:HIGH of plant state 3 (0:0 for none)")
    ] = "0:0",
    n_points: Annotated[int, typer.Option("--n-points", help="grid points per axis", min=2)] = 41,
    ivc: Annotated[str, typer.Option("--ivc", help="jmin (J = sum u^2) or none")] = "jmin",
    max_memory_mb: MaxMemoryOpt = 2000.0,
    json_out: JsonOpt = False,
) -> None:
    """Squared H2 norms of the input and output after the switch over initial states
    (book §3.3.3, (3.65)-(3.81), Fig. 3.13) and the best free states for --position (3.81).

    JSON keys: velocity_out_per_s, acceleration_out_per_s2 (grid), ju, jy (maps, rows over
    acceleration), optimal_state (the plant states minimising Ju with state 1 fixed:
    position_out, velocity_out_per_s, acceleration_out_per_s2 when the plant has a third
    state; any further states are held at 0).
    """
    from servokit.switching import ivc_jmin, switching_cost_grid

    check_finite("--position", position)
    if ivc not in ("jmin", "none"):
        raise ServokitValueError(f"--ivc must be jmin or none (got {ivc!r})")
    vel = _parse_range("--vel-range", vel_range)
    acc = _parse_range("--acc-range", acc_range)
    check_memory(8.0 * 4 * n_points**2, what=f"--n-points {n_points}", max_memory_mb=max_memory_mb)
    loop = _build_loop(plant, controller, freq, dt, max_memory_mb)
    K = ivc_jmin(loop, None, output_weight=loop.Cu) if ivc == "jmin" else None
    with flag_names(_COST_FLAGS):
        grid = switching_cost_grid(loop, K, position, vel, acc, n_points)
    if json_out:
        emit_json({
            "velocity_out_per_s": grid.velocity, "acceleration_out_per_s2": grid.acceleration,
            "ju": grid.cost.ju, "jy": grid.cost.jy,
            "optimal_state": _state_keys(grid.optimal_state),
        })  # fmt: skip
        return
    console.print(
        f"min Ju on the grid {np.min(grid.cost.ju):.4g}; best free states for "
        f"position {position:g}: {np.array2string(grid.optimal_state[grid.free], precision=5)}"
    )


def _state_keys(x) -> dict[str, float]:  # noqa: ANN001
    """Plant states 1-3 of a switching state under their unit-suffixed names."""
    names = ("position_out", "velocity_out_per_s", "acceleration_out_per_s2")
    return {k: float(v) for k, v in zip(names, x, strict=False)}


_COST_FLAGS = {"position": "--position", "vel_range": "--vel-range", "acc_range": "--acc-range"}


def _parse_range(flag: str, text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(":"))
    except ValueError:
        raise ServokitValueError(f"{flag} must be LOW:HIGH, e.g. -1e5:1e5 (got {text!r})") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        raise ServokitValueError(f"{flag} needs finite LOW <= HIGH (got {text!r})")
    return lo, hi
