"""``servokit seek --method robust``: the robust minimum-time seek over a plant set (issue 13).

The ``seek`` command builds the request (:func:`servokit.cli._requests.seek_job`) and
forwards ``--method robust`` here: the design is :func:`servokit.seek.run_seek` (the LP of
:func:`~servokit.seek.robust_minimum_time`, verified by the ordinary simulator), or with
``--variations`` :func:`~servokit.seek.robust_seek_over_box`; this module renders them.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from servokit.cli._app import console, emit_json, flag_names, warn, wrote
from servokit.cli._requests import SEEK_FLAGS, SeekJob
from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from servokit.seek import NoFeasibleSeekError, SeekRun, ValidatedSeek

__all__ = ["JSON_KEYS", "robust_seek"]

#: JSON keys of ``servokit seek --method robust --json`` (documented in its help)
JSON_KEYS = (
    "plant, variations (file or null), method, target_out, n_samples, dt_s, u_max, "
    "peak_input, settle_band_out, design_band_out, margin, seek_time_s (simulated worst "
    "case), guaranteed_seek_time_s (LP), worst_plant, binding_plant, n_plants, seek_times_s, "
    "design_time_s, n_lp, input, n_search "
    "{n_samples, guaranteed_seek_time_s}, plot; with --variations: seek_time_s (validated "
    "worst inside the box), guaranteed_seek_time_s (design set), n_validation, n_adversarial, "
    "n_design, converged, rounds, worst_source, seek_times_s (validation sample)"
)


def robust_seek(job: SeekJob) -> None:
    """Design (on the plant set, or validated over the ``--variations`` box) and render.

    Parameters
    ----------
    job : SeekJob
        The checked robust request and the output flags.
    """
    from servokit.seek import NoFeasibleSeekError, run_seek

    with flag_names(SEEK_FLAGS):
        try:
            if job.box is not None:
                t0 = time.perf_counter()
                res = _box_design(job)
                return _render_box(job, res, time.perf_counter() - t0)
            run = run_seek(job.request)
        except NoFeasibleSeekError as exc:
            raise _infeasible(job, exc) from None
    _render_set(job, run)


def _box_design(job: SeekJob) -> ValidatedSeek:
    """The design validated over the ``--variations`` box (issue 22 item 4)."""
    from servokit.models import without_delay
    from servokit.seek import robust_seek_over_box

    req = job.request
    box = job.box
    if not req.simulate_delay:  # --no-delay: the box's nominal without its input delay
        box = dataclasses.replace(box, nominal=without_delay([box.nominal])[0])
    kw = {} if req.N == "auto" else {"N": req.N}
    return robust_seek_over_box(
        box,
        req.dt,
        req.target,
        band=req.band,
        u_max=req.u_max,
        n_validation=job.n_validation,
        margin=req.margin,
        N_max=req.N_max,
        slew_max=req.slew_max,
        objective=req.objective,
        max_memory_mb=req.max_memory_mb,
        progress=None if job.output.json_out else console.print,
        **kw,
    )


def _infeasible(job: SeekJob, exc: NoFeasibleSeekError) -> ServokitValueError:
    """The LP's infeasibility, naming the flags to relax."""
    req = job.request
    lo, hi = exc.N_range
    if lo > hi:
        return ServokitValueError(
            f"|u| <= --u-max {req.u_max:g} needs at least N = {lo} steps to move the rigid "
            f"body {req.target:g} and stop, above --n-samples-max {hi}: raise "
            "--n-samples-max or --u-max"
        )
    return ServokitValueError(
        f"no N in {lo}..{hi} settles every plant within --settle-band {req.band:g} "
        f"(margin {req.margin:g}) with |u| <= --u-max {req.u_max:g}: raise --u-max, widen "
        "--settle-band, lower --margin or raise --n-samples-max"
    )


def _render_set(job: SeekJob, run: SeekRun) -> None:
    """Plot, print or emit the design on the plant set (verified by simulation)."""
    req, ff, out = job.request, run.ff, run.outcome
    names = [p.name or str(i) for i, p in enumerate(req.plants)]
    if job.output.plot is not None:
        title = (
            f"Robust minimum-time seek of {req.target:g} on {job.label}, N = {ff.N}, "
            f"|u| <= {req.u_max:g} (beyond the book)"
        )
        _plot(job, req.simulated_plants(), ff, title)
    data = {
        **_common_keys(job, ff),
        "seek_time_s": out.worst,
        "guaranteed_seek_time_s": ff.guaranteed_seek_time,
        "worst_plant": names[out.worst_plant],
        "binding_plant": names[ff.binding_plant],
        "n_plants": len(req.plants),
        "seek_times_s": out.seek_times,
        "design_time_s": run.design_time_s,
        "n_lp": ff.n_lp,
        "input": ff.u,
        "n_search": {"n_samples": ff.N_values, "guaranteed_seek_time_s": ff.seek_times},
        "plot": _plot_name(job),
    }
    if job.output.json_out:
        emit_json(data)
        return
    console.print(
        f"ROBUST seek of {req.target:g} on {job.label}: N = {ff.N}, worst-case seek time "
        f"{out.worst * 1e3:.6g} ms simulated ({data['worst_plant']}, {len(req.plants)} "
        f"plant(s); LP guarantee {ff.guaranteed_seek_time * 1e3:.6g} ms within "
        f"+-{ff.band:g}), peak input {data['peak_input']:.4g}, designed in "
        f"{run.design_time_s:.2f} s"
    )


def _render_box(job: SeekJob, res: ValidatedSeek, design_time: float) -> None:
    """Plot, print or emit the design validated over the ``--variations`` box."""
    req, ff = job.request, res.ff
    if job.output.plot is not None:
        plants = [job.box.nominal, res.worst_plant.replace(name="validated worst")]
        title = (
            f"Robust seek of {req.target:g} validated over {job.box.name or 'the box'}"
            f", N = {ff.N}, |u| <= {req.u_max:g}"
        )
        _plot(job, plants, ff, title)
    if not res.converged:
        warn(
            f"the validated worst ({res.seek_time * 1e3:.6g} ms) still exceeds the design "
            f"guarantee ({res.design_seek_time * 1e3:.6g} ms) after {len(res.rounds)} rounds"
        )
    data = {
        **_common_keys(job, ff),
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
        "plot": _plot_name(job),
    }
    if job.output.json_out:
        emit_json(data)
        return
    console.print(
        f"ROBUST seek of {req.target:g} on {job.label} over {job.variations}: N = {ff.N}, "
        f"worst-case seek time {res.seek_time * 1e3:.6g} ms validated ({res.n_validation} "
        "Monte-Carlo plants + "
        f"{res.n_adversarial} adversarial, worst {res.worst_source}); design guarantee "
        f"{res.design_seek_time * 1e3:.6g} ms on {res.n_design} plants, peak input "
        f"{data['peak_input']:.4g}, designed in {design_time:.2f} s"
    )


def _plot_name(job: SeekJob) -> str | None:
    return None if job.output.plot is None else str(job.output.plot)


def _plot(job: SeekJob, plants: list, ff: Any, title: str) -> None:
    """The seek response of ``plants`` (the first one's resonances marked) into ``--plot``."""
    from servokit.seek import seek_plot, simulate_seek

    req, path = job.request, job.output.plot
    assert path is not None
    out = simulate_seek(plants, ff, req.target, band=req.band)  # shorter record
    seek_plot(
        out, req.target, title, path,
        resonances_hz=plants[0].resonances_hz(), band=req.band, unit=job.unit,
    )  # fmt: skip
    wrote(Path(path))


def _common_keys(job: SeekJob, ff: Any) -> dict:
    """The JSON keys of both robust reports (design-set and validated over a box)."""
    req = job.request
    return {
        "plant": job.label,
        "variations": job.variations,
        "method": "robust",
        "target_out": req.target,
        "n_samples": ff.N,
        "dt_s": ff.dt,
        "u_max": req.u_max,
        "peak_input": float(np.abs(ff.u).max()),
        "settle_band_out": req.band,
        "design_band_out": ff.band,
        "margin": req.margin,
    }
