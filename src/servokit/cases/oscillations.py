"""Unobservable oscillations and shock response spectra (book §4.3, §4.4, §4.5.3).

§4.3 and §4.4 (generic, 40 kHz sampling): unobservable magnitudes at the sampling,
Nyquist and one-third frequencies (4.41)-(4.45), the unacceptable sampling frequencies
of Fig. 4.24 and the measurement time of Fig. 4.25; shock response spectra of
half-sine and polynomial waves (4.53)-(4.61), Figs. 4.28, 4.32, 4.36, 4.37.

§4.5.3: ``yui`` of the 4.1 kHz primary mode of Table 4.1 against the sampling
frequency (Fig. 4.54) and the measurement time (Fig. 4.55).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.cases import register
from servokit.models import hdd_sampled_data
from servokit.report import CaseResult, Comparison, nearest
from servokit.report.pairing import pair_rows
from servokit.sampled.srs import (
    amplitude_spectrum,
    half_sine,
    polynomial_wave,
    shock_response_spectrum,
    spectrum_peaks,
    srs_plot,
)
from servokit.sampled.unobservable import (
    required_measurement_time,
    unacceptable_sampling_frequencies,
    unobservable_magnitude,
    unobservable_plot,
    unobservable_rms,
)

__all__ = ["oscillations_case"]


def _yui_vs_fs_figure(
    freq_hz: float, damping: float, fs: np.ndarray, level: float, title: str, path: Path
) -> Path:
    """yui of one mode against the sampling frequency for Ns = 5, 10, 20 (Figs. 4.24, 4.54)."""
    curves = {
        f"Ns = {ns}": unobservable_rms(freq_hz, 1 / fs, damping=damping, n_samples=ns, n_phases=360)
        for ns in (5, 10, 20)
    }
    unobservable_plot(
        fs / 1e3,
        curves,
        xlabel="Sampling frequency [kHz]",
        ylabel="yui [-]",
        title=title,
        level=level,
        path=path,
        logx=True,
    )
    return path


def _section_4_3(outdir: Path) -> tuple[list[Comparison], list[Path]]:
    return _section_4_3_rows(), _section_4_3_figures(outdir)


def _section_4_3_rows() -> list[Comparison]:
    """yu at three frequencies, the unacceptable sampling frequencies and tau*Ns (§4.3)."""
    tau = 25e-6
    rows = []
    for label, f, mn, mx in (
        ("sampling", 1 / tau, 1.0, 2.0),
        ("Nyquist", 0.5 / tau, 0.0, 1.0),
        ("one-third", 1 / (3 * tau), 0.134, 0.5),
    ):
        r = unobservable_magnitude(f, tau)
        rows += [
            Comparison(
                f"yu min at the {label} frequency",
                mn,
                float(r.minimum),
                "",
                0.01,
                "§4.3.1, Figs. 4.4-4.8",
            ),
            Comparison(
                f"yu max at the {label} frequency",
                mx,
                float(r.worst),
                "",
                0.01,
                "§4.3.1, Figs. 4.4-4.8",
            ),
        ]
    iv = unacceptable_sampling_frequencies(40e3, 0.01, 10, 0.2, (5e3, 200e3))
    peaks = [i.peak_hz for i in iv]
    rows += pair_rows(
        "unacceptable fs (wd 40 kHz, Ns 10, level 0.2)",
        ["13.3", "20.0", "40.0", "80.0"],
        np.asarray(peaks) / 1e3,
        unit="kHz",
        source="§4.3.2.3, Fig. 4.24",
    )
    req = required_measurement_time(40e3, 23.8e-6, 0.01, 0.2, max_samples=40)
    rows.append(
        Comparison.printed(
            "tau*Ns for yui <= 0.2 (tau 23.8 us)",
            "0.26",
            req.crossing_time_s * 1e3,
            unit="ms",
            source="§4.3.2.3, Fig. 4.25",
            note="book: 'more than 0.26 ms', read from its figure; tolerance = printed precision",
            miss_class="figure_read",
            miss_note=f"the yui = 0.2 crossing of the tau = 23.8 us curve of Fig. 4.25 is at "
            f"{req.crossing_time_s * 1e3:.4f} ms (Ns = {req.crossing_time_s / 23.8e-6:.1f} "
            "samples); the book reads 'more than 0.26 ms' off the figure",
        )
    )
    return rows


def _section_4_3_figures(outdir: Path) -> list[Path]:
    """Figs. 4.3, 4.21, 4.23 and 4.24 (tau = 25 us, zeta = 0.01)."""
    tau = 25e-6
    fig = _yui_vs_fs_figure(
        40e3,
        0.01,
        np.geomspace(5e3, 200e3, 1500),
        0.2,
        "Fig. 4.24: yui vs sampling frequency (wd = 40 kHz, zeta = 0.01)",
        outdir / "hdd_residual_fig4_24_yui_vs_fs.png",
    )
    fo = np.linspace(100.0, 100e3, 1000)
    fig0 = outdir / "hdd_residual_fig4_03_yuw_steady_state.png"
    steady = unobservable_magnitude(fo, tau, n_phases=360).worst
    unobservable_plot(
        fo / 1e3,
        {"steady state": steady},
        xlabel="Oscillation frequency [kHz]",
        ylabel="yuw [-]",
        title="Fig. 4.3: worst-case unobservable magnitude (tau = 25 us)",
        path=fig0,
    )
    maps = {
        ns: unobservable_magnitude(fo, tau, damping=0.01, n_samples=ns, n_phases=360)
        for ns in (5, 10, 20)
    }
    fig1 = outdir / "hdd_residual_fig4_21_yuw_damped.png"
    unobservable_plot(
        fo / 1e3,
        {f"Ns = {k}": m.worst for k, m in maps.items()},
        xlabel="Damped natural frequency [kHz]",
        ylabel="yuw [-]",
        title="Fig. 4.21: yuw (tau = 25 us, zeta = 0.01)",
        path=fig1,
    )
    fig2 = outdir / "hdd_residual_fig4_23_yui_damped.png"
    unobservable_plot(
        fo / 1e3,
        {f"Ns = {k}": m.rms for k, m in maps.items()},
        xlabel="Damped natural frequency [kHz]",
        ylabel="yui [-]",
        title="Fig. 4.23: yui (tau = 25 us, zeta = 0.01)",
        path=fig2,
    )
    return [fig0, fig1, fig2, fig]


def _section_4_4(outdir: Path) -> tuple[list[Comparison], list[Path]]:
    tz = 25e-6
    f = np.arange(100.0, 100e3, 10.0)
    hs = half_sine(0.5e-3)
    zoh = shock_response_spectrum(hs, tz, f, 0.0, duration=0.5e-3)
    cont = shock_response_spectrum(hs, None, f, 0.0, duration=0.5e-3)
    src = "§4.4.1.2, Fig. 4.28"
    # Tolerances: half a unit of the last printed digit, at least 1 %.
    rows = [
        Comparison(
            "SRS peak, 0.5 ms half-sine with ZOH",
            b,
            nearest(spectrum_peaks(f, zoh.magnitude), b * 1e3) / 1e3,
            "kHz",
            max(0.01, 0.05 / b),
            src,
        )
        for b in (1.4, 38.6, 41.4, 78.6, 81.4)
    ]
    rows.append(
        Comparison(
            "SRS peak, 0.5 ms half-sine without ZOH",
            1.4,
            nearest(spectrum_peaks(f, cont.magnitude), 1.4e3) / 1e3,
            "kHz",
            0.05 / 1.4,
            src,
        )
    )
    f60 = f[f < 60e3]
    one = shock_response_spectrum(half_sine(1e-3), tz, f60, 0.0, duration=1e-3)
    rows += [
        Comparison(
            "SRS peak, 1 ms half-sine with ZOH",
            b,
            nearest(spectrum_peaks(f60, one.magnitude), b * 1e3) / 1e3,
            "kHz",
            max(0.01, 0.05 / b),
            "§4.4.1.2, Fig. 4.32",
        )
        for b in (0.7, 39.3, 40.7)
    ]
    poly = polynomial_wave(40, tz, 1.0)
    band = f[(f > 30e3) & (f < 50e3)]
    p5 = shock_response_spectrum(poly, tz, band, 0.005)
    rows.append(
        Comparison(
            "largest residual, 40-sample polynomial wave (zeta 0.005)",
            38.7,
            band[np.argmax(p5.magnitude)] / 1e3,
            "kHz",
            0.01,
            "§4.4.1.3, Fig. 4.36",
        )
    )
    fig1 = outdir / "hdd_residual_fig4_28_srs_half_sine.png"
    srs_plot(
        [zoh, cont],
        ["with ZOH (25 us)", "without ZOH"],
        path=fig1,
        unit="m/s^2",
        title="Fig. 4.28: residual SRS of a 0.5 ms half-sine (zeta = 0)",
    )
    p0 = shock_response_spectrum(poly, tz, f, 0.0)
    p5f = shock_response_spectrum(poly, tz, f, 0.005)
    fig2 = outdir / "hdd_residual_fig4_37_srs_vs_dft.png"
    srs_plot(
        [p0, p5f],
        ["SRS, zeta = 0", "SRS, zeta = 0.005"],
        normalize=True,
        path=fig2,
        reference=(f, amplitude_spectrum(poly, tz, f), "amplitude spectrum (DFT)"),
        title="Fig. 4.37: SRS vs DFT, 40-sample polynomial wave",
    )
    return rows, [fig1, fig2]


def _around(row: Comparison, fd_hz: float) -> Comparison:
    """Classify a miss of an "around X kHz" value of §4.5.3 (read off Fig. 4.54)."""
    ratio = row.servokit * 1e3 / fd_hz
    return replace(
        row,
        miss_class="figure_read",
        miss_note=f"the book says 'around {row.book:g} kHz', read off Fig. 4.54 to three "
        f"digits; the computed peak of the yui curve is {row.servokit:.4g} kHz = "
        f"{ratio:.4g} fd (fd = {fd_hz:.0f} Hz), {100 * (row.servokit / row.book - 1):+.2g} % "
        "from the printed value",
    )


def _section_4_5_3(outdir: Path) -> tuple[list[Comparison], list[Path]]:
    mode = hdd_sampled_data().modes[1]
    f, zeta = mode.freq_hz, mode.damping
    src = "§4.5.3, Fig. 4.54"
    iv10 = [i.peak_hz for i in unacceptable_sampling_frequencies(f, zeta, 10, 0.1, (0.9e3, 15e3))]
    iv20 = [i.peak_hz for i in unacceptable_sampling_frequencies(f, zeta, 20, 0.1, (0.9e3, 15e3))]
    # every computed interval is paired one-to-one with the book's list (extras reported)
    rows = pair_rows(
        "unacceptable fs, Ns 10",
        ["1.02", "1.37", "2.05", "2.73", "4.10", "8.20", "12.3"],
        np.asarray(iv10) / 1e3,
        unit="kHz",
        source=src,
    )
    for i, printed in ((5, "82.0"), (6, "123")):  # misprinted in the book's text
        rows[i] = replace(rows[i], note=f"printed {printed} in the book; read as {rows[i].book:g}")
    rows += pair_rows(
        "unacceptable fs, Ns 20", ["2.05", "4.10", "8.20"], np.asarray(iv20) / 1e3,
        unit="kHz", source=src,
    )  # fmt: skip
    rows = [_around(r, f) for r in rows]
    req = required_measurement_time(f, 233e-6, zeta, 0.1, max_samples=40)
    rows.append(
        Comparison.printed(
            "tau*Ns for yui <= 0.1 (tau 233 us)",
            "3",
            req.crossing_time_s * 1e3,
            unit="ms",
            source="§4.5.3, Fig. 4.55",
            note="book: 'more than 3 ms' (one printed digit: 2.5-3.5 ms)",
        )
    )
    fig1 = _yui_vs_fs_figure(
        f,
        zeta,
        np.geomspace(0.9e3, 15e3, 1500),
        0.1,
        "Fig. 4.54: yui vs sampling frequency (4.1 kHz mode, zeta = 0.01)",
        outdir / "hdd_residual_fig4_54_yui_vs_fs_hdd.png",
    )
    fig2 = _fig_4_55(f, zeta, outdir / "hdd_residual_fig4_55_yui_vs_time_hdd.png")
    return rows, [fig1, fig2]


def _fig_4_55(f: float, zeta: float, fig2: Path) -> Path:
    """Fig. 4.55: yui against the measurement time for three sampling periods."""
    times = {}
    for fs_k in (4.1e3, 4.3e3, 4.5e3):
        r = required_measurement_time(f, 1 / fs_k, zeta, 0.1, max_samples=40)
        times[f"tau = {1e6 / fs_k:.0f} us"] = r.rms
    ns = np.arange(1, 41)
    # Curves share the Ns axis; plot each against its own tau * Ns.
    import matplotlib.pyplot as plt

    figure, ax = plt.subplots(figsize=(7, 4))
    for (label, rms), fs_k, style in zip(
        times.items(), (4.1e3, 4.3e3, 4.5e3), ("-", "--", "-."), strict=True
    ):
        ax.plot(ns / fs_k * 1e3, rms, style, label=label)
    ax.axhline(0.1, color="k", lw=0.8, ls=":", label="level 0.1")
    ax.set_xlabel("Measurement time tau x Ns [ms]")
    ax.set_ylabel("yui [-]")
    ax.set_title("Fig. 4.55: yui vs measurement time (4.1 kHz mode)")
    ax.grid(True, alpha=0.3)
    ax.legend()
    save_figure(figure, fig2)
    return fig2


@register("sampled-oscillations", order=30)
def oscillations_case(outdir: Path) -> CaseResult:
    """§4.3, §4.4, §4.5.3: unobservable magnitudes and shock response spectra.

    Parameters
    ----------
    outdir : pathlib.Path
        Directory for the figures (created if missing).

    Returns
    -------
    CaseResult
        Rows: min/max of ``yu`` at the sampling, Nyquist and one-third frequencies, the
        unacceptable sampling frequencies and measurement times of Figs. 4.24-4.25 and
        4.54-4.55, and the SRS peak frequencies of the half-sine and polynomial waves
        (Figs. 4.28, 4.32, 4.36); Figs. 4.3, 4.21, 4.23, 4.24, 4.28, 4.37, 4.54 and 4.55.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    rows: list[Comparison] = []
    figures: list[Path] = []
    for part in (_section_4_3, _section_4_4, _section_4_5_3):
        r, fg = part(outdir)
        rows += r
        figures += fg
    return CaseResult(
        name="sampled-oscillations",
        title="Unobservable oscillations and shock response spectra (§4.3-§4.5.3)",
        comparisons=rows,
        figures=figures,
        chapter=4,
    )
