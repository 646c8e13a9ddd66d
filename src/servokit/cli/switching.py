"""``servokit switching ...``: initial value compensation and admissible sets (book ch. 3)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

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
    load_controller,
    load_plant,
    plot_target,
    sub_app,
    wrote,
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

PlantOpt = Annotated[
    str, typer.Option("--plant", help="catalogue name or .toml plant file", metavar="NAME_OR_TOML")
]
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


def _build_loop(plant: str, controller: str, freq: float, dt: float | None) -> SwitchedLoop:
    """Discretise the plant at the controller's (or --dt) period and close the loop."""
    from servokit.switching import switched_loop
    from servokit.switching.design import lead_lag

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
        pd = p.discretize(dt)
        return switched_loop(pd, lead_lag(pd, freq))
    ctrl = load_controller(controller, dt)
    return switched_loop(p.discretize(float(ctrl.dt)), ctrl)


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
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Initial value compensation gain of a discrete loop (book §3.3.1-§3.3.2).

    JSON keys: method, dt_s, n_plant_states, n_controller_states, closed_loop_poles,
    gain (K, m x n: xc[0] = K xp[0]) or numerators/denominator (input: r' = n_k/d xp_k[0]),
    zeros_position (zeros of xp_1[0] -> y after IVC, without the factor z).
    """
    from servokit.switching import ivc_additional_input, ivc_jmin, ivc_pole_zero, ivc_zeros

    plot = plot_target(plot)
    check_count("--n-samples", n_samples, lo=2, hi=1_000_000)
    for flag, w in (("--input-weight", input_weight), ("--jerk-weight", jerk_weight)):
        if float(check_finite(flag, w)) < 0:
            raise ServokitValueError(f"{flag} must be >= 0 (got {w})")
    if method not in ("jmin", "pole-zero", "input"):
        raise ServokitValueError(f"--method must be jmin, pole-zero or input (got {method!r})")
    if method == "pole-zero" and not poles:
        raise ServokitValueError("--method pole-zero needs --poles, e.g. --poles 0.905,0.954")
    loop = _build_loop(plant, controller, freq, dt)
    out: dict = {
        "method": method,
        "dt_s": loop.dt,
        "n_plant_states": loop.n,
        "n_controller_states": loop.m,
        "closed_loop_poles": _poles_json(loop.poles()),
    }
    if method == "input":
        if not abs(pole) < 1:
            raise ServokitValueError(f"--pole must lie inside the unit circle (got {pole})")
        unweighted = input_weight <= 0 and jerk_weight <= 0
        if order is not None and order > loop.n + loop.m - 1 and unweighted:
            raise ServokitValueError(
                "--order above n + m - 1 needs --input-weight or --jerk-weight"
            )
        with flag_names(_INPUT_FLAGS):
            design = ivc_additional_input(
                loop, pole, order=order, input_weight=input_weight, jerk_weight=jerk_weight
            )
        out |= {"numerators": design.num, "denominator": design.den}
        K = None
    else:
        if method == "jmin":
            K = ivc_jmin(loop, None, **_weight(loop, weight))
        else:
            K = ivc_pole_zero(loop, None, _parse_complex("--poles", poles))
        out |= {"gain": K, "zeros_position": _poles_json(ivc_zeros(loop, K, 0))}
    if plot is not None:
        _ivc_plot(loop, K, design if K is None else None, n_samples, plot)
        out["plot"] = str(plot)
    if json_out:
        emit_json(out)
        return
    console.print(f"closed loop: {loop.n} plant + {loop.m} controller states, dt = {loop.dt:g} s")
    if K is not None:
        console.print(f"IVC gain K (xc[0] = K xp[0]), {method}:\n{np.array2string(K, precision=5)}")
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
    from servokit.switching import ivc_jmin, max_output_admissible_set

    plot = plot_target(plot)
    u_max = check_positive("--u-max", u_max)
    pts = [_parse_condition(c) for c in condition or []]
    loop = _build_loop(plant, controller, freq, dt)
    N = loop.n + loop.m
    check_memory(
        8.0 * 2 * t_max * N * (N + 2),
        what=f"--t-max {t_max} with {N} states",
        max_memory_mb=max_memory_mb,
    )
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    full = max_output_admissible_set(loop.A, loop.Cu, -u_max, u_max, t_max=t_max)
    E = np.eye(loop.n)[:, :2]
    sets = {
        "ivc": full.restrict(loop.stack(K) @ E),
        "zero_reset": full.restrict(loop.stack(np.zeros_like(K)) @ E),
    }
    rows = []
    for x in pts:
        need = {k: float(s.gauge(x)[0]) * u_max for k, s in sets.items()}
        rows.append(
            {
                "position_out": x[0],
                "velocity_out_per_s": x[1],
                "admissible_ivc": need["ivc"] <= u_max * (1 + 1e-9),
                "admissible_zero_reset": need["zero_reset"] <= u_max * (1 + 1e-9),
                "needed_u_ivc": need["ivc"],
                "needed_u_zero_reset": need["zero_reset"],
            }
        )
    out = {
        "t_star": full.t_star,
        "n_inequalities": len(full.h),
        "polygon_ivc": sets["ivc"].polygon(),
        "polygon_zero_reset": sets["zero_reset"].polygon(),
        "conditions": rows,
    }
    if plot is not None:
        from servokit.switching.plots import admissible_plot

        admissible_plot(
            {"O_inf with IVC": sets["ivc"], "O_inf with zero reset": sets["zero_reset"]},
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
    console.print(f"O_inf determined at t* = {full.t_star} ({len(full.h)} inequalities)")
    for i, r in enumerate(rows):
        console.print(
            f"condition {i + 1} ({r['position']:g}, {r['velocity']:g}): "
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
    acceleration), optimal_state (plant states minimising Ju with state 1 fixed).
    """
    from servokit.switching import (
        ivc_jmin,
        optimal_condition,
        switching_cost_map,
        switching_cost_matrix,
    )

    check_finite("--position", position)
    if ivc not in ("jmin", "none"):
        raise ServokitValueError(f"--ivc must be jmin or none (got {ivc!r})")
    vel = _parse_range("--vel-range", vel_range)
    acc = _parse_range("--acc-range", acc_range)
    check_memory(8.0 * 4 * n_points**2, what=f"--n-points {n_points}", max_memory_mb=max_memory_mb)
    loop = _build_loop(plant, controller, freq, dt)
    K = ivc_jmin(loop, None, output_weight=loop.Cu) if ivc == "jmin" else None
    base = np.zeros(loop.n)
    base[0] = float(check_finite("--position", position))
    with_acc = acc[0] != acc[1]
    if with_acc and loop.n < 3:
        raise ServokitValueError("--acc-range needs a plant with a third state; use 0:0")
    v = np.linspace(*vel, n_points)
    # without acceleration the second axis is state 1 held at --position (one map row)
    a = np.linspace(*acc, n_points) if with_acc else np.zeros(1)
    axes, second = ((1, 2), a) if with_acc else ((1, 0), np.array([position]))
    cmap = switching_cost_map(loop, K, base, axes, v, second)
    if not (np.any(np.isfinite(cmap.ju)) or np.any(np.isfinite(cmap.jy))):
        # every cell overflowed: the map would be all null, which answers nothing
        raise ServokitValueError(
            f"--position {position:g}: the switching cost overflows at every grid point; "
            "give a position (and --vel-range/--acc-range) of the plant's scale"
        )
    M = switching_cost_matrix(loop, K, loop.Cu)
    free = [1, 2] if with_acc else [1]
    best = optimal_condition(M, base, free)
    out = {
        "velocity_out_per_s": v,
        "acceleration_out_per_s2": a,
        "ju": cmap.ju, "jy": cmap.jy, "optimal_state": best}
    if json_out:
        emit_json(out)
        return
    console.print(
        f"min Ju on the grid {np.min(cmap.ju):.4g}; best free states for "
        f"position {position:g}: {np.array2string(best[free], precision=5)}"
    )


def _parse_range(flag: str, text: str) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in text.split(":"))
    except ValueError:
        raise ServokitValueError(f"{flag} must be LOW:HIGH, e.g. -1e5:1e5 (got {text!r})") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
        raise ServokitValueError(f"{flag} needs finite LOW <= HIGH (got {text!r})")
    return lo, hi
