"""Identification of a continuous plant above the Nyquist frequency (book §5.2.1.2, §5.2.2.2).

The plant Pm(s) sits in a digital loop (ZOH, PES sampled at T, controller C(z)). Two
simulated closed-loop measurements, each run as one batch over all excitation
frequencies with :func:`servokit.simulate.simulate`:

1. Sd(e^{jω'T}): a discrete-time sinusoid d_k = cos(ωd kT) held over T is added to the
   plant input; the total plant input v_k = d_k + u_k obeys v = Sd d, so
   Sd = V(ω') / D(ω') at the aliased frequency ω' of (5.11) (the book's "discrete-time
   sinusoid sampled at 30 kHz ... periodically extended up to 60 kHz").
2. [Pm D]*: the same sinusoid generated at the fine rate T/substeps and held there (the
   book's continuous excitation; its "maximum step 2.77 μs" is T/12 at 30 kHz) is added
   to the plant input; the sampled output obeys y* = Sd [Pm D]* (5.8), so
   Pm(jωd) = Y(ω') / (Sd(e^{jω'T}) D(jωd)), (5.10)-(5.11), with D(jωd) the fundamental
   of the applied held sinusoid, ½ (1 − e^{−jωd h}) / (jωd h), h = T/substeps.

Y(ω'), V(ω') are the projections of the steady-state samples on e^{jω'kT} over a window
holding a whole number of periods. Frequencies whose alias ω' is 0 or the Nyquist
frequency (multiples of 1/(2T)) are excluded: there e^{jω'kT} is real and the response
cannot be told from its conjugate.

Book correction: (5.9) prints S*(s) = G*C*/(1 + G*C*), the complementary sensitivity;
with R = 0 the loop gives y* = [Pm D]* − G*C* y*, i.e. S* = 1/(1 + G*C*), which is what
(5.8) and (5.10) need (and what "the sensitivity transfer function" means).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_memory, check_positive
from servokit.models.modal import ModalPlant
from servokit.models.rational import as_state_space_data, series

__all__ = [
    "Identification",
    "identify_above_nyquist",
    "identification_plot",
    "excitation_frequencies",
    "aliased_frequency",
    "settling_samples",
]


@dataclass(frozen=True)
class Identification:
    """Result of :func:`identify_above_nyquist` (excluded frequencies removed)."""

    freq_hz: np.ndarray  #: excitation frequencies ωd / 2π [Hz]
    aliased_hz: np.ndarray  #: ω'd / 2π of (5.11) [Hz]
    sd: np.ndarray  #: measured Sd(e^{jω'T}) (complex)
    response: np.ndarray  #: recovered Pm(jωd) (complex)
    excluded_hz: np.ndarray  #: excitation frequencies dropped (alias 0 or Nyquist) [Hz]
    dt: float  #: PES sampling period T [s]

    def errors(self, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Magnitude [dB] and phase [deg] errors of ``response`` against ``true``."""
        ratio = self.response / np.asarray(true, dtype=complex)
        return 20 * np.log10(np.abs(ratio)), np.degrees(np.angle(ratio))

    def to_dict(self) -> dict[str, object]:
        return {
            "freq_hz": self.freq_hz,
            "aliased_hz": self.aliased_hz,
            "magnitude_db": 20 * np.log10(np.abs(self.response)),
            "phase_deg": np.degrees(np.angle(self.response)),
            "sd_magnitude_db": 20 * np.log10(np.abs(self.sd)),
            "sd_phase_deg": np.degrees(np.angle(self.sd)),
            "excluded_hz": self.excluded_hz,
            "dt_s": self.dt,
        }


def aliased_frequency(freq_hz: np.ndarray, dt: float) -> np.ndarray:
    """ω'd / 2π = fd − n/T in [0, 1/T), eq. (5.11).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Excitation frequencies [Hz].
    dt : float
        Sampling period T [s].

    Returns
    -------
    numpy.ndarray
        The aliased frequencies [Hz].
    """
    fs = 1.0 / dt
    a = np.mod(np.asarray(freq_hz, dtype=float), fs)
    # 1/(1/fs) may round above fs: a multiple of fs must alias to 0, not to fs
    return np.where(np.isclose(a, fs, rtol=1e-12, atol=0.0), 0.0, a)


def settling_samples(
    plant: ModalPlant, controller: control.LTI, dt: float, tol: float, *, in_loop: bool = True
) -> int:
    """Samples for the slowest pole to decay to ``tol``: of the digital loop P C, or of
    the plant alone when it sits outside the loop (``in_loop=False``).

    Parameters
    ----------
    plant : ModalPlant
        The continuous plant (discretised exactly at ``dt``).
    controller : control.LTI or RationalTF
        Discrete controller.
    dt : float
        Sampling period [s].
    tol : float
        Relative decay.
    in_loop : bool
        Whether ``plant`` is inside the loop.

    Returns
    -------
    int
        Number of samples.
    """
    rho = float(np.max(np.abs(_loop_poles(plant, controller, dt, in_loop))))
    if rho >= 1.0:
        what = "digital loop" if in_loop else "plant"
        raise ServokitValueError(f"the {what} is unstable; identification needs a stable one")
    return int(np.ceil(np.log(tol) / np.log(rho)))


def _loop_poles(plant: ModalPlant, controller: Any, dt: float, in_loop: bool) -> np.ndarray:
    """Poles of the unity-feedback loop ``P_d C`` (or of ``P_d`` alone) with numpy: the
    exact ZOH in closed form per mode and the controller's companion form (a python-control
    controller is converted), python-control and scipy left unloaded (start-up, issue 23)."""
    pd = plant.discretize_data(dt, method="modal")
    if not in_loop:
        return pd.poles()
    return series(as_state_space_data(controller), pd).feedback(1.0).poles()


def _project(x: np.ndarray, f_alias: np.ndarray, dt: float, k0: int) -> np.ndarray:
    """2/N Σ x_k e^{−jω'kT} over samples k0.. (absolute k, the excitation's time origin)."""
    k = k0 + np.arange(x.shape[1])
    return 2.0 * np.mean(x * np.exp(-2j * np.pi * f_alias[:, None] * dt * k), axis=1)


def _held_sinusoids(freq: np.ndarray, dt: float, substeps: int, hold: int, n: int) -> np.ndarray:
    """cos(2π f t) sampled every ``hold`` fine steps (of T/substeps) and held, (F, n substeps)."""
    h = dt / substeps
    # cos once per held value, then repeated: the same numbers as cos on every fine step
    t_held = h * np.arange(0, n * substeps, hold)
    held = np.cos(2 * np.pi * freq[:, None] * t_held[None, :])
    return held if hold == 1 else np.repeat(held, hold, axis=1)[:, : n * substeps]


def _closed_loop(
    loop_plant: ModalPlant, controller: control.LTI, dt: float, substeps: int, n: int, **signals
):
    from servokit.simulate import simulate

    rows = next(iter(signals.values())).shape[0]
    return simulate(
        [loop_plant] * rows,
        dt=dt,
        n_samples=n,
        substeps=substeps,
        controller=controller,
        check_stability=False,
        samples_only=True,  # the measurements read the samples only
        **signals,
    )


def _measure_sd(loop_plant, controller, dt, freq, substeps, n) -> np.ndarray:
    """Total plant-input samples v_k under a T-held sinusoid at the loop plant's input."""
    d = _held_sinusoids(freq, dt, substeps, substeps, n)
    return _closed_loop(loop_plant, controller, dt, substeps, n, input_disturbance=d).u


def _measure_output(plant, loop_plant, controller, dt, freq, substeps, n) -> np.ndarray:
    """Sampled output y_k with the fine-held sinusoid driving ``plant``."""
    from servokit.simulate import simulate

    d = _held_sinusoids(freq, dt, substeps, 1, n)
    if plant is loop_plant:
        return _closed_loop(plant, controller, dt, substeps, n, input_disturbance=d).yd
    # the measured actuator sits outside the loop: its output adds to the PES (Fig. 5.9);
    # the loop reads that output at its samples only (held here to the fine grid)
    yk = simulate(
        [plant] * freq.size,
        dt=dt,
        n_samples=n,
        substeps=substeps,
        input_disturbance=d,
        samples_only=True,
    ).yd
    dc = np.repeat(yk, substeps, axis=1)
    return _closed_loop(loop_plant, controller, dt, substeps, n, output_disturbance=dc).yd


def excitation_frequencies(fmin_hz: float, fmax_hz: float, step_hz: float) -> np.ndarray:
    """The excitation grid fmin, fmin + step, ... up to fmax (within rounding) [Hz].

    Parameters
    ----------
    fmin_hz, fmax_hz : float
        First and last excitation frequency [Hz], 0 < fmin_hz <= fmax_hz.
    step_hz : float
        Spacing [Hz], > 0.

    Returns
    -------
    numpy.ndarray
        The frequencies [Hz].
    """
    lo, hi, step = (check_positive(n, v, "Hz") for n, v in
                    (("fmin_hz", fmin_hz), ("fmax_hz", fmax_hz), ("step_hz", step_hz)))  # fmt: skip
    if hi < lo:
        raise ServokitValueError(f"fmax_hz must be >= fmin_hz (got {hi:g} < {lo:g})")
    # the 1e-9 keeps fmax itself when (fmax - fmin) / step is a whole number up to rounding
    return lo + step * np.arange(int(np.floor((hi - lo) / step + 1e-9)) + 1)


def identify_above_nyquist(
    plant: ModalPlant,
    controller: control.LTI,
    freq_hz: np.ndarray,
    *,
    substeps: int = 12,
    n_measure: int | None = None,
    settle_tol: float = 1e-5,
    chunk: int = 150,
    max_memory_mb: float | None = None,
    progress: Callable[[int], None] | None = None,
    loop_plant: ModalPlant | None = None,
) -> Identification:
    """Recover Pm(jω) above the Nyquist frequency from simulated closed-loop data, (5.10)-(5.11).

    Parameters
    ----------
    plant : ModalPlant
        The continuous plant Pm(s) (e.g. Table 5.1 VCM, Table 5.3 PZT).
    controller : python-control LTI or RationalTF
        Discrete controller C(z); its ``dt`` is the PES sampling period T.
    freq_hz : array_like
        Excitation frequencies [Hz], any values (above 1/(2T) too).
    substeps : int
        Fine steps per T on which the "continuous" excitation is generated and held.
    n_measure : int, optional
        Samples of the measurement window; default one whole period of the frequency grid
        spacing (all multiples of the spacing then complete whole periods).
    settle_tol : float
        Transient decay (relative) before the window; sets the settling samples.
    chunk : int
        Frequencies simulated together (memory); progress is reported per chunk.
    loop_plant : ModalPlant, optional
        The actuator the loop is closed around when ``plant`` is measured outside it (the
        PZT of Fig. 5.9 with the VCM loop): Sd is that loop's, ``plant``'s output adds to
        the PES. Default: ``plant`` itself is in the loop (Fig. 5.5).
    max_memory_mb : float, optional
        Memory limit of one chunk [MB] (checked before allocating).
    progress : callable, optional
        Called with the number of frequencies done after each chunk.

    Returns
    -------
    Identification
        Recovered Pm(jωd), measured Sd and the excluded frequencies.
    """
    dt = check_positive("controller dt", getattr(controller, "dt", None) or np.nan, "s")
    f = np.asarray(freq_hz, dtype=float).ravel()
    if f.size == 0 or np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ServokitValueError("freq_hz must be positive finite frequencies [Hz]")
    S = check_count("substeps", substeps, lo=1, hi=1000)
    fs = 1.0 / dt
    if f.max() >= 0.5 * fs * S:
        raise ServokitValueError(
            f"freq_hz must stay below half the excitation rate {0.5 * fs * S:g} Hz; raise substeps"
        )
    alias = aliased_frequency(f, dt)
    nyq = np.isclose(alias, 0.0, atol=1e-9 * fs) | np.isclose(alias, fs, atol=1e-9 * fs)
    bad = nyq | np.isclose(alias, 0.5 * fs, atol=1e-9 * fs)
    if n_measure is None:
        spacing = np.gcd.reduce(np.round(f).astype(np.int64)) if np.allclose(f, np.round(f)) else 0
        n_measure = int(round(fs / spacing)) if spacing and abs(fs / spacing % 1) < 1e-9 else 4096
    n_meas = check_count("n_measure", n_measure, lo=8)
    lp = plant if loop_plant is None else loop_plant
    n_settle = settling_samples(lp, controller, dt, settle_tol)
    if lp is not plant:
        n_settle = max(n_settle, settling_samples(plant, controller, dt, settle_tol, in_loop=False))
    n_total = n_settle + n_meas
    # per frequency: input, fine output and windows (~6 S per sample) and the modal states
    per_freq = n_total * 8.0 * (6 * S + 2 * len(plant.modes))
    check_memory(
        per_freq * min(chunk, f.size),
        what=f"{min(chunk, f.size)} frequencies x {n_total} samples",
        flag="--max-memory-mb (or a smaller chunk)",
        max_memory_mb=max_memory_mb,
    )
    keep = np.flatnonzero(~bad)
    sd = np.empty(keep.size, dtype=complex)
    y = np.empty(keep.size, dtype=complex)
    for lo in range(0, keep.size, chunk):
        idx = keep[lo : lo + chunk]
        v = _measure_sd(lp, controller, dt, f[idx], S, n_total)
        sd[lo : lo + idx.size] = _project(v[:, n_settle:], alias[idx], dt, n_settle)
        yd = _measure_output(plant, lp, controller, dt, f[idx], S, n_total)
        y[lo : lo + idx.size] = _project(yd[:, n_settle:], alias[idx], dt, n_settle)
        if progress is not None:
            progress(idx.size)
    fk = f[keep]
    wh = 2 * np.pi * fk * dt / S
    held = (1 - np.exp(-1j * wh)) / (1j * wh)  # fundamental of the sinusoid held at T/S
    return Identification(
        freq_hz=fk,
        aliased_hz=alias[keep],
        sd=sd,
        response=y / (sd * held),
        excluded_hz=f[bad],
        dt=dt,
    )


def identification_plot(
    result: Identification,
    true_response: np.ndarray,
    *,
    path: str,
    title: str,
) -> str:
    """Recovered vs true magnitude [dB] and phase [deg]; multiples of 1/T marked.

    Parameters
    ----------
    result : Identification
        The identification.
    true_response : numpy.ndarray
        The true plant response at ``result.freq_hz``.
    path : str
        Figure file.
    title : str
        Figure title (with the book's figure number).

    Returns
    -------
    str
        The written figure's path.
    """
    import matplotlib.pyplot as plt

    from servokit._figures import save_figure

    f = result.freq_hz / 1e3
    fig, (ax_m, ax_p) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 6))
    true = np.asarray(true_response, dtype=complex)
    ax_m.plot(f, 20 * np.log10(np.abs(true)), "k-", lw=1.0, label="true plant")
    ax_m.plot(f, 20 * np.log10(np.abs(result.response)), "r.", ms=2.5, label="identified (5.10)")
    ax_p.plot(f, np.degrees(np.angle(true)), "k-", lw=1.0, label="true plant")
    ax_p.plot(f, np.degrees(np.angle(result.response)), "r.", ms=2.5, label="identified")
    fs = 1.0 / result.dt
    for ax in (ax_m, ax_p):
        for k in range(1, int(f.max() * 1e3 // (0.5 * fs)) + 1):
            ax.axvline(0.5 * fs * k / 1e3, color="gray", lw=0.6, ls=":" if k % 2 else "--")
        ax.grid(True, alpha=0.3)
    ax_m.set_ylabel("Magnitude [dB]")
    ax_p.set_ylabel("Phase [deg]")
    ax_p.set_xlabel("Frequency [kHz]  (dotted: Nyquist multiples, dashed: sampling multiples)")
    ax_m.legend(loc="best", fontsize=8)
    ax_m.set_title(title)
    save_figure(fig, path)
    return path
