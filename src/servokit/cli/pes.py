"""``servokit pes``: track following under the HDD benchmark disturbances (§6.1.4)."""

from __future__ import annotations

import typer

from servokit.cli._app import (
    JsonOpt,
    MaxMemoryOpt,
    PlantOpt,
    PlotOpt,
    SeedOpt,
    app,
    console,
    emit_json,
    example,
    load_plant,
    plot_target,
    wrote,
)
from servokit.cli._options import (
    check_state_size,
    controller_states,
    discrete_states,
    load_controller_data,
)
from servokit.errors import DEFAULT_MAX_MEMORY_MB, ServokitValueError, check_memory

_PEAK_FORM = "FREQ_HZ:DAMPING:DEPTH_DB, e.g. 960:0.08:12"


def _peak_spec(text: str, dt: float):
    """The ``--peak-filter`` spec, each part finite and > 0, the centre below Nyquist."""
    import math

    from servokit.feedback.peak_filtered import PeakFilterSpec

    parts = text.split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        freq, damping, depth = (float(v) for v in parts)
    except ValueError:
        raise ServokitValueError(f"--peak-filter {text!r} must be {_PEAK_FORM}") from None
    for name, value, unit in (
        ("FREQ_HZ", freq, " Hz"),
        ("DAMPING", damping, ""),
        ("DEPTH_DB", depth, " dB"),
    ):
        if not (math.isfinite(value) and value > 0):
            raise ServokitValueError(
                f"--peak-filter {text!r}: {name} must be finite and > 0{unit} "
                f"(got {value:g}); give {_PEAK_FORM}"
            )
    if freq >= 0.5 / dt:
        raise ServokitValueError(
            f"--peak-filter {text!r}: FREQ_HZ must be below the Nyquist frequency "
            f"{0.5 / dt:g} Hz of the {1 / dt:g} Hz PES sampling"
        )
    return PeakFilterSpec(freq, damping, depth)


def _controller(name: str, dt: float):
    """The controller as numpy coefficients (python-control left unloaded, issue 23)."""
    if name == "benchmark":
        from servokit.models import benchmark_controller_data

        return benchmark_controller_data(dt=dt)
    return load_controller_data(name, dt)


@app.command(
    "pes",
    epilog=example("servokit pes --peak-filter 960:0.08:12 --plot pes.png"),
)
def pes_cmd(
    plant: PlantOpt = "hdd-benchmark",
    controller: str = typer.Option(
        "benchmark",
        "--controller",
        help="'benchmark' (servokit's 1 kHz baseline) or a discrete controller .toml at Ts",
    ),
    peak_filter: str | None = typer.Option(
        None,
        "--peak-filter",
        help="add a phase-stable peak filter FREQ_HZ:DAMPING:DEPTH_DB [Hz, 1, dB] (eqs. 5.17-5.18)",
    ),
    n_revolutions: int = typer.Option(200, "--n-revolutions", help="revolutions simulated", min=10),
    seed: SeedOpt = 0,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """NRPE 3 sigma and PES spectrum under the benchmark v2 disturbances.

    JSON: nrpe_3sigma_percent, pes_3sigma_percent, rpe_pp_track, freq_hz[], pes_psd_db[]
    (10 log10 of track^2/Hz).
    """
    from servokit.models import BenchmarkDisturbances
    from servokit.simulate.pes import track_following_pes

    plot = plot_target(plot)
    if seed < 0:
        raise ServokitValueError(f"--seed must be >= 0 (got {seed})")
    bd = BenchmarkDisturbances()
    spec = _peak_spec(peak_filter, bd.dt) if peak_filter is not None else None
    p, c = _loop(plant, controller, spec, n_revolutions, bd, max_memory_mb)
    res = track_following_pes(
        p, c, bd.generate(n_revolutions, seed=seed), max_memory_mb=max_memory_mb, zoh="modal"
    )
    _render(res, plot, json_out)


def _loop(plant: str, controller: str, spec, n_revolutions: int, bd, max_memory_mb: float):  # noqa: ANN001, ANN202
    """Plant and controller (peak filter added), their run's size checked before building."""
    from servokit.feedback.peak_filtered import peak_filtered_data

    p = load_plant(plant)
    c = _controller(controller, bd.dt)
    n_states = discrete_states(p, bd.dt, controller_states(c))
    check_state_size(n_states, what=f"--plant {plant}", max_memory_mb=max_memory_mb)
    n = n_revolutions * bd.samples_per_rev
    check_memory(
        8.0 * n * max(_STATES_PER_SAMPLE, n_states + 4),
        what=f"--n-revolutions {n_revolutions}",
        max_memory_mb=max_memory_mb,
    )
    if spec is not None:
        c = peak_filtered_data(c, p.discretize_data(bd.dt, method="modal"), spec)
    return p, c


#: Values per sample of the PES run held at once (states, inputs, outputs) at least.
_STATES_PER_SAMPLE = 60


def _render(res, plot, json_out: bool) -> None:  # noqa: ANN001
    """Figure (cf. Fig. 6.5), JSON or one line of a track-following run."""
    import numpy as np

    f, psd = res.spectrum(2048)
    if plot is not None:
        from servokit.simulate.plots import pes_spectrum_plot

        wrote(pes_spectrum_plot(f, psd, res.nrpe_3sigma_percent, plot))
    data = {
        "nrpe_3sigma_percent": res.nrpe_3sigma_percent,
        "pes_3sigma_percent": res.pes_3sigma_percent,
        "rpe_pp_track": float(np.ptp(res.rpe)),
        "freq_hz": f,
        "pes_psd_db": 10 * np.log10(np.maximum(psd, 1e-300)),
    }
    if json_out:
        emit_json(data)
        return
    console.print(
        f"NRPE 3sigma = {res.nrpe_3sigma_percent:.2f} % of track, PES 3sigma = "
        f"{res.pes_3sigma_percent:.2f} %, RPE p-p = {data['rpe_pp_track']:.4f} track"
    )
