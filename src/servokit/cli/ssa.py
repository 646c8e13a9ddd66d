"""``servokit ssa ...``: self-sensing bridges, active mode damping, adaptive SSA (§5.4)."""

from __future__ import annotations

from typing import Annotated

import numpy as np
import typer

from servokit.cli._app import JsonOpt, console, emit_json, example, flag_names, started, sub_app
from servokit.cli._options import FLAG_RANGES
from servokit.errors import ServokitValueError

ssa_app = sub_app("ssa", "Self-sensing actuation (book §5.4): bridges, mode damping, adaptive.")


def _report(data: dict, json_out: bool) -> None:
    if json_out:
        emit_json(data)
        return
    for key, value in data.items():
        shown = np.round(value, 6).tolist() if isinstance(value, np.ndarray | list) else value
        console.print(f"{key}: {shown}")


@ssa_app.command(
    "ddssa",
    epilog=example("servokit ssa ddssa --c-pzt 2e-9 --c1 2e-9 --c2 2e-9 --c3 2e-9 --freq 1000"),
)
def ddssa_cmd(
    c_pzt: Annotated[float, typer.Option("--c-pzt", help="PZT capacitance CPZT [F]")] = 2e-9,
    c1: Annotated[float, typer.Option("--c1", help="C1 [F]")] = 2e-9,
    c2: Annotated[float, typer.Option("--c2", help="C2 [F]")] = 2e-9,
    c3: Annotated[float, typer.Option("--c3", help="C3 [F]")] = 2e-9,
    r1: Annotated[float | None, typer.Option("--r1", help="drift resistor R1 || C1 [ohm]")] = None,
    r3: Annotated[float | None, typer.Option("--r3", help="drift resistor R3 || C3 [ohm]")] = None,
    freq: Annotated[float, typer.Option("--freq", help="evaluation frequency [Hz]")] = 1000.0,
    json_out: JsonOpt = False,
) -> None:
    """Direct-driven bridge (Fig. 5.27, eqs. 5.59-5.62): vs = a uM + b vM at --freq.

    JSON keys: balanced, freq_hz, um_gain, vm_gain (magnitudes of a and b).
    """
    from servokit.feedback.ssa import ddssa_response

    names = {
        "c_pzt": "--c-pzt",
        "c1": "--c1",
        "c2": "--c2",
        "c3": "--c3",
        "r1": "--r1",
        "r3": "--r3",
    }
    if not (np.isfinite(freq) and freq > 0):
        raise ServokitValueError(f"--freq must be > 0 Hz (got {freq})")
    with flag_names(names):
        from_um, from_vm, balanced = ddssa_response(c_pzt, c1, c2, c3, freq, r1=r1, r3=r3)
    _report(
        {
            "balanced": balanced,
            "freq_hz": freq,
            "um_gain": float(abs(from_um)),
            "vm_gain": float(abs(from_vm)),
        },
        json_out,
    )


@ssa_app.command("idssa", epilog=example("servokit ssa idssa --c 1e-9 --r 10e3 --k 2"))
def idssa_cmd(
    c: Annotated[float, typer.Option("--c", help="C1 = C2 = C3 = C4 = CPZT = C'PZT [F]")] = 1e-9,
    r: Annotated[float, typer.Option("--r", help="R1 = R2 = R3 = R4 [ohm]")] = 10e3,
    k: Annotated[float, typer.Option("--k", help="R6 = R7 = k R5, R5 = R8 (gain) [1]")] = 1.0,
    json_out: JsonOpt = False,
) -> None:
    """Indirect-driven bridge balanced as in (5.65): the high-pass (5.66) vS/vM.

    JSON keys: fc_hz, damping, gain, um_leak_at_fc (|vS/uM| at fc, 0 at balance).
    """
    from servokit.feedback.ssa import idssa_response

    for flag, v in (("--c", c), ("--r", r), ("--k", k)):
        if not (np.isfinite(v) and v > 0):
            raise ServokitValueError(f"{flag} must be > 0 (got {v})")
    args = ((c, c, c, c), c, c, (r, r, r, r, 1e3, k * 1e3, k * 1e3, 1e3))
    fc_hz, damping, gain = idssa_response(*args, 1.0)[2]
    leak = float(abs(idssa_response(*args, fc_hz)[0]))
    _report({"fc_hz": fc_hz, "damping": damping, "gain": gain, "um_leak_at_fc": leak}, json_out)


def _parse_mode(text: str) -> tuple[float, float, float]:
    try:
        f, eps, kappa = (float(x) for x in text.split(":"))
    except ValueError:
        raise ServokitValueError(
            f"--mode {text!r}: write FREQ_HZ:EPS:KAPPA, e.g. 9103:2:10"
        ) from None
    lo, hi, unit = FLAG_RANGES["--freq"]  # the range every frequency flag takes
    if not lo <= f <= hi:
        raise ServokitValueError(f"--mode {text!r}: FREQ_HZ must be {lo:g}..{hi:g} {unit}")
    for name, v in (("EPS", eps), ("KAPPA", kappa)):
        if not np.isfinite(v) or abs(v) > 1e12 or 0 < abs(v) < 1e-12:
            raise ServokitValueError(
                f"--mode {text!r}: {name} must be finite, |{name}| 1e-12..1e12"
            )
    return f, eps, kappa


def _amd_fields(res) -> dict:  # noqa: ANN001
    """The JSON of a mode-damping result; an unstable loop has no damped response."""
    data = {"stable": res.stable, "freq_hz": res.freq_hz, "open_db": res.open_db}
    if res.stable:
        return data | {"damped_db": res.damped_db, "attenuation_db": res.attenuation_db,
                       "estimate_db": res.estimate_db}  # fmt: skip
    reason = "the damped loop is unstable: its frequency response (and attenuation) do not exist"
    return data | {"damped_db": None, "attenuation_db": None, "estimate_db": None,
                   "reason": reason}  # fmt: skip


@ssa_app.command("amd", epilog=example("servokit ssa amd --mode 5461:2:10 --mode 9103:2:10"))
def amd_cmd(
    mode: Annotated[
        list[str] | None,
        typer.Option("--mode", help="mode to damp FREQ_HZ:EPS:KAPPA (repeatable) [Hz:1:1]"),
    ] = None,
    json_out: JsonOpt = False,
) -> None:
    """Active mode damping (5.67)-(5.69) on the Table 5.3 PZT model.

    JSON keys: stable, freq_hz, open_db, damped_db, attenuation_db, estimate_db (1/|CD|).
    """
    from servokit.feedback.ssa import amd_mode_damping, amd_response
    from servokit.models import pzt_active_suspension

    modes = [_parse_mode(m) for m in (mode or ["5461:2:10", "6074:2:10", "9103:2:10"])]
    freqs = [m[0] for m in modes]
    if len(set(freqs)) < len(freqs):
        twice = next(f for f in freqs if freqs.count(f) > 1)
        raise ServokitValueError(f"--mode: FREQ_HZ {twice:g} is given twice; give each mode once")
    try:
        amd_response(modes, 0j)  # checks every factor's arguments
    except ServokitValueError as exc:
        raise ServokitValueError(f"--mode: {exc}") from None
    res = amd_mode_damping(pzt_active_suspension(), modes)
    _report(_amd_fields(res), json_out)


@ssa_app.command("adaptive", epilog=example("servokit ssa adaptive --duration 2e-3 --json"))
def adaptive_cmd(
    duration: Annotated[float, typer.Option("--duration", help="simulated time [s]")] = 2e-3,
    n_modes: Annotated[int, typer.Option("--n-modes", help="beam modes (1..4) [count]")] = 3,
    json_out: JsonOpt = False,
) -> None:
    """Adaptive strain feedback (5.73)-(5.75) on a cantilever: V of (5.76) along the run.

    JSON keys: duration_s, lyapunov_start, lyapunov_end (V of (5.76)),
    max_relative_increase, amplitude_ratio, ys_end, k0_end (the adaptive gains); V, Ys and
    k0 are in the beam model's normalised units (unit modal mass and tip weights).
    """
    from servokit.feedback.adaptive import AdaptiveGains, cantilever_beam, simulate_adaptive

    if not (np.isfinite(duration) and 0 < duration <= 0.02):
        raise ServokitValueError(f"--duration must be in (0, 0.02] s (got {duration})")
    if not 1 <= n_modes <= 4:
        raise ServokitValueError(f"--n-modes must be 1..4 (got {n_modes})")
    # SciPy's ODE solver (DOP853) is the slow part of the start: its import costs 0.5 s
    started("ssa adaptive", f"integrating {duration:g} s of a {n_modes}-mode beam (DOP853)")
    run = simulate_adaptive(
        cantilever_beam(n_modes),
        AdaptiveGains(),
        duration=duration,
        n_out=max(200, int(duration * 1e6)),
    )
    _report(
        {
            "duration_s": duration,
            "lyapunov_start": float(run.V[0]),
            "lyapunov_end": float(run.V[-1]),
            "max_relative_increase": run.max_increase(),
            "amplitude_ratio": run.amplitude_ratio(),
            "ys_end": float(run.Ys[-1]),
            "k0_end": float(run.k0[-1]),
        },
        json_out,
    )
