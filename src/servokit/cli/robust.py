"""``servokit seek --method robust``: the robust minimum-time seek over a plant set (issue 13).

The ``seek`` command forwards ``--method robust`` here; the design is
:func:`servokit.seek.robust_minimum_time`, verified by the ordinary simulator.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from servokit.cli._app import console, emit_json, plot_target, wrote
from servokit.errors import ServokitValueError, check_positive

if TYPE_CHECKING:
    from servokit.models import ModalPlant, VariationSet
    from servokit.seek import RobustFeedforwardInput, ValidatedSeek

__all__ = ["RobustSeekRequest", "box_variations", "robust_seek"]

#: JSON keys of ``servokit seek --method robust --json`` (documented in its help)
JSON_KEYS = (
    "plant, method, target, n_samples, dt_s, u_max, peak_input, settle_band, design_band, "
    "margin, seek_time_s (simulated worst case), guaranteed_seek_time_s (LP), worst_plant, "
    "binding_plant, n_plants, seek_times_s, design_time_s, n_lp, input, n_search "
    "{n_samples, guaranteed_seek_time_s}, plot; with --variations: seek_time_s (validated "
    "worst inside the box), guaranteed_seek_time_s (design set), n_validation, n_adversarial, "
    "n_design, converged, rounds, worst_source, seek_times_s (validation sample)"
)


@dataclass(frozen=True)
class RobustSeekRequest:
    """What the ``seek`` command collected for a robust design."""

    plant_name: str
    plants: list[ModalPlant]
    dt: float
    target: float
    settle_band: float
    u_max: float | None
    n_steps: int | None
    n_max: int | None
    margin: float
    slew_max: float | None
    objective: str
    plot: Path | None
    json_out: bool
    variations: VariationSet | None = None
    n_validation: int = 2000


def box_variations(vset: VariationSet | None, delay: bool) -> VariationSet | None:
    """The ``--variations`` box, its nominal without delay under ``--no-delay``."""
    if vset is None or delay:
        return vset
    return dataclasses.replace(vset, nominal=vset.nominal.replace(delay=0.0))


def _box_design(req: RobustSeekRequest) -> ValidatedSeek:
    """The design validated over the ``--variations`` box (issue 22 item 4)."""
    from servokit.seek import robust_seek_over_box

    assert req.variations is not None and req.u_max is not None
    kw = {} if req.n_steps is None else {"N": req.n_steps}
    return robust_seek_over_box(
        req.variations,
        req.dt,
        req.target,
        band=req.settle_band,
        u_max=req.u_max,
        n_validation=req.n_validation,
        margin=req.margin,
        N_max=req.n_max,
        slew_max=req.slew_max,
        objective=req.objective,
        progress=None if req.json_out else console.print,
        **kw,
    )


def _design(req: RobustSeekRequest) -> RobustFeedforwardInput | ValidatedSeek:
    from servokit.seek import NoFeasibleSeekError, SeekRequest, design_seek

    if req.u_max is None:
        raise ServokitValueError("--method robust needs --u-max (input limit [plant input unit])")
    check_positive("--u-max", req.u_max)
    check_positive("--settle-band", req.settle_band)
    if req.slew_max is not None:
        check_positive("--slew-max", req.slew_max)
    if not 0.0 <= req.margin < 1.0:
        raise ServokitValueError(
            f"--margin must be in [0, 1) (fraction of the band), got {req.margin}"
        )
    if req.objective not in ("peak", "energy"):
        raise ServokitValueError(f"--objective must be 'peak' or 'energy', got {req.objective!r}")
    try:
        if req.variations is not None:
            return _box_design(req)
        request = SeekRequest(
            req.plants,
            req.dt,
            req.target,
            req.settle_band,
            "robust",
            "auto" if req.n_steps is None else req.n_steps,
            N_max=req.n_max,
            u_max=req.u_max,
            slew_max=req.slew_max,
            margin=req.margin,
            objective=req.objective,
        )
        return design_seek(request).ff  # type: ignore[return-value]
    except NoFeasibleSeekError as exc:
        lo, hi = exc.N_range
        if lo > hi:
            raise ServokitValueError(
                f"|u| <= --u-max {req.u_max:g} needs at least N = {lo} steps to move the rigid "
                f"body {req.target:g} and stop, above --n-samples-max {hi}: raise "
                "--n-samples-max or --u-max"
            ) from None
        raise ServokitValueError(
            f"no N in {lo}..{hi} settles every plant within --settle-band {req.settle_band:g} "
            f"(margin {req.margin:g}) with |u| <= --u-max {req.u_max:g}: raise --u-max, widen "
            "--settle-band, lower --margin or raise --n-samples-max"
        ) from None


def robust_seek(req: RobustSeekRequest) -> None:
    """Design, verify by simulation, print or emit JSON, optionally plot."""
    from servokit.seek import simulate_seek

    plot = plot_target(req.plot)
    t0 = time.perf_counter()
    ff = _design(req)
    design_time = time.perf_counter() - t0
    from servokit.seek import ValidatedSeek

    if isinstance(ff, ValidatedSeek):
        return _report_box(req, ff, design_time, plot)
    # a record far beyond the input and its guarantee (the tail bound holds after it too)
    horizon = max(20 * ff.duration, ff.duration + 0.02)
    out = simulate_seek(req.plants, ff, req.target, band=req.settle_band, horizon=horizon)
    names = [p.name or str(i) for i, p in enumerate(req.plants)]
    if plot is not None:
        title = (
            f"Robust minimum-time seek of {req.target:g} on {req.plant_name}, N = {ff.N}, "
            f"|u| <= {req.u_max:g} (beyond the book)"
        )
        _plot(req, req.plants, ff, title, plot)
    data = {
        **_common_keys(req, ff),
        "seek_time_s": out.worst,
        "guaranteed_seek_time_s": ff.guaranteed_seek_time,
        "worst_plant": names[out.worst_plant],
        "binding_plant": names[ff.binding_plant],
        "n_plants": len(req.plants),
        "seek_times_s": out.seek_times,
        "design_time_s": design_time,
        "n_lp": ff.n_lp,
        "input": ff.u,
        "n_search": {"n_samples": ff.N_values, "guaranteed_seek_time_s": ff.seek_times},
        "plot": str(plot) if plot else None,
    }
    if req.json_out:
        emit_json(data)
        return
    console.print(
        f"ROBUST seek of {req.target:g} on {req.plant_name}: N = {ff.N}, worst-case seek time "
        f"{out.worst * 1e3:.6g} ms simulated ({data['worst_plant']}, {len(req.plants)} "
        f"plant(s); LP guarantee {ff.guaranteed_seek_time * 1e3:.6g} ms within "
        f"+-{ff.band:g}), peak input {data['peak_input']:.4g}, designed in {design_time:.2f} s"
    )


def _report_box(
    req: RobustSeekRequest, res: ValidatedSeek, design_time: float, plot: Path | None
) -> None:
    """Print or emit the design validated over the ``--variations`` box."""
    from servokit.cli._app import warn

    assert req.variations is not None
    ff = res.ff
    if plot is not None:
        plants = [req.variations.nominal, res.worst_plant.replace(name="validated worst")]
        title = (
            f"Robust seek of {req.target:g} validated over {req.variations.name or 'the box'}"
            f", N = {ff.N}, |u| <= {req.u_max:g}"
        )
        _plot(req, plants, ff, title, plot)
    if not res.converged:
        warn(
            f"the validated worst ({res.seek_time * 1e3:.6g} ms) still exceeds the design "
            f"guarantee ({res.design_seek_time * 1e3:.6g} ms) after {len(res.rounds)} rounds"
        )
    data = {
        **_common_keys(req, ff),
        "seek_time_s": res.seek_time,
        "guaranteed_seek_time_s": res.design_seek_time,
        "n_validation": res.n_validation,
        "n_adversarial": res.n_adversarial,
        "n_design": res.n_design,
        "converged": res.converged,
        "rounds": len(res.rounds),
        "worst_source": res.worst_source,
        "seek_times_s": res.validation_seek_times,
        "design_time_s": design_time,
        "n_lp": ff.n_lp,
        "input": ff.u,
        "plot": str(plot) if plot else None,
    }
    if req.json_out:
        emit_json(data)
        return
    console.print(
        f"ROBUST seek of {req.target:g} on {req.plant_name}: N = {ff.N}, worst-case seek time "
        f"{res.seek_time * 1e3:.6g} ms validated ({res.n_validation} Monte-Carlo plants + "
        f"{res.n_adversarial} adversarial, worst {res.worst_source}); design guarantee "
        f"{res.design_seek_time * 1e3:.6g} ms on {res.n_design} plants, peak input "
        f"{data['peak_input']:.4g}, designed in {design_time:.2f} s"
    )


def _plot(req: RobustSeekRequest, plants: list, ff: Any, title: str, plot: Path) -> None:
    """The seek response of ``plants`` (the first one's resonances marked) into ``plot``."""
    from servokit.seek import seek_plot, simulate_seek

    out = simulate_seek(plants, ff, req.target, band=req.settle_band)  # shorter record
    seek_plot(
        out, req.target, title, plot,
        resonances_hz=plants[0].resonances_hz(), band=req.settle_band,
    )  # fmt: skip
    wrote(plot)


def _common_keys(req: RobustSeekRequest, ff: Any) -> dict:
    """The JSON keys of both robust reports (design-set and validated over a box)."""
    return {
        "plant": req.plant_name,
        "method": "robust",
        "target": req.target,
        "n_samples": ff.N,
        "dt_s": ff.dt,
        "u_max": req.u_max,
        "peak_input": float(np.abs(ff.u).max()),
        "settle_band": req.settle_band,
        "design_band": ff.band,
        "margin": req.margin,
    }
