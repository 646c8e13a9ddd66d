"""Disturbance model of the HDD Benchmark Problem v2 (IEEJ / MSS benchmark working group).

Parameters from the benchmark's public parameter file ``hdd_distparam_v2.m``
(macs-lab/NSS-HDD-Benchmark), rebuilt here (no code copied):

* sensor noise, 1 sigma 0.015 track per PES sample (Ts = 1/(7200/60 * 220));
* force noise at the plant input, 1 sigma 1e-4 A *with sampling Ts*;
* flutter / suspension disturbance: white noise through nine resonators
  ``pk 2 zeta w^2 / (s^2 + 2 zeta w s + w^2)`` (750 ... 5000 Hz), added at the head;
* RRO at 1, 2, 3 x 120 Hz, amplitudes 0.15, 0.03, 0.006 track, seeded random phases.

Per-sample scaling (derived).  The benchmark multiplies every amplitude by
``scl = sqrt(2 Ts)`` and feeds a white sequence of variance ``1/(2 T)`` at its own sampling
period ``T``: the per-sample standard deviation is ``amp sqrt(2 Ts) / sqrt(2 T) =
amp sqrt(Ts/T)``.  At ``T = Ts`` this is ``amp`` (the "1 sigma" of the parameter file); at
the plant-input rate ``Tu = Ts/2`` the force noise has ``sqrt(2) * 1e-4`` A per sample,
which is the same one-sided PSD ``2 amp^2 Ts`` [unit^2/Hz] as 1e-4 A at Ts.  The flutter
resonators are driven by a Ts-held white sequence of standard deviation ``pk``.

Model PSDs (one-sided, [track^2/Hz]) are those of the generated sampled sequences:
``2 Ts sigma^2`` for the sensor noise, ``2 Ts pk^2 |G_d(e^{j w Ts})|^2`` for each flutter
resonator, ``G_d`` its exact ZOH discretisation (the continuous ``2 Ts pk^2 |G(j w)|^2`` differs
near Nyquist because of the hold).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from servokit._lazy import control
from servokit._lazy import scipy_signal as signal
from servokit.errors import ServokitValueError, check_count, check_positive
from servokit.models._zoh import damped_pair, modal_zoh
from servokit.models.lti_response import lti_response

__all__ = ["BenchmarkDisturbances", "DisturbanceRecord", "band_powers", "disturbance_magnitude"]

_FLUTTER_HZ = (750.0, 780.0, 900.0, 1020.0, 1080.0, 1230.0, 1800.0, 3000.0, 5000.0)
_FLUTTER_ZETA = (0.01, 0.01, 0.01, 0.01, 0.005, 0.01, 0.005, 0.002, 0.002)
_FLUTTER_PK = (0.09, 0.17, 0.20, 0.17, 0.06, 0.09, 0.06, 0.06, 0.12)


def band_powers(freq_hz: np.ndarray, psd: np.ndarray, edges_hz: np.ndarray) -> np.ndarray:
    """Power of a one-sided PSD in each band ``[edges[i], edges[i+1])`` (trapezoid).

    Comparing band powers rather than single bins makes a Welch estimate comparable with a
    model PSD at sharp resonances (leakage stays inside the band).

    Parameters
    ----------
    freq_hz : ndarray
        Frequencies of ``psd`` [Hz], increasing.
    psd : ndarray
        One-sided PSD [unit^2/Hz].
    edges_hz : ndarray
        Band edges [Hz].

    Returns
    -------
    ndarray
        Band powers [unit^2], one per band.
    """
    f, p = np.asarray(freq_hz, dtype=float), np.asarray(psd, dtype=float)
    out = []
    for lo, hi in zip(edges_hz[:-1], edges_hz[1:], strict=True):
        sel = (f >= lo) & (f < hi)
        out.append(np.trapezoid(p[sel], f[sel]))
    return np.array(out)


@dataclass(frozen=True)
class DisturbanceRecord:
    """Generated disturbance sequences (PES rate unless stated).

    Attributes
    ----------
    sensor : ndarray (n,)
        Sensor noise [track].
    force : ndarray (n, force_rate)
        Force noise [A], ``force_rate`` plant-input samples per PES sample.
    flutter : ndarray (n,)
        Flutter / suspension disturbance at the head [track].
    rro : ndarray (n,)
        Repeatable runout [track].
    dt : float
        PES sampling period Ts [s].
    """

    sensor: np.ndarray
    force: np.ndarray
    flutter: np.ndarray
    rro: np.ndarray
    dt: float

    @property
    def n(self) -> int:
        return int(self.sensor.shape[0])


@dataclass(frozen=True)
class BenchmarkDisturbances:
    """The benchmark's disturbance generator and model spectra (parameters: v2 file).

    Amplitudes can be changed (``dataclasses.replace``) or switched off (set to 0).
    """

    sensor_sigma_track: float = 0.015
    force_sigma_a: float = 1.0e-4
    flutter_freq_hz: tuple[float, ...] = _FLUTTER_HZ
    flutter_damping: tuple[float, ...] = _FLUTTER_ZETA
    flutter_peak_track: tuple[float, ...] = _FLUTTER_PK
    rro_harmonics: tuple[int, ...] = (1, 2, 3)
    rro_amplitude_track: tuple[float, ...] = (0.15, 0.03, 0.006)
    rpm: float = 7200.0
    samples_per_rev: int = 220
    force_rate: int = 2
    _cache: dict = field(default_factory=dict, init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        check_positive("rpm", self.rpm, "rpm")
        check_count("samples_per_rev", self.samples_per_rev, lo=4)
        check_count("force_rate", self.force_rate, lo=1, hi=64)
        n = len(self.flutter_freq_hz)
        if len(self.flutter_damping) != n or len(self.flutter_peak_track) != n:
            raise ServokitValueError(
                "flutter_freq_hz, flutter_damping, flutter_peak_track differ in length"
            )
        if len(self.rro_harmonics) != len(self.rro_amplitude_track):
            raise ServokitValueError("rro_harmonics and rro_amplitude_track differ in length")
        for name in ("sensor_sigma_track", "force_sigma_a"):
            if getattr(self, name) < 0:
                raise ServokitValueError(f"{name} must be >= 0")

    # -------------------------------------------------------------- timing
    @property
    def dt(self) -> float:
        """PES sampling period Ts = 60 / (rpm * samples_per_rev) [s]."""
        return 60.0 / (self.rpm * self.samples_per_rev)

    @property
    def rev_hz(self) -> float:
        """Spindle frequency [Hz] (120 Hz at 7200 rpm)."""
        return self.rpm / 60.0

    @property
    def force_sigma_per_sample_a(self) -> float:
        """Per-sample sigma of the force noise at the plant-input rate [A] (module docstring)."""
        return self.force_sigma_a * np.sqrt(self.force_rate)

    # -------------------------------------------------------------- models
    def flutter_filters(self) -> list[control.TransferFunction]:
        """Continuous resonators ``pk 2 zeta w^2 / (s^2 + 2 zeta w s + w^2)``."""
        out = []
        for f, z, pk in zip(
            self.flutter_freq_hz, self.flutter_damping, self.flutter_peak_track, strict=True
        ):
            w = 2 * np.pi * f
            out.append(control.tf([pk * 2 * z * w * w], [1.0, 2 * z * w, w * w]))
        return out

    def _discrete_flutter(self) -> list[control.TransferFunction]:
        if "flutter" not in self._cache:  # second-order sections: well-conditioned as TFs
            with warnings.catch_warnings():
                # scipy flags the ZOH numerator's tiny leading term of a 2nd-order section
                warnings.simplefilter("ignore", signal.BadCoefficients)
                self._cache["flutter"] = [
                    control.sample_system(g, self.dt, method="zoh") for g in self.flutter_filters()
                ]
        return self._cache["flutter"]

    def _flutter_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """Numerators and denominators of the ZOH resonators, one row each, padded in front
        with zeros to a common length (a leading zero leaves Horner's value unchanged)."""
        if "flutter_coef" not in self._cache:
            gs = self._discrete_flutter()
            rows = []
            for part in ([g.num_array[0, 0] for g in gs], [g.den_array[0, 0] for g in gs]):
                m = max(len(c) for c in part)
                rows.append(np.array([np.concatenate([np.zeros(m - len(c)), c]) for c in part]))
            self._cache["flutter_coef"] = (rows[0], rows[1])
        return self._cache["flutter_coef"]

    def flutter_psd(self, freq_hz: np.ndarray) -> np.ndarray:
        """One-sided PSD of the generated (sampled) flutter sequence [track^2/Hz].

        Each resonator (unit-variance white input per sample, gain ``pk`` in the filter) is
        independent, so the PSDs add.
        """
        z = np.exp(2j * np.pi * np.asarray(freq_hz, dtype=float) * self.dt)
        num, den = self._flutter_coefficients()
        # every g(z) at once by the Horner quotient np.polyval computes (the same
        # operations, element by element): the quadratures of the variance bound (6.16)
        # call this 10^4 times with one frequency, where the per-filter calls cost 4x more
        terms = np.abs(_horner_rows(num, z) / _horner_rows(den, z)) ** 2
        if z.size == 1:  # the same float additions in filter order, without array calls
            acc = 0.0
            for term in terms.ravel().tolist():
                acc += term
            return np.full(z.shape, 2.0 * self.dt * acc)
        total = np.zeros(z.shape)
        for term in terms:  # summed in filter order, as before
            total += term
        return 2.0 * self.dt * total

    def sensor_psd(self, freq_hz: np.ndarray) -> np.ndarray:
        """One-sided PSD of the sensor noise [track^2/Hz] (white)."""
        return np.full(np.shape(freq_hz), 2.0 * self.dt * self.sensor_sigma_track**2)

    def rro_freq_hz(self) -> np.ndarray:
        """RRO frequencies [Hz]."""
        return np.asarray(self.rro_harmonics, dtype=float) * self.rev_hz

    # -------------------------------------------------------------- generator
    def flutter_impulse(self, n: int) -> np.ndarray:
        """Impulse responses of the ZOH resonators, one row each, ``n`` samples [track].

        ``h[k] = C Phi(k Ts) Gamma``, ``k >= 0``: the exact ZOH of each resonator in closed
        form at every lag (:func:`~servokit.models._zoh.modal_transition`'s first row, no powers
        accumulated), one sample ahead of the held response ``(b1 z + b2)/(z^2 + a1 z +
        a2)``: the sequence the generator has always produced (``lfilter([b1, b2], [1,
        a1, a2])`` reads the coefficients in powers of ``z^-1``); a shift leaves the
        spectrum, the PSD of :meth:`flutter_psd`, unchanged.

        Parameters
        ----------
        n : int
            Samples.

        Returns
        -------
        ndarray (n_resonators, n)
        """
        n = check_count("n", n, lo=1)
        w = 2 * np.pi * np.asarray(self.flutter_freq_hz, dtype=float)
        z = np.asarray(self.flutter_damping, dtype=float)
        r = np.asarray(self.flutter_peak_track, dtype=float) * 2 * z * w * w
        _, gamma = modal_zoh(w, z, r, self.dt)
        sigma = (z * w)[:, None]
        # the first row of modal_transition's Phi = [[EC + sigma ES, ES], ...] at every lag
        ec, es = damped_pair(w[:, None], sigma, self.dt * np.arange(n)[None, :])
        return (ec + sigma * es) * gamma[:, None, 0] + es * gamma[:, None, 1]

    def _flutter_sequence(self, whites: list[np.ndarray]) -> np.ndarray:
        """The sum of the resonators driven by their white sequences, by FFT convolution.

        The same sums as filtering each sequence by its ZOH transfer function
        (``scipy.signal.lfilter``, agreeing to ~1e-15 of the sequence's size) at a
        fraction of the cost and without importing scipy.signal (start-up, issue 23).
        """
        n = whites[0].size
        size = 1 << int(2 * n - 1).bit_length()  # linear convolution: no wrap-around
        spectrum = np.zeros(size // 2 + 1, dtype=complex)
        for h, white in zip(self.flutter_impulse(n), whites, strict=True):
            spectrum += np.fft.rfft(h, size) * np.fft.rfft(white, size)
        return np.fft.irfft(spectrum, size)[:n]

    def generate(self, n_revolutions: int, seed: int = 0) -> DisturbanceRecord:
        """Seeded disturbance sequences for ``n_revolutions`` revolutions.

        Independent streams (``numpy.random.SeedSequence(seed).spawn``) for sensor, force,
        flutter and RRO phases, so switching one source off leaves the others unchanged.
        """
        n_rev = check_count("n_revolutions", n_revolutions, lo=1, hi=10_000_000)
        n = n_rev * self.samples_per_rev
        rng_s, rng_f, rng_fl, rng_r = (
            np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(4)
        )
        sensor = self.sensor_sigma_track * rng_s.standard_normal(n)
        force = self.force_sigma_per_sample_a * rng_f.standard_normal((n, self.force_rate))
        flutter = self._flutter_sequence([rng_fl.standard_normal(n) for _ in self.flutter_freq_hz])
        k = np.arange(n)
        phases = rng_r.uniform(0.0, 2 * np.pi, len(self.rro_harmonics))
        rro = np.zeros(n)
        for h, a, ph in zip(self.rro_harmonics, self.rro_amplitude_track, phases, strict=True):
            rro += a * np.sin(2 * np.pi * h * k / self.samples_per_rev + ph)
        return DisturbanceRecord(sensor, force, flutter, rro, self.dt)


#: one-point values :func:`disturbance_magnitude` remembers (a quadrature asks ~10^4)
_SEEN_MAX = 100_000


def disturbance_magnitude(disturbances, plant_d: control.LTI):
    """``freq_hz -> |D|`` of the lumped output disturbance for the variance (6.13).

    ``|D|^2 = (flutter + sensor + force-through-plant PSDs) / (2 Ts)``: a discrete shaping
    filter of unit-variance white noise.  The force noise is taken through the Ts-rate
    plant ``plant_d`` (its aliasing at the plant-input rate is neglected).

    Parameters
    ----------
    disturbances : BenchmarkDisturbances
        The disturbance model (its ``dt`` is the PES period).
    plant_d : LTI
        The plant discretised at ``dt`` (force-noise path).

    Returns
    -------
    callable
        ``freq_hz -> |D(e^{j w Ts})|``.  One-point calls are remembered: the quadratures
        of (6.13) and (6.16) ask for one frequency at a time and share about a fifth of
        their nodes (1743 of 9558 in the ``limits`` case); a repeat returns the value
        computed the first time, the same number.
    """
    dt = disturbances.dt
    seen: dict[float, float] = {}

    def evaluate(f: np.ndarray) -> np.ndarray:
        z = np.exp(2j * np.pi * f * dt)
        p2 = np.abs(np.asarray(lti_response(plant_d, z)).reshape(f.shape)) ** 2
        force = 2 * dt * disturbances.force_sigma_a**2 * p2
        psd = disturbances.flutter_psd(f) + disturbances.sensor_psd(f) + force
        return np.sqrt(psd / (2 * dt))

    def mag(freq_hz):
        f = np.asarray(freq_hz, dtype=float)
        if f.size != 1:
            return evaluate(f)
        key = float(f.reshape(-1)[0])
        if key not in seen:  # (a NaN is never found: evaluated each time, as before)
            if len(seen) >= _SEEN_MAX:  # a long-lived callable: bounded memory
                seen.clear()
            seen[key] = float(evaluate(f.reshape(1))[0])
        return np.full(f.shape, seen[key])

    return mag


def _horner_rows(coef: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``np.polyval(coef[i], z)`` for every row ``i``, stacked first (same arithmetic)."""
    y = np.zeros((coef.shape[0], *z.shape), dtype=complex)
    for k in range(coef.shape[1]):
        y = y * z + coef[:, k].reshape((-1,) + (1,) * z.ndim)
    return y
