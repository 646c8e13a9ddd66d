"""Resonance compensation without extra sensors (book §5.5.2.1, §4.5.2), chapter 5 part 1.

* Complex lag of §5.5.2.1 (5.92)-(5.94) and the margins of the §4.5 multirate loop on the
  exact frequency response (python-control reports a spurious PM there).
* The peak-filter examples of §5.3.3 are in :mod:`servokit.cases.peak_filters`.
"""

from __future__ import annotations

import time
from pathlib import Path

import control
import numpy as np

from servokit.cases import register
from servokit.feedback import Margins, complex_lag, frequency_grid, stability_margins
from servokit.feedback.plots import bode_responses_plot
from servokit.report import CaseResult, Comparison

__all__ = ["resonance_filters_case"]

TWO_PI = 2.0 * np.pi


def _at_least(
    quantity: str, bound: float, value: float, unit: str, note: str, **miss: str
) -> Comparison:
    """A specification row "value >= bound" (ok when met: no upper tolerance)."""
    return Comparison(
        quantity, bound, value, unit, 0.0, "§4.5.2", kind="spec", note=note, bound="min", **miss
    )


def _lag_rows() -> tuple[control.TransferFunction, list[Comparison]]:
    """The complex lag (5.92)-(5.94) and its rows against §5.5.2.1."""
    lag = complex_lag(6900.0, 0.1, 1.1519)
    lag_at = complex(lag(2j * np.pi * 6900.0))
    f_p = float(np.abs(lag.poles()[0]) / TWO_PI)
    f_z = float(np.abs(lag.zeros()[0]) / TWO_PI)
    rows = [
        Comparison.printed(
            "complex lag phase at ωm = -2φm",
            "-2.3038",
            float(np.angle(lag_at)),
            unit="rad",
            source="(5.92)-(5.94)",
            kind="consistency",
            note="the lag is built from φm = 1.1519 rad, so -2φm = -2.3038 holds by "
            "construction of (5.92)-(5.94)",
        ),
        Comparison(
            "complex lag poles near the VCM zeros (5691 Hz)",
            5691.0,
            f_p,
            "Hz",
            0.05,
            "§5.5.2.1",
            kind="spec",
            note="the book says 'close to'; 5 % accepted",
        ),
        Comparison(
            "complex lag zeros near the VCM poles (8599 Hz)",
            8599.0,
            f_z,
            "Hz",
            0.05,
            "§5.5.2.1",
            kind="spec",
            note="the book says 'close to'; 5 % accepted",
        ),
    ]
    return lag, rows


def _margin_rows() -> tuple[Margins, list[Comparison]]:
    """Margins of the §4.5.2 multirate loop against its design specification."""
    from servokit.models import (
        HDD_SAMPLED_DATA_TS,
        controller_eq_4_69,
        hdd_sampled_data,
        without_delay,
    )
    from servokit.sampled.hdd_multirate import hdd_multirate

    dt = HDD_SAMPLED_DATA_TS
    plant = hdd_sampled_data()
    pdm = hdd_multirate(dt, 4).discretize(plant, dt)
    m = stability_margins([pdm, controller_eq_4_69()])
    # the same loop without the 10 us plant delay: evidence the miss is not a delay convention
    m0 = stability_margins(
        [hdd_multirate(dt, 4).discretize(without_delay(plant)[0], dt), controller_eq_4_69()]
    )
    pc = control.stability_margins(pdm * controller_eq_4_69())
    rows = [
        _at_least(
            "§4.5.2 multirate loop: phase margin >= 30°",
            30.0,
            m.phase_margin_deg,
            "deg",
            f"at {m.pm_freq_hz:.0f} Hz; python-control reports {pc[1]:.1f}° at "
            f"{pc[4] / TWO_PI:.0f} Hz, a spurious crossing",
        ),
        _at_least(
            "§4.5.2 multirate loop: gain margin >= 4.5 dB",
            4.5,
            m.gain_margin_db,
            "dB",
            f"at {m.gm_freq_hz:.0f} Hz on the exact loop (Ip, Fm, ZOH at Ts/4); the book's "
            "design target, which this loop misses",
            miss_class="book_inconsistent",
            miss_note=f"the book's controller (4.69) on its plant (4.64)-(4.65) gives "
            f"{m.gain_margin_db:.3g} dB at {m.gm_freq_hz:.0f} Hz ({m0.gain_margin_db:.3g} dB "
            "without the 10 us delay): the printed specification and controller disagree",
        ),
    ]
    return m, rows


@register("resonance-filters", order=300)
def resonance_filters_case(outdir: Path) -> CaseResult:
    """Complex lag (§5.5.2.1) and margins of the §4.5 multirate loop.

    Parameters
    ----------
    outdir : pathlib.Path
        Directory for the figures (created if missing).

    Returns
    -------
    CaseResult
        Book-vs-servokit rows, figure paths and extras (runtime included).
    """
    t0 = time.perf_counter()
    outdir.mkdir(parents=True, exist_ok=True)
    lag, rows = _lag_rows()
    m, margin_rows = _margin_rows()
    rows += margin_rows
    f = frequency_grid(lag, 1e3, 3e4, 1500)
    fig = bode_responses_plot(
        {"Clag (ζ 0.1, 6900 Hz, φm 1.1519 rad)": lag},
        f,
        path=outdir / "fig5_38_complex_lag.png",
        title="Complex lag (5.92) of §5.5.2.1 (Fig. 5.38)",
    )
    return CaseResult(
        name="resonance-filters",
        title="Complex lag (5.92)-(5.94) and exact-response margins (§5.5.2.1, §4.5.2)",
        comparisons=rows,
        figures=[fig],
        extra={"margins_4_5": m.to_dict(), "runtime_s": time.perf_counter() - t0},
        chapter=5,
    )
