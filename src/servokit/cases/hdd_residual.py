"""Unobservable oscillations and residual vibrations of an HDD seek (book §4.3-§4.5.4).

§4.3 and §4.4 (generic, 40 kHz sampling): unobservable magnitudes at the sampling,
Nyquist and one-third frequencies (4.41)-(4.45), the unacceptable sampling frequencies
of Fig. 4.24 and the measurement time of Fig. 4.25; shock response spectra of
half-sine and polynomial waves (4.53)-(4.61), Figs. 4.28, 4.32, 4.36, 4.37.

§4.5.3: ``yui`` of the 4.1 kHz primary mode of Table 4.1 against the sampling
frequency (Fig. 4.54) and the measurement time (Fig. 4.55).

§4.5.4: TDOF seek of 500 tracks (Fig. 4.57).  ``C = Cp Cn`` from (4.72)-(4.73), the
acceleration input ``Fa`` is the sixth-order sampled-data polynomial (4.60) held for
``tau_ff`` = 3, 6, 8 feedback periods with N = 40, 20, 15, and the position reference
``Fp = Mf Ip Fa`` with ``Mf`` the ZOH discretisation of ``Pf`` (4.74) including a delay.

Two facts of §4.5.4 are not printed and are recovered here from what is:

* The feedback period.  ``Mf`` runs at ``tau_fb`` ("the sampling time of Fp, Mf and Ip
  is set as tau_fb") and the poles of (4.75), ``z^2 - 0.9245 z + 0.5648``, are those of
  ``Pf`` only for ``tau_fb = Ts / 4`` = 38.375 us (the fast rate of §4.5.2); the
  ``tau_ff`` values 115/230/307 us are 3, 6 and 8 of those periods, and with it the
  loop meets the stated design (40 deg phase margin at 1 kHz, gain margin > 5 dB).
* The plant gain unit.  ``Cpc`` of (4.72) is scaled for a plant gain about 390 times
  below the ``Kp`` of Table 4.1 (other position/input units).  The gain is normalised
  so that the loop crosses 0 dB at 1 kHz, the design point of §4.5.4.1; the gain of
  ``Mf`` then follows and is compared with (4.75).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import control
import numpy as np

from servokit.cases import register
from servokit.feedforward import sampled_polynomial
from servokit.models import (
    HDD_SAMPLED_DATA_TS,
    ModalPlant,
    Mode,
    controller_fig_4_57,
    hdd_sampled_data,
)
from servokit.report import CaseResult, Comparison
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
)
from servokit.simulate import settling_time, tdof_response

__all__ = [
    "TdofSetup",
    "SeekRun",
    "crossover_gain",
    "reference_model",
    "tdof_setup",
    "tdof_seeks",
    "residual_amplitude",
    "hdd_residual_case",
]

# Case inputs (book §4.5.4): seek span, Pf parameters (4.74), hold multiples and N.
SEEK_TRACKS = 500.0
PF_RESIDUE, PF_FREQ_HZ, PF_DAMPING = -1.3, 3950.0, 0.3
#: Delay of Mf: the zeros of (4.75) are those of Pf with 20 us (twice the 10 us of (4.65)).
MF_DELAY = 20e-6
FF_CASES = ((3, 40), (6, 20), (8, 15))  # (tau_ff / tau_fb, N)
CROSSOVER_HZ = 1000.0
SRS_DAMPING = 0.01  # zeta_srs of §4.5.4.3, the damping of the 4.1 kHz mode
SETTLE_BAND = 0.1  # [track] band of the reported settling time (as in the §2.4 seeks)


def crossover_gain(plant: ModalPlant, controller: control.LTI, freq_hz: float) -> float:
    """Plant gain that puts the 0 dB crossing of ``P_d(z) C(z)`` at ``freq_hz``."""
    dt = float(controller.dt)
    z = np.exp(2j * np.pi * freq_hz * dt)
    loop = plant.discretize(dt)(z) * controller(z)
    return plant.gain / abs(complex(loop))


def reference_plant(gain: float, delay: float) -> ModalPlant:
    """``Pf(s) e^{-s delay}`` of eq. (4.74): rigid body plus one well-damped mode."""
    return ModalPlant(
        gain,
        (Mode(0.0, 0.0, 1.0), Mode(PF_FREQ_HZ, PF_DAMPING, PF_RESIDUE)),
        delay=delay,
        name="Pf (4.74)",
    )


def reference_model(gain: float, dt: float, delay: float) -> control.StateSpace:
    """``Mf(z)``: exact ZOH discretisation of ``Pf(s) e^{-s delay}``, eqs. (4.74)-(4.75)."""
    return reference_plant(gain, delay).discretize(dt)


@dataclass(frozen=True)
class TdofSetup:
    """Loop of Fig. 4.57: gain-normalised plant, ``C(z)``, ``Mf(z)`` at ``tau_fb``."""

    plant: ModalPlant
    tau_fb: float
    controller: control.TransferFunction
    mf: control.StateSpace
    gain_scale: float


def tdof_setup() -> TdofSetup:
    """Build the §4.5.4 loop (``tau_fb = Ts / 4``, gain normalised at 1 kHz crossover)."""
    tau_fb = HDD_SAMPLED_DATA_TS / 4
    ctrl = controller_fig_4_57(tau_fb)
    base = hdd_sampled_data()
    gain = crossover_gain(base, ctrl, CROSSOVER_HZ)
    plant = base.replace(gain=gain, name="hdd-sampled-data (gain normalised for (4.72))")
    return TdofSetup(plant, tau_fb, ctrl, reference_model(gain, tau_fb, MF_DELAY), gain / base.gain)


@dataclass(frozen=True)
class SeekRun:
    """One seek of §4.5.4: inputs, SRS at the mode and the simulated response."""

    tau_ff: float
    n: int
    accel: np.ndarray  # Fa as plant input (acceleration / gain), held for tau_ff
    srs_at_mode: float  # residual SRS of Fa (acceleration units) at 4.1 kHz
    t: np.ndarray
    yc: np.ndarray
    td: np.ndarray
    yd: np.ndarray
    reference: np.ndarray
    residual: float  # amplitude of the 4.1 kHz vibration after the input ends
    peak_error: float  # max |yc - target| after the input ends
    settling: float  # time [s] after which |yc - target| <= SETTLE_BAND


def residual_amplitude(
    t: np.ndarray, y: np.ndarray, t_end: float, freq_hz: float, damping: float, window: float
) -> float:
    """Initial amplitude of the damped ``freq_hz`` vibration in ``y`` on ``[t_end, t_end+window]``.

    Least-squares fit of ``e^{-zeta w s}(a cos w s + b sin w s)`` plus a cubic baseline
    (the slow settling of the loop), ``s = t - t_end``; returns ``hypot(a, b)``.
    """
    m = (t >= t_end) & (t <= t_end + window)
    s = t[m] - t_end
    w = 2 * np.pi * freq_hz
    env = np.exp(-damping * w * s)
    cols = [env * np.cos(w * s), env * np.sin(w * s)] + [(s / window) ** p for p in range(4)]
    coef, *_ = np.linalg.lstsq(np.column_stack(cols), y[m], rcond=None)
    return float(np.hypot(coef[0], coef[1]))


def tdof_seeks(setup: TdofSetup, n_samples: int = 320, substeps: int = 8) -> list[SeekRun]:
    """The three 500-track seeks of §4.5.4.2 simulated with the hybrid simulator."""
    plant, tau = setup.plant, setup.tau_fb
    mode = plant.modes[1]
    runs = []
    for k, n in FF_CASES:
        tau_ff = k * tau
        acc = np.asarray(sampled_polynomial(6, n, tau_ff, SEEK_TRACKS), dtype=float)[:n]
        srs = shock_response_spectrum(acc, tau_ff, [mode.freq_hz], SRS_DAMPING).magnitude[0]
        fa = acc / plant.gain
        # Fp = Mf Ip Fa: the TDOF reference is Pf's exact output at tau_fb (Fig. 4.57)
        tdof = tdof_response(
            plant,
            reference_plant(plant.gain, MF_DELAY),
            controller=setup.controller,
            dt=tau,
            n_samples=n_samples,
            substeps=substeps,
            feedforward=fa,
            ff_dt=tau_ff,
        )
        res, fp = tdof.sim, tdof.reference
        t_end = n * tau_ff
        yc = res.yc[0]
        after = res.t >= t_end
        runs.append(
            SeekRun(
                tau_ff,
                n,
                fa,
                float(srs),
                res.t,
                yc,
                res.td,
                res.yd[0],
                fp,
                residual_amplitude(
                    res.t, yc - SEEK_TRACKS, t_end, mode.freq_hz, mode.damping, 2e-3
                ),
                float(np.abs(yc[after] - SEEK_TRACKS).max()),
                float(settling_time(res.t, yc, SEEK_TRACKS, SETTLE_BAND)[0]),
            )
        )
    return runs


def _nearest(found: np.ndarray, value: float) -> float:
    found = np.asarray(found, dtype=float)
    return float(found[np.argmin(np.abs(found - value))]) if found.size else float("nan")


def _rank(values: list[float]) -> list[int]:
    order = np.argsort(values)
    rank = np.empty(len(values), dtype=int)
    rank[order] = np.arange(1, len(values) + 1)
    return [int(r) for r in rank]


def _section_4_3(outdir: Path) -> tuple[list[Comparison], list[Path]]:
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
    rows += [
        Comparison(
            "unacceptable fs (wd 40 kHz, Ns 10, level 0.2)",
            b,
            _nearest(peaks, b * 1e3) / 1e3,
            "kHz",
            0.01,
            "§4.3.2.3, Fig. 4.24",
        )
        for b in (13.3, 20.0, 40.0, 80.0)
    ]
    req = required_measurement_time(40e3, 23.8e-6, 0.01, 0.2, max_samples=40)
    rows.append(
        Comparison(
            "tau*Ns for yui <= 0.2 (tau 23.8 us)",
            0.26,
            req.crossing_time_s * 1e3,
            "ms",
            0.10,
            "§4.3.2.3, Fig. 4.25",
        )
    )
    fs = np.geomspace(5e3, 200e3, 1500)
    curves = {
        f"Ns = {ns}": unobservable_magnitude(
            40e3, 1 / fs, damping=0.01, n_samples=ns, n_phases=360
        ).rms
        for ns in (5, 10, 20)
    }
    fig = outdir / "hdd_residual_fig4_24_yui_vs_fs.png"
    unobservable_plot(
        fs / 1e3,
        curves,
        xlabel="Sampling frequency [kHz]",
        ylabel="yui [-]",
        title="Fig. 4.24: yui vs sampling frequency (wd = 40 kHz, zeta = 0.01)",
        level=0.2,
        path=fig,
        logx=True,
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
    return rows, [fig0, fig1, fig2, fig]


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
            _nearest(spectrum_peaks(f, zoh.magnitude), b * 1e3) / 1e3,
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
            _nearest(spectrum_peaks(f, cont.magnitude), 1.4e3) / 1e3,
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
            _nearest(spectrum_peaks(f60, one.magnitude), b * 1e3) / 1e3,
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


def _section_4_5_3(outdir: Path) -> tuple[list[Comparison], list[Path]]:
    mode = hdd_sampled_data().modes[1]
    f, zeta = mode.freq_hz, mode.damping
    src = "§4.5.3, Fig. 4.54"
    iv10 = [i.peak_hz for i in unacceptable_sampling_frequencies(f, zeta, 10, 0.1, (0.9e3, 15e3))]
    iv20 = [i.peak_hz for i in unacceptable_sampling_frequencies(f, zeta, 20, 0.1, (0.9e3, 15e3))]
    rows = [
        Comparison(
            f"unacceptable fs, Ns 10{note}", b, _nearest(iv10, b * 1e3) / 1e3, "kHz", 0.01, src
        )
        for b, note in (
            (1.02, ""),
            (1.37, ""),
            (2.05, ""),
            (2.73, ""),
            (4.10, ""),
            (8.20, " (printed 82.0)"),
            (12.3, " (printed 123)"),
        )
    ]
    rows += [
        Comparison("unacceptable fs, Ns 20", b, _nearest(iv20, b * 1e3) / 1e3, "kHz", 0.01, src)
        for b in (2.05, 4.10, 8.20)
    ]
    req = required_measurement_time(f, 233e-6, zeta, 0.1, max_samples=40)
    rows.append(
        Comparison(
            "tau*Ns for yui <= 0.1 (tau 233 us)",
            3.0,
            req.crossing_time_s * 1e3,
            "ms",
            0.10,
            "§4.5.3, Fig. 4.55",
        )
    )
    fs = np.geomspace(0.9e3, 15e3, 1500)
    curves = {
        f"Ns = {ns}": unobservable_magnitude(
            f, 1 / fs, damping=zeta, n_samples=ns, n_phases=360
        ).rms
        for ns in (5, 10, 20)
    }
    fig1 = outdir / "hdd_residual_fig4_54_yui_vs_fs_hdd.png"
    unobservable_plot(
        fs / 1e3,
        curves,
        xlabel="Sampling frequency [kHz]",
        ylabel="yui [-]",
        title="Fig. 4.54: yui vs sampling frequency (4.1 kHz mode, zeta = 0.01)",
        level=0.1,
        path=fig1,
        logx=True,
    )
    times = {}
    for fs_k in (4.1e3, 4.3e3, 4.5e3):
        r = required_measurement_time(f, 1 / fs_k, zeta, 0.1, max_samples=40)
        times[f"tau = {1e6 / fs_k:.0f} us"] = r.rms
    ns = np.arange(1, 41)
    fig2 = outdir / "hdd_residual_fig4_55_yui_vs_time_hdd.png"
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
    figure.tight_layout()
    figure.savefig(fig2, dpi=110)
    plt.close(figure)
    return rows, [fig1, fig2]


def _section_4_5_4(outdir: Path) -> tuple[list[Comparison], list[Path], dict]:
    setup = tdof_setup()
    mf = control.ss2tf(setup.mf)
    zeros = np.sort(np.real_if_close(control.zeros(mf)).real)
    poles = control.poles(mf)
    cplx = poles[np.abs(poles.imag) > 1e-9]
    quad = np.real(np.poly(cplx[:2]))
    num = np.trim_zeros(np.asarray(mf.num[0][0], dtype=float), "f")
    den = np.asarray(mf.den[0][0], dtype=float)
    gain = float(num[0] / den[0])
    src = "§4.5.4.2, eq. (4.75)"
    rows = [
        Comparison(f"Mf zero {b:g}", b, _nearest(zeros, b), "", 0.01, src)
        for b in (14.34, 0.3574, -0.1314, -2.408)
    ]
    rows += [
        Comparison("Mf pole pair: z coefficient", -0.9245, float(quad[1]), "", 0.01, src),
        Comparison("Mf pole pair: constant", 0.5648, float(quad[2]), "", 0.01, src),
        Comparison("Mf gain (plant gain from the 1 kHz crossover)", -3.157e-6, gain, "", 0.01, src),
    ]
    runs = tdof_seeks(setup)
    srs_rank = _rank([r.srs_at_mode for r in runs])
    res_rank = _rank([r.residual for r in runs])
    for run, b_rank, s_rank, r_rank in zip(runs, (1, 3, 2), srs_rank, res_rank, strict=True):
        us = f"{run.tau_ff * 1e6:.0f} us"
        rows += [
            Comparison(
                f"rank of SRS at 4.1 kHz, tau_ff {us} (1 = smallest)",
                b_rank,
                s_rank,
                "",
                0.0,
                "§4.5.4.3, Fig. 4.61",
            ),
            Comparison(
                f"rank of simulated residual, tau_ff {us}",
                b_rank,
                r_rank,
                "",
                0.0,
                "§4.5.4.4, Figs. 4.62-4.63",
            ),
        ]
    margins = control.stability_margins(
        control.ss(setup.plant.discretize(setup.tau_fb)) * control.ss(setup.controller)
    )
    z1k = np.exp(2j * np.pi * CROSSOVER_HZ * setup.tau_fb)
    loop_1k = complex(setup.plant.discretize(setup.tau_fb)(z1k) * setup.controller(z1k))
    extra = {
        "tau_fb_s": setup.tau_fb,
        "gain_scale_vs_table_4_1": setup.gain_scale,
        "phase_margin_at_1kHz_deg": 180.0 + float(np.degrees(np.angle(loop_1k))),
        "gain_margin_db": float(20 * np.log10(margins[0])),
        "seeks": [
            {
                "tau_ff_s": r.tau_ff,
                "N": r.n,
                "srs_at_4100Hz": r.srs_at_mode,
                "residual_4100Hz_tracks": r.residual,
                "peak_error_after_seek_tracks": r.peak_error,
                "settling_time_s": r.settling,
                "settling_band_tracks": SETTLE_BAND,
            }
            for r in runs
        ],
    }
    f = np.linspace(100.0, 10e3, 2000)
    spectra = [
        shock_response_spectrum(r.accel * setup.plant.gain, r.tau_ff, f, SRS_DAMPING) for r in runs
    ]
    labels = [f"tau_ff = {r.tau_ff * 1e6:.0f} us, N = {r.n}" for r in runs]
    fig1 = outdir / "hdd_residual_fig4_61_srs_seek_inputs.png"
    srs_plot(
        spectra,
        labels,
        path=fig1,
        unit="track/s^2",
        marks_hz=(setup.plant.modes[1].freq_hz,),
        title="Fig. 4.61: residual SRS of the seek accelerations (zeta = 0.01)",
    )
    fig2 = outdir / "hdd_residual_fig4_62_tdof_seek.png"
    _seek_plot(runs, fig2)
    fig3 = outdir / "hdd_residual_fig4_60_feedforward.png"
    _inputs_plot(runs, setup, fig3)
    return rows, [fig3, fig1, fig2], extra


def _inputs_plot(runs: list[SeekRun], setup: TdofSetup, path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for r, style in zip(runs, ("-", "--", "-."), strict=True):
        label = f"tau_ff = {r.tau_ff * 1e6:.0f} us"
        t_ff = np.arange(r.n + 1) * r.tau_ff
        a1.step(
            t_ff * 1e3, np.r_[r.accel, 0.0] * setup.plant.gain, style, where="post", label=label
        )
        a2.plot(r.td * 1e3, r.reference, style, label=label)
    a1.set_ylabel("Fa [track/s^2]")
    a1.set_title("Fig. 4.60: (a) acceleration feedforward Fa, (b) position reference Fp")
    a2.set_ylabel("Fp [track]")
    a2.set_xlabel("Time [ms]")
    a2.set_xlim(0, 1.5 * runs[0].n * runs[0].tau_ff * 1e3)
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _seek_plot(runs: list[SeekRun], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for r, style in zip(runs, ("-", "--", "-."), strict=True):
        label = f"tau_ff = {r.tau_ff * 1e6:.0f} us"
        a1.plot(r.t * 1e3, r.yc, style, label=label)
        a2.plot(r.t * 1e3, r.yc - SEEK_TRACKS, style, label=label)
    a1.set_ylabel("Head position yc [track]")
    a1.set_title("Figs. 4.62-4.63: simulated 500-track TDOF seeks")
    a2.set_ylabel("yc - target [track]")
    a2.set_ylim(-1.5, 1.5)
    a2.set_xlabel("Time [ms]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


@register("hdd-residual")
def hdd_residual_case(outdir: Path) -> CaseResult:
    """§4.3-§4.5.4: unobservable magnitudes, SRS and the residual vibrations of HDD seeks."""
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    rows: list[Comparison] = []
    figures: list[Path] = []
    for part in (_section_4_3, _section_4_4, _section_4_5_3):
        r, fg = part(outdir)
        rows += r
        figures += fg
    r, fg, extra = _section_4_5_4(outdir)
    return CaseResult(
        name="hdd-residual",
        title="Unobservable oscillations, shock response spectra, HDD residual vibrations",
        comparisons=rows + r,
        figures=figures + fg,
        extra=extra,
    )
