"""Switching-condition sets for acoustic-noise reduction (book §3.4.1, Figs. 3.21, 3.23).

On the HDD loop of the §3.3.3 case (benchmark plant, 500 Hz lead-lag, assumed), the sets
of switching states (head position [track], velocity [mm/s]; other states at rest) that
keep the current peak within cp (Fig. 3.21) and that settle within 10 % of the track
pitch after a given time (Fig. 3.23), for pole-zero IVC (the two slowest real poles
cancelled) and for J-min IVC with J = sum u^2 (3.95)-(3.96).

Both are polytopes from one maximal output admissible set: the current set is O_inf of
|u| <= cp restricted to the IVC coordinates; the settling set is
``{x : A^ks x in O_inf(|y| <= 0.1)}`` (the error stays in the band from sample ks on).
cp = 0.02 A and a settling time of 1.5 ms are assumed (the book plots families of cp and
st without printing them). The book's switching condition (16 tracks before the target
at 10 mm/s, §3.4.1) is classified.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from servokit.cases import register
from servokit.cases.switching_admissible import _slice, admissible_loop
from servokit.report import CaseResult, Comparison
from servokit.switching import (
    AdmissibleSet,
    ivc_jmin,
    ivc_pole_zero,
    max_output_admissible_set,
)
from servokit.switching.plots import admissible_plot

__all__ = ["switching_acoustic_case"]

CP_A = 0.02  # current peak [A], assumed
BAND_TRACK = 0.1  # settling band: 10 % of the track pitch (book)
SETTLE_S = 1.5e-3  # assumed settling-time constraint
CONDITION = np.array([-16.0, 10.0])  # §3.4.1's switching condition


def _area(s: AdmissibleSet) -> float:
    v = s.polygon()
    x, y = v[:, 0], v[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1))))


@register("switching-acoustic", order=115)
def switching_acoustic_case(outdir: Path) -> CaseResult:
    """Current-peak and settling-time sets with pole-zero vs J-min IVC (§3.4.1).

    Parameters
    ----------
    outdir : Path
        Directory the figures are written to.

    Returns
    -------
    CaseResult
        Book-vs-servokit rows, figure paths and extra numbers (runtime included).
    """
    start = time.perf_counter()
    loop = admissible_loop()
    real = sorted((p.real for p in loop.poles() if abs(p.imag) < 1e-12), key=lambda p: -abs(p))
    gains = {
        "pole-zero IVC": ivc_pole_zero(loop, None, real[:2]),
        "J-min IVC": ivc_jmin(loop, None, output_weight=loop.Cu),
    }
    current = max_output_admissible_set(loop.A, loop.Cu, -CP_A, CP_A)
    band = max_output_admissible_set(loop.A, loop.C, -BAND_TRACK, BAND_TRACK)
    ks = int(round(SETTLE_S / loop.dt))
    pull = np.linalg.matrix_power(loop.A, ks)
    E = _slice(loop)
    cur = {k: current.restrict(loop.stack(K) @ E) for k, K in gains.items()}
    settle = {k: band.restrict(pull @ loop.stack(K) @ E) for k, K in gains.items()}
    ratio = _area(cur["J-min IVC"]) / _area(cur["pole-zero IVC"])
    rows = [
        Comparison(
            "current-peak set larger with J-min than pole-zero IVC (1 = yes)",
            1.0,
            float(ratio > 1),
            "",
            0.0,
            "Fig. 3.21",
            kind="assumed",
            note=f"area ratio {ratio:.3g}; cp = {CP_A} A and the loop assumed",
        ),
        Comparison(
            "switching condition (-16 track, 10 mm/s) within cp with J-min IVC (1 = yes)",
            1.0,
            float(cur["J-min IVC"].contains(CONDITION)),
            "",
            0.0,
            "§3.4.1",
            kind="assumed",
            note="book: chosen inside the J-min safe region",
        ),
    ]
    figs = [
        admissible_plot(
            {f"|u| <= {CP_A} A, {k}": s for k, s in cur.items()},
            points={"switching condition": CONDITION},
            xlabel="Head position [track]",
            ylabel="Head velocity [mm/s]",
            title="Fig. 3.21: states keeping the current peak within cp",
            path=outdir / "fig3_21_current_sets.png",
            limits=((-120.0, 40.0), (-20.0, 60.0)),
        ),
        admissible_plot(
            {f"settled by {SETTLE_S * 1e3:g} ms, {k}": s for k, s in settle.items()},
            points={"switching condition": CONDITION},
            xlabel="Head position [track]",
            ylabel="Head velocity [mm/s]",
            title="Fig. 3.23: states settling to 10 % Tp in time",
            path=outdir / "fig3_23_settling_sets.png",
        ),
    ]
    extra = {
        "area_current_track_mm_s": {k: _area(s) for k, s in cur.items()},
        "area_settling_track_mm_s": {k: _area(s) for k, s in settle.items()},
        "runtime_s": time.perf_counter() - start,
    }
    return CaseResult(
        name="switching-acoustic",
        title="Switching-condition sets for acoustic noise (§3.4.1)",
        comparisons=rows,
        figures=figs,
        extra=extra,
        chapter=3,
    )
