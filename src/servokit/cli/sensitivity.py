"""``servokit sensitivity``: sampled-data |Ssd|, |Tsd| and discrete |Sd|, |Td| (book §4.2)."""

from __future__ import annotations

from typing import Annotated

import typer

from servokit.cli._app import (
    FmaxOpt,
    FminOpt,
    JsonOpt,
    MaxMemoryOpt,
    NFreqOpt,
    PlantOpt,
    PlotOpt,
    app,
    console,
    emit_json,
    example,
    flag_names,
    load_plant,
    plot_target,
    progress,
    wrote,
)
from servokit.cli._options import (
    check_state_size,
    controller_states,
    discrete_states,
    load_controller_data,
)
from servokit.errors import (
    DEFAULT_MAX_MEMORY_MB,
    ServokitValueError,
    check_count,
    check_memory,
    check_range,
    check_work,
)

_FLAGS = {
    "freq_hz": "--fmin/--fmax",
    "tol": "--tol",
    "band_limit_hz": "--band-limit",
    "controller_d": "--controller",
    "dt": "--controller's dt",
    "plant": "--plant",
}
# frequencies per call: a progress step, and the alias-sum work per call stays bounded
_CHUNK = 2000
# complex arrays per frequency in the result and the alias sums
_ARRAYS_PER_FREQ = 24
_ALIAS_BLOCK_BYTES = 2_000_000 * 16 * 4
_JSON_KEYS = (
    "plant, controller, dt_s, m, peak_ssd, peak_ssd_freq_hz, peak_tsd, peak_tsd_freq_hz, "
    "peak_sd, alias_terms, tail_estimate, freq_hz, ssd, tsd, sd_mag, td_mag, s_delta, t_delta, "
    "gamma_sum, pd_magnitude_db, pd_phase_deg, plot"
)


@app.command(
    "sensitivity",
    epilog=example(
        "servokit sensitivity --plant hdd-sampled-data --controller eq-4.69 --multirate "
        "--plot ssd.png"
    )
    + f"\n\nJSON: {_JSON_KEYS}.",
)
def sensitivity_cmd(
    plant: PlantOpt = "hdd-sampled-data",
    controller: Annotated[
        str,
        typer.Option(
            "--controller",
            help="'eq-4.69' or a discrete controller .toml file",
            metavar="NAME_OR_TOML",
        ),
    ] = "eq-4.69",
    multirate: Annotated[
        bool,
        typer.Option(
            "--multirate/--no-multirate",
            help="use the §4.5.2 multirate path: Ip (4.67), Fm (4.68) at 3.6 kHz, ZOH at Ts/m",
        ),
    ] = True,
    m: Annotated[
        int, typer.Option("--m", help="multirate number m [count] (with --multirate)")
    ] = 4,
    fmin: FminOpt = 10.0,
    fmax: FmaxOpt = 10000.0,
    n_freq: NFreqOpt = 1000,
    tol: Annotated[
        float, typer.Option("--tol", help="relative truncation tolerance of the alias sums [1]")
    ] = 1e-6,
    band_limit: Annotated[
        float | None,
        typer.Option(
            "--band-limit", help="band limit of eq. (4.62) [Hz]: plant response set to 0 above it"
        ),
    ] = None,
    max_memory_mb: MaxMemoryOpt = DEFAULT_MAX_MEMORY_MB,
    plot: PlotOpt = None,
    json_out: JsonOpt = False,
) -> None:
    """Sensitivity of a digital loop including the intersample response (eqs. 4.13-4.38)."""
    import numpy as np

    fmin, fmax = check_range(fmin, fmax)
    n = check_count("--n-freq", n_freq, lo=2)
    _check_tolerances(tol, band_limit)
    check_memory(
        n * _ARRAYS_PER_FREQ * 16 + _ALIAS_BLOCK_BYTES,
        what=f"--n-freq {n}",
        max_memory_mb=max_memory_mb,
    )
    plot = plot_target(plot)
    p, ctrl, mr = _loop(plant, controller, multirate, m, max_memory_mb)
    dt, freq = float(ctrl.dt), np.linspace(fmin, fmax, n)
    if band_limit is not None:  # every alias order up to the band limit, at every frequency
        check_work(
            2.0 * n * np.ceil((band_limit + fmax) * dt),
            what=f"--band-limit {band_limit:g} with --n-freq {n}",
            limit=_MAX_BAND_CELLS,
            about="about half a minute",
        )
    with flag_names(_FLAGS):
        res = _sweep(p, ctrl, dt, freq, mr, tol, band_limit, show=not json_out)
    _render(res, p.name, controller, plot, json_out)


def _check_tolerances(tol: float, band_limit: float | None) -> None:
    import numpy as np

    if not (np.isfinite(tol) and 0 < tol < 1):
        raise ServokitValueError(f"--tol must be in (0, 1) (got {tol:g})")
    if band_limit is not None and not (np.isfinite(band_limit) and band_limit > 0):
        raise ServokitValueError(f"--band-limit must be > 0 Hz (got {band_limit:g})")


def _loop(plant: str, controller: str, multirate: bool, m: int, max_memory_mb: float):  # noqa: ANN202
    """Plant, controller and the multirate setting; the plant's discrete model (at Ts/m with
    --multirate) is estimated before anything is built."""
    p = load_plant(plant)
    ctrl = load_controller_data(controller)  # numpy coefficients: python-control unloaded
    dt = float(ctrl.dt)
    m = check_count("--m", m, lo=1, hi=_MAX_MULTIRATE) if multirate else 1
    n_states = discrete_states(p, dt / m, controller_states(ctrl))
    check_state_size(n_states, what=f"--plant {plant}", max_memory_mb=max_memory_mb)
    if not multirate:
        return p, ctrl, None
    from servokit.sampled.hdd_multirate import hdd_multirate

    return p, ctrl, hdd_multirate(dt, m)


def _render(res, name: str, controller: str, plot, json_out: bool) -> None:  # noqa: ANN001
    """Figure, JSON or the table of a sensitivity sweep."""
    import numpy as np

    if plot is not None:
        from servokit.sampled import sensitivity_plot

        sensitivity_plot(res, quantities=("Ssd", "Tsd", "Sd"), filename=str(plot))
        wrote(plot)
    freq = res.freq_hz
    i_s, i_t = int(np.argmax(res.Ssd)), int(np.argmax(res.Tsd))
    summary = {
        "plant": name,
        "controller": controller,
        "dt_s": res.dt,
        "m": res.m,
        "peak_ssd": float(res.Ssd[i_s]),
        "peak_ssd_freq_hz": float(freq[i_s]),
        "peak_tsd": float(res.Tsd[i_t]),
        "peak_tsd_freq_hz": float(freq[i_t]),
        "peak_sd": float(np.abs(res.Sd).max()),
        "plot": str(plot) if plot else None,
    }
    if json_out:
        emit_json({**summary, **_curves(res)})
        return
    _print_table(res, name, res.dt, freq, summary)


#: Most (frequency, alias order) cells of a band-limited sweep: ~3e7 take ~10 s here.
_MAX_BAND_CELLS = 1e8

#: Largest multirate number: the lifted system grows as m states; the book uses m = 2.
_MAX_MULTIRATE = 64


def _sweep(p, ctrl, dt, freq, mr, tol, band_limit, *, show: bool):  # noqa: ANN001
    """:func:`~servokit.sampled.sensitivity_in_chunks` with a progress bar."""
    import numpy as np

    from servokit.sampled.sensitivity import sensitivity_in_chunks

    n_chunks = int(np.ceil(freq.size / _CHUNK))
    with progress(n_chunks, "sensitivity sweep", enabled=show) as advance:
        return sensitivity_in_chunks(
            p, ctrl, dt, freq, multirate=mr, tol=tol, band_limit_hz=band_limit, chunk=_CHUNK,
            progress=advance,
        )  # fmt: skip


def _curves(res) -> dict:  # noqa: ANN001
    import numpy as np

    return {
        "alias_terms": res.alias_terms,
        "tail_estimate": res.tail_estimate,
        "freq_hz": res.freq_hz,
        "ssd": res.Ssd,
        "tsd": res.Tsd,
        "sd_mag": np.abs(res.Sd),
        "td_mag": np.abs(res.Td),
        "s_delta": res.S_delta,
        "t_delta": res.T_delta,
        "gamma_sum": res.gamma_sum,
        "pd_magnitude_db": 20 * np.log10(np.abs(res.Pd)),
        "pd_phase_deg": np.degrees(np.angle(res.Pd)),
    }


def _print_table(res, name: str, dt: float, freq, summary: dict) -> None:  # noqa: ANN001
    import numpy as np
    from rich.table import Table

    table = Table(title=f"{name}: Ts = {dt * 1e6:.4g} us, m = {res.m}")
    for col in ("f [Hz]", "|Ssd|", "|Tsd|", "|Sd|", "|Td|"):
        table.add_column(col, justify="right")
    n = freq.size
    for i in np.unique(np.linspace(0, n - 1, min(n, 12)).astype(int)):
        table.add_row(
            *(f"{v:.4g}" for v in (freq[i], res.Ssd[i], res.Tsd[i], abs(res.Sd[i]), abs(res.Td[i])))
        )
    console.print(table)
    console.print(
        f"peak |Ssd| = {summary['peak_ssd']:.4g} at {summary['peak_ssd_freq_hz']:.4g} Hz; "
        f"peak |Tsd| = {summary['peak_tsd']:.4g} at {summary['peak_tsd_freq_hz']:.4g} Hz"
    )
