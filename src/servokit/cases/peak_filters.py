"""Peak filters at a plant mode (book §5.3.3.2-§5.3.3.3, Figs. 5.16-5.22), chapter 5 part 1.

The book gives neither the baseline loop nor the filter gain of its 12 kHz example. The
baseline family stated here is the LTV example's plant, "a 50 Hz mode (ζ 0.4) plus a
12 kHz mode (ζ 0.015)":
``P(s) = ω0²/(s² + 0.8 ω0 s + ω0²) + a ω1²/(s² + 0.03 ω1 s + ω1²)``, with a lead
``C(s) = k (r s/ωc + 1)/(s/(r ωc) + 1)`` giving crossover fc. Its unknowns (residue a, fc,
lead spread r) are searched on :data:`SEARCH_GRID`; for each candidate the filter gain K
is fitted to the printed +10 dB extra attenuation of the phase-shift design (5.38) and
used for all three designs; the candidate kept minimises the squared log-errors of the
three printed gain margins (0.0157, 11.7, 8.22) plus ((extra attenuation of the
frequency-shift design − 8 dB)/3 dB)². Every other row is then a prediction, but all
rest on the fitted baseline, so all are labelled "fitted".

Gain margins are the critical multipliers of the designed F on the root locus of
1 + k Sh F = 0. Departure angles are exact residue angles; they are compared for the pole
in the lower half-plane, whose angles carry the signs the book prints (its (5.40)-(5.41)
for the phase-shift design; the upper pole departs at the negated angle).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import control
import numpy as np
from scipy.optimize import brentq

from servokit.cases import register
from servokit.feedback import design_peak_filter, pseudo_plant
from servokit.feedback.plots import bode_responses_plot, root_locus_plot
from servokit.feedback.rootlocus import PeakFilterLocus, peak_filter_locus, root_locus
from servokit.report import CaseResult, Comparison

__all__ = [
    "PeakExample",
    "SEARCH_GRID",
    "peak_example_baseline",
    "peak_filter_case",
    "ltv_locus_case",
]

TWO_PI = 2.0 * np.pi
F_MODE, Z_MODE, F_LOW, Z_LOW = 12000.0, 0.015, 50.0, 0.4
F_SHIFT = 11800.0  # the frequency-shift filter's centre, printed
ANGLE_TOL_DEG = 15.0  # the book's angles are "≈", read off root-locus figures
#: (residue a, crossover fc [Hz], lead spread r) candidates of the baseline search.
SEARCH_GRID = tuple(
    itertools.product((-1e-3, -1e-4, -2.87e-5, 1e-4, 3.16e-4, 1e-3), (500.0, 1000.0), (2.0,))
)
_BOOK_GM = {"stable": 0.0157, "phase-shift": 11.7, "frequency-shift": 8.22}


def _mode(freq_hz: float, damping: float) -> control.TransferFunction:
    w = TWO_PI * freq_hz
    return control.tf([w * w], [1.0, 2.0 * damping * w, w * w])


@dataclass(frozen=True)
class PeakExample:
    """A baseline loop of the §5.3.3 examples with its fitted filter gain and cost."""

    plant: control.TransferFunction
    controller: control.TransferFunction
    sh: control.TransferFunction
    residue: float
    crossover_hz: float
    lead_spread: float
    gain: float = float("nan")  #: K fitted to the +10 dB of the phase-shift design
    cost: float = float("nan")
    #: the three designs at ``gain`` (:func:`_designs`), kept from the fit: the rows and
    #: the evidence of every missed row read them instead of designing them again
    designs: dict[str, tuple] = field(default_factory=dict, compare=False, repr=False)

    def pseudo_resonance_hz(self) -> float:
        """Damped frequency of the pseudo plant's pole nearest 12 kHz [Hz]."""
        p = self.sh.poles()
        return float(abs(p[np.argmin(np.abs(p - 2j * np.pi * F_MODE))].imag) / TWO_PI)


def _candidate(residue: float, crossover_hz: float, spread: float) -> PeakExample:
    plant = _mode(F_LOW, Z_LOW) + residue * _mode(F_MODE, Z_MODE)
    wc = TWO_PI * crossover_hz
    lead = control.tf([spread / wc, 1.0], [1.0 / (spread * wc), 1.0])
    lead = lead / abs(complex((plant * lead)(1j * wc)))
    sh = control.tf(control.minreal(pseudo_plant(plant * lead), verbose=False))
    return PeakExample(plant, lead, sh, residue, crossover_hz, spread)


def extra_attenuation_db(ex: PeakExample, flt: control.TransferFunction, f_hz: float) -> float:
    """|S0 / S| = |1 + Sh F| at ``f_hz`` [dB], (5.15)-(5.16)."""
    s = 2j * np.pi * f_hz
    return float(20 * np.log10(abs(1 + complex(ex.sh(s)) * complex(flt(s)))))


def _designs(ex: PeakExample, gain: float) -> dict[str, tuple]:
    """The three LTI designs at gain K: method -> (F, φ, locus)."""
    out = {}
    for method, f1 in (("stable", F_MODE), ("phase-shift", F_MODE), ("frequency-shift", F_SHIFT)):
        flt, phi = design_peak_filter(ex.sh, f1, 0.01, gain, method)
        out[method] = (flt, phi, peak_filter_locus(ex.sh, flt, F_MODE))
    return out


def _fit(ex: PeakExample) -> PeakExample:
    """K for +10 dB with the phase-shift design, and the search cost of the candidate."""

    def miss(log_k: float) -> float:
        flt, _ = design_peak_filter(ex.sh, F_MODE, 0.01, 10.0**log_k, "phase-shift")
        return extra_attenuation_db(ex, flt, F_MODE) - 10.0

    gain = float(10.0 ** brentq(miss, -8.0, 4.0, xtol=1e-12))
    d = _designs(ex, gain)
    cost = sum(np.log(min(max(d[m][2].k_crit, 1e-9), 1e9) / g) ** 2 for m, g in _BOOK_GM.items())
    cost += ((extra_attenuation_db(ex, d["frequency-shift"][0], F_MODE) - 8.0) / 3.0) ** 2
    return PeakExample(**{**ex.__dict__, "gain": gain, "cost": float(cost), "designs": d})


def _designs_at_gain(ex: PeakExample) -> dict[str, tuple]:
    """:func:`_designs` of ``ex`` at its fitted gain (kept by :func:`_fit`)."""
    return ex.designs or _designs(ex, ex.gain)


@lru_cache(maxsize=1)
def peak_example_baseline() -> PeakExample:
    """The searched baseline (module docstring): the stable candidate of least cost."""
    fitted = []
    for a, fc, r in SEARCH_GRID:
        ex = _candidate(a, fc, r)
        if np.all(ex.sh.poles().real < 0):
            fitted.append(_fit(ex))
    return min(fitted, key=lambda e: e.cost)


#: (fc [Hz], r) of the baseline search constrained to the book's 11.8 kHz pseudo-plant
#: resonance (§5.3.3.2: the frequency-shift filter centre, where p1 and ph1 align)
CONSTRAINED_GRID = tuple(itertools.product((300.0, 500.0, 1000.0), (2.0, 3.0)))


@lru_cache(maxsize=1)
def constrained_baseline() -> PeakExample:
    """The baseline search with the pseudo-plant resonance held at the book's 11.8 kHz.

    For each (fc, r) of :data:`CONSTRAINED_GRID` the residue ``a`` in [-1e-3, -1e-6] is
    solved so that the pseudo plant resonates at :data:`F_SHIFT`; K is then fitted as in
    the free search and the candidate of least cost kept.

    Returns
    -------
    PeakExample
        The best constrained candidate (its ``cost`` is the free search's cost).
    """
    fitted = []
    for fc, r in CONSTRAINED_GRID:
        a = brentq(
            lambda x, fc=fc, r=r: _candidate(x, fc, r).pseudo_resonance_hz() - F_SHIFT,
            -1e-3,
            -1e-6,
            xtol=1e-10,
        )
        ex = _candidate(a, fc, r)
        if np.all(ex.sh.poles().real < 0):
            fitted.append(_fit(ex))
    return min(fitted, key=lambda e: e.cost)


def _evidence(name: str, key: str, book: str) -> dict[str, str]:
    """``miss_class``/``miss_note`` of a 12 kHz row: the free and the constrained search."""
    free, con = peak_example_baseline(), constrained_baseline()
    method = {v[0]: k for k, v in _LTI_BOOK.items()}.get(name, "")
    values = []
    for ex in (free, con):
        if not method:
            values.append(ex.pseudo_resonance_hz())
            continue
        flt, _, loc = _designs_at_gain(ex)[method]
        values.append(
            {
                "gm": loc.k_crit,
                "filter_dep": -loc.filter_departure_deg,
                "plant_dep": -loc.plant_departure_deg,
                "att": extra_attenuation_db(ex, flt, F_MODE),
            }[key]
        )
    return {
        "miss_class": "under_determined",
        "miss_note": f"the baseline loop is not printed: the free search over a, fc, r "
        f"({len(SEARCH_GRID)} candidates, K fitted) gives {values[0]:.4g} (book {book}) with a "
        f"pseudo-plant resonance of {free.pseudo_resonance_hz():.0f} Hz; constrained to the "
        f"book's 11.8 kHz resonance (fc in 300-1000 Hz, r in 2-3, a solved) the best "
        f"candidate (a = {con.residue:.3g}, fc = {con.crossover_hz:g} Hz, r = "
        f"{con.lead_spread:g}, cost {con.cost:.3g} vs {free.cost:.3g}) gives {values[1]:.4g}: "
        "no searched baseline reproduces this number",
    }


#: every row rests on the searched baseline, whose a, fc, r and K are fitted to the book
_FIT_NOTE = "baseline a, fc, r, K fitted to the printed 12 kHz margins and attenuations"


def _angle_rows(name, loc: PeakFilterLocus, book: dict[str, str], source: str, miss=None):
    miss = miss or (lambda key, text: _evidence(name, key, text))
    rows = []
    for key, upper, what in (
        ("filter_dep", loc.filter_departure_deg, "filter-pole departure"),
        ("plant_dep", loc.plant_departure_deg, "plant-pole departure"),
    ):
        if key in book:
            lower = -upper  # the conjugate pole's angle (module docstring)
            err = (lower - float(book[key]) + 180.0) % 360.0 - 180.0
            rows.append(
                Comparison(
                    f"{name}: {what} angle, error from the book's {book[key]}°",
                    0.0,
                    err,
                    "deg",
                    ANGLE_TOL_DEG,
                    source,
                    kind="fitted",
                    note=f"lower-half-plane pole {lower:.1f}° (upper {upper:.1f}°); exact residue "
                    f"angle vs the book's approximate (5.30)-(5.46), ±{ANGLE_TOL_DEG:g}° accepted; "
                    f"{_FIT_NOTE}",
                    **miss(key, book[key]),
                )
            )
    return rows


def _margin_rows(name, loc: PeakFilterLocus, book: dict[str, str], source: str, miss=None):
    miss = miss or (lambda key, text: _evidence(name, key, text))
    rows = []
    for key, value, what in (
        ("gm", loc.k_crit, "gain margin (smallest branch)"),
        ("plant_gm", loc.plant_k_crit, "plant-pole gain margin"),
        ("filter_gm", loc.filter_k_crit, "filter-pole gain margin"),
    ):
        if book.get(key, "inf") != "inf":
            rows.append(
                Comparison.printed(
                    f"{name}: {what}",
                    book[key],
                    value,
                    source=source,
                    # the §5.3.3.2 baseline (a, fc, r) is searched to minimise the errors of
                    # the printed "gm" margins (module docstring): those rows are fit targets
                    kind="fitted",
                    note="critical multiplier of the designed F on the root locus of Sh F; "
                    + ("a fit target of the baseline search; " if key == "gm" else "")
                    + _FIT_NOTE,
                    **miss(key, book[key]),
                )
            )
        elif key in book:
            rows.append(
                Comparison(
                    f"{name}: {what} is infinite (1 = yes)",
                    1.0,
                    float(np.isinf(value)),
                    "",
                    0.0,
                    source,
                    kind="fitted",
                    note=f"servokit {value:.4g}; {_FIT_NOTE}",
                    **miss(key, book[key]),
                )
            )
    return rows


#: The three LTI designs of §5.3.3.2 with the book's printed results.
_LTI_BOOK = {
    "stable": (
        "(5.18)",
        "Fig. 5.16",
        {"filter_dep": "180", "plant_dep": "0", "gm": "0.0157"},
    ),
    "phase-shift": (
        "phase shift (5.38)",
        "Fig. 5.17",
        {"filter_dep": "90", "plant_dep": "-90", "gm": "11.7", "att": "10"},
    ),
    "frequency-shift": (
        "frequency shift (5.42)",
        "Fig. 5.19",
        {"filter_dep": "90", "plant_dep": "-90", "gm": "8.22", "att": "8"},
    ),
}


def _locus_figure(ex: PeakExample, flt: control.TransferFunction, title: str, path: Path):
    locus = root_locus(ex.sh * flt, np.geomspace(1e-4, 1e2, 1500))
    fpoles = flt.poles()
    is_filter = np.array([np.min(np.abs(fpoles - p)) < 1e-6 * abs(p) for p in locus.start])
    return root_locus_plot(
        locus,
        is_filter,
        path=path,
        title=title,
        window_hz=(10e3, 16e3),
        real_window_hz=(-1.5e3, 0.5e3),
    )


def _baseline_rows(ex: PeakExample) -> list[Comparison]:
    note = (
        f"searched baseline a = {ex.residue:.3g}, fc = {ex.crossover_hz:g} Hz, r = "
        f"{ex.lead_spread:g}, K = {ex.gain:.4g} (cost {ex.cost:.3g})"
    )
    return [
        Comparison.printed(
            "pseudo-plant resonance = the frequency-shift filter's centre",
            "11.8e3",
            ex.pseudo_resonance_hz(),
            unit="Hz",
            source="§5.3.3.2",
            kind="fitted",
            note=f"{note}; {_FIT_NOTE}",
            miss_class="under_determined",
            miss_note=f"the baseline loop is not printed: the free search over a, fc, r "
            f"({len(SEARCH_GRID)} candidates, K fitted to the printed margins) puts the "
            f"resonance at {ex.pseudo_resonance_hz():.0f} Hz; holding it at the book's 11.8 kHz "
            f"(fc 300-1000 Hz, r 2-3, a solved) raises the best cost from {ex.cost:.3g} to "
            f"{constrained_baseline().cost:.3g} and moves the margins further from the book "
            "(see their rows): resonance and margins are not jointly reachable in this family",
        )
    ]


@register("peak-filter-12khz", order=310)
def peak_filter_case(outdir: Path) -> CaseResult:
    """The 12 kHz LTI peak-filter example (§5.3.3.2, Figs. 5.16-5.20) on a searched baseline.

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
    ex = peak_example_baseline()
    rows, figures = _baseline_rows(ex), []
    sens = {"baseline S0": control.feedback(1, ex.plant * ex.controller)}
    extra: dict[str, object] = {
        "filter_gain_k": ex.gain,
        "mode_residue": ex.residue,
        "crossover_hz": ex.crossover_hz,
        "search_cost": ex.cost,
    }
    for method, (flt, phi, loc) in _designs_at_gain(ex).items():
        name, fig, book = _LTI_BOOK[method]
        rows += _angle_rows(name, loc, book, fig) + _margin_rows(name, loc, book, fig)
        if "att" in book:
            fitted = method == "phase-shift"
            rows.append(
                Comparison.printed(
                    f"{name}: extra attenuation at 12 kHz",
                    book["att"],
                    extra_attenuation_db(ex, flt, F_MODE),
                    unit="dB",
                    source=fig,
                    kind="fitted",
                    note="K fitted to this row"
                    if fitted
                    else "same K as the phase-shift design; baseline a, fc, r searched to fit "
                    "this row with the three printed margins",
                    **_evidence(name, "att", book["att"]),
                )
            )
        extra[method] = {"phi_rad": phi, **loc.to_dict()}
        figures.append(
            _locus_figure(
                ex,
                flt,
                f"Root loci of Sh F, {name} ({fig})",
                outdir / f"peak12k_locus_{method.replace('-', '_')}.png",
            )
        )
        sens[f"S with F, {name}"] = control.feedback(1, ex.plant * ex.controller * (1 + flt))
    figures.append(
        bode_responses_plot(
            sens,
            np.geomspace(2e3, 3e4, 3000),
            path=outdir / "peak12k_sensitivity.png",
            title="Sensitivity with the 12 kHz peak filters (Figs. 5.18(b), 5.20(b))",
            magnitude_only=True,
        )
    )
    extra["runtime_s"] = time.perf_counter() - t0
    return CaseResult(
        name="peak-filter-12khz",
        title="LTI peak filter at a 12 kHz plant mode: zero placements (§5.3.3.2)",
        comparisons=rows,
        figures=figures,
        extra=extra,
        chapter=5,
    )


def _ltv_evidence(method: str, k: float, zeta: float, loc: PeakFilterLocus):
    """Miss evidence of an LTV-stage row: the same stage on the constrained baseline."""
    con = constrained_baseline()
    flt, _ = design_peak_filter(con.sh, F_MODE, zeta, k, method)
    alt = peak_filter_locus(con.sh, flt, F_MODE)
    text = (
        f"plant-pole gain margin {loc.plant_k_crit:.4g}, filter-pole {loc.filter_k_crit:.4g}, "
        f"departures {-loc.filter_departure_deg:.1f}°/{-loc.plant_departure_deg:.1f}° on the "
        f"free-search baseline; {alt.plant_k_crit:.4g}, {alt.filter_k_crit:.4g}, "
        f"{-alt.filter_departure_deg:.1f}°/{-alt.plant_departure_deg:.1f}° on the baseline "
        "constrained to the book's 11.8 kHz resonance"
    )

    def miss(key: str, book: str) -> dict[str, str]:
        return {
            "miss_class": "under_determined",
            "miss_note": f"the baseline loop is not printed (book {key} = {book}): {text}; "
            "neither searched baseline reproduces the printed locus",
        }

    return miss


@register("ltv-peak-filter-locus", order=320)
def ltv_locus_case(outdir: Path) -> CaseResult:
    """Root loci of the LTV filter's transient and steady stages (§5.3.3.3, Figs. 5.21-5.22).

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
    ex = peak_example_baseline()
    rows, figures, extra = _baseline_rows(ex)[:0], [], {}
    stages = (
        (
            "LTV transient stage (5.51)",
            "transient",
            1.0,
            0.1,
            "Fig. 5.21",
            {"filter_dep": "0", "plant_dep": "-180", "plant_gm": "108", "filter_gm": "inf"},
        ),
        (
            "LTV steady stage",
            "phase-shift",
            0.2,
            0.02,
            "Fig. 5.22",
            {"filter_dep": "90", "plant_dep": "-90", "plant_gm": "16", "filter_gm": "inf"},
        ),
    )
    for name, method, k, zeta, fig, book in stages:
        flt, _ = design_peak_filter(ex.sh, F_MODE, zeta, k, method)
        loc = peak_filter_locus(ex.sh, flt, F_MODE)
        ev = _ltv_evidence(method, k, zeta, loc)
        rows += _angle_rows(name, loc, book, fig, ev) + _margin_rows(name, loc, book, fig, ev)
        extra[method] = loc.to_dict()
        figures.append(
            _locus_figure(
                ex, flt, f"Root loci of Sh F, {name} ({fig})", outdir / f"ltv_locus_{method}.png"
            )
        )
    extra["runtime_s"] = time.perf_counter() - t0
    return CaseResult(
        name="ltv-peak-filter-locus",
        title="LTV peak filter: root loci of the transient and steady stages (§5.3.3.3)",
        comparisons=rows,
        figures=figures,
        extra=extra,
        chapter=5,
    )
