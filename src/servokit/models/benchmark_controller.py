"""A track-following controller for the HDD benchmark plant (book eq. 2.73, Table 2.2).

The book shows its chapter-6 loops only as figures, so servokit designs a baseline of
the classic benchmark kind (PID + notch filters, as in the benchmark's own example):

* PI + lead: ``K (s + wc/8)/s * (s/(wc/3) + 1)/(s/(3 wc) + 1)`` with ``wc = 2 pi 1 kHz``;
* notches at the out-of-phase modes 4.1 kHz and 7 kHz (pole damping 0.2) and a wide notch
  at the 12.3 kHz mode, which aliases near Nyquist (zero damping 0.05, pole damping 0.5);
* every continuous section sampled by Tustin prewarped at its own frequency, at
  ``Ts = 37.879 us``; ``K`` sets ``|C P_d| = 1`` at 1 kHz on the nominal plant discretised
  exactly (delay included).

Measured on the 18 plants of Table 2.3 (see ``tests/test_pes.py``): all closed loops
stable, worst gain margin 4.7 dB and phase margin 27 deg.
"""

from __future__ import annotations

import control
import numpy as np

from servokit.errors import check_positive
from servokit.models.catalogue import HDD_BENCHMARK_TS, hdd_benchmark

__all__ = ["BENCHMARK_NOTCHES", "benchmark_controller"]

#: (mode frequency [Hz], zero damping, pole damping) of the baseline's notch filters.
BENCHMARK_NOTCHES: tuple[tuple[float, float, float], ...] = (
    (4100.0, 0.03, 0.2),
    (7000.0, 0.01, 0.2),
    (12300.0, 0.05, 0.5),
)


def _tustin(
    section: control.TransferFunction, dt: float, freq_hz: float
) -> control.TransferFunction:
    return control.sample_system(
        section, dt, method="tustin", prewarp_frequency=2 * np.pi * freq_hz
    )


def benchmark_controller(
    crossover_hz: float = 1000.0,
    *,
    dt: float = HDD_BENCHMARK_TS,
    notches: tuple[tuple[float, float, float], ...] = BENCHMARK_NOTCHES,
) -> control.TransferFunction:
    """Baseline discrete controller C(z) for the HDD benchmark (module docstring).

    Parameters
    ----------
    crossover_hz : float
        Gain crossover on the nominal plant [Hz].
    dt : float
        Sampling period [s].
    notches : tuple of (freq_hz, zero_damping, pole_damping)
        Notch sections ``(s^2 + 2 z w s + w^2) / (s^2 + 2 zd w s + w^2)``, eq. (5.14) with
        ``fD = fR``.

    Returns
    -------
    TransferFunction
        Discrete ``C(z)`` at ``dt``.
    """
    fc = check_positive("crossover_hz", crossover_hz, "Hz")
    h = check_positive("dt", dt, "s")
    wc = 2 * np.pi * fc
    pid = control.tf([1.0, wc / 8], [1.0, 0.0]) * control.tf(
        [1 / (wc / 3), 1.0], [1 / (3 * wc), 1.0]
    )
    c = _tustin(pid, h, fc)
    for f, z, zd in notches:
        w = 2 * np.pi * f
        c = c * _tustin(control.tf([1.0, 2 * z * w, w * w], [1.0, 2 * zd * w, w * w]), h, f)
    z_c = np.exp(1j * wc * h)
    gain = 1.0 / abs(complex(c(z_c)) * complex(hdd_benchmark().discretize(h)(z_c)))
    return c * gain
