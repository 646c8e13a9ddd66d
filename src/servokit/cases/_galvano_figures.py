"""Figures of the galvano scanner case (Figs. 2.25-2.26, 2.28, 2.36 and 2.39).

Drawn by :func:`servokit.cases.galvano.run` from the designs of
:mod:`servokit.cases.galvano_designs`.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from servokit._figures import save_figure
from servokit.cases.galvano_designs import (
    _AMP_DROP,
    _BAND,
    _LIMITS,
    _N_GALVANO_I,
    _REFERENCE_STEP,
    _STEPS,
    _V_MAX,
    GALVANO_TS,
    ConstrainedDesign,
    GalvanoIResult,
    galvano_scanner,
    normalised_plant,
)


def _plot_galvano_i(res: GalvanoIResult, outdir: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = []
    fig, (ax_u, ax_s) = plt.subplots(2, 1, figsize=(7, 7))
    plant = normalised_plant(galvano_scanner(), _N_GALVANO_I * GALVANO_TS)
    f1, f2 = (m.freq_hz for m in plant.modes if m.freq_hz > 0)
    for ff, style, name in ((res.fsc, "--", "FSC"), (res.ffsc, "-", "FFSC")):
        edges = np.arange(ff.N + 1) * ff.dt
        ax_u.stairs(ff.u, edges, linestyle=style, label=name)
        # spectrum on the time-normalised grid, plotted against f / f1 as in Fig. 2.26
        f = np.linspace(0.0, 3.5, 1200)
        ax_s.semilogy(f, np.abs(ff.spectrum(f * f1)) + 1e-12, style, label=name)
    ax_u.set_xlabel("time [s/unit] (final time = 1)")
    ax_u.set_ylabel("input u_c [A/unit]")
    ax_u.set_title("Galvano I: FSC and FFSC inputs (Fig. 2.25, illustrative model)")
    ax_u.legend()
    ax_u.grid(True, alpha=0.3)
    for fm in (1.0, f2 / f1):
        ax_s.axvline(fm, color="k", linestyle=":", linewidth=0.8)
    ax_s.set_xlabel("frequency [Hz/unit] (primary mode = 1)")
    ax_s.set_ylabel("|U_c| [A s/unit^2]")
    ax_s.set_title("Spectra of the inputs (Fig. 2.26)")
    ax_s.legend()
    ax_s.grid(True, alpha=0.3)
    paths.append(save_figure(fig, outdir / "galvano_fig_2_25_2_26_inputs.png"))

    fig, axes = plt.subplots(2, 1, figsize=(7, 7), sharex=True, sharey=True)
    cmap = plt.get_cmap("viridis")
    for ax, y, name in ((axes[0], res.y_fsc, "FSC"), (axes[1], res.y_ffsc, "FFSC")):
        for i, p in enumerate(res.percents):
            lbl = f"{p:+.0f} %" if i % 3 == 0 else None
            ax.plot(res.t, y[i], color=cmap((p + 6) / 12), linewidth=0.9, label=lbl)
        for b in (1 + _BAND, 1 - _BAND):
            ax.axhline(b, color="k", linestyle=":", linewidth=0.8)
        ax.set_ylim(1 - 6 * _BAND, 1 + 6 * _BAND)
        ax.set_xlim(0.8, 3.0)
        ax.set_ylabel("output y [rad/unit]")
        ax.set_title(f"{name}: primary mode -6 % .. +6 % (band +-0.08 %)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, ncol=5, loc="lower right")
    axes[1].set_xlabel("time [s/unit]")
    paths.append(save_figure(fig, outdir / "galvano_fig_2_28_outputs.png"))
    return paths


def _limit_label(limit: float | None) -> str:
    return "no voltage limit" if limit is None else f"|V| <= {limit:g} V"


def _plot_galvano_ii(designs: list[ConstrainedDesign], outdir: Path) -> list[Path]:
    import matplotlib.pyplot as plt

    paths = []
    fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex="col")
    for col, target in enumerate((1e-3, 1e-2)):
        ds = [d for d in designs if d.target == target]
        for d in ds:
            t = np.arange(d.N + 1) * d.ff.dt * 1e3
            lbl = _limit_label(d.voltage_limit)
            axes[0, col].stairs(d.voltage, t, label=lbl)
            axes[1, col].stairs(d.current, t, label=lbl)
            axes[2, col].plot(t[:-1], d.velocity, label=lbl)
        for lim in (lim for lim in _LIMITS if lim is not None):
            for sign in (1, -1):
                axes[0, col].axhline(sign * lim, color="k", linestyle=":", linewidth=0.7)
        for sign in (1, -1):
            axes[2, col].axhline(sign * _V_MAX, color="k", linestyle=":", linewidth=0.7)
        axes[0, col].set_title(f"{target * 1e3:g} mm step, N = {ds[0].N}")
        axes[2, col].set_xlabel("time [ms]")
    for row, name in enumerate(("motor voltage (2.84) [V]", "current [A]", "velocity [m/s]")):
        axes[row, 0].set_ylabel(name)
        for ax in axes[row]:
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Galvano II: voltage-constrained FFSC trajectories (Fig. 2.36, illustrative)")
    paths.append(save_figure(fig, outdir / "galvano_fig_2_36_waveforms.png"))

    fig, ax = plt.subplots(figsize=(7, 4.5))
    v_free = next(
        float(np.max(np.abs(d.voltage)))
        for d in designs
        if d.target == _REFERENCE_STEP and d.voltage_limit is None
    )
    for target, book_N in ((t, n) for t, n in _STEPS):
        ds = [d for d in designs if d.target == target]
        x = [v_free if d.voltage_limit is None else d.voltage_limit for d in ds]
        n_txt = f"N = {ds[0].N}"
        if ds[0].N != book_N:
            n_txt += f"; limits infeasible at N = {book_N}"
        ax.plot(x, [d.pamp for d in ds], "o-", label=f"{target * 1e3:g} mm step ({n_txt})")
    ax.set_xticks(
        [36.0, 72.0, v_free],
        [
            "36\n(Vp = 52)",
            "72\n(Vp = 88)",
            f"{v_free:.0f} (no limit)\n(Vp = {v_free + _AMP_DROP:.0f})",
        ],
    )
    ax.set_xlabel("motor-voltage constraint [V] (supply Vp = constraint + 16 V)")
    ax.set_ylabel("Pamp (2.89) [W]")
    ax.set_title("Amplifier loss vs voltage constraint (Fig. 2.39, illustrative motor)")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    paths.append(save_figure(fig, outdir / "galvano_fig_2_39_energy.png"))
    return paths
