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

import numpy as np

from servokit._lazy import control
from servokit.errors import check_positive
from servokit.models.catalogue import HDD_BENCHMARK_TS, hdd_benchmark

__all__ = ["BENCHMARK_NOTCHES", "benchmark_controller", "ieej_example_controller"]

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


#: PID of the HDD benchmark's own track-following example (``followdemo.m``):
#: P 2, I 0.05, D 70 as ``2 (1 - z^-1) + 0.05 + 70 (1 - z^-1)^2`` over ``1 - z^-1``.
IEEJ_PID_NUM = (72.0, -141.95, 70.0)


def ieej_example_controller(
    *,
    dt: float = HDD_BENCHMARK_TS,
    gain: float = 1.665e3 / 0.9512,
    notch_pole_damping: float = 0.5,
    lowpass_hz: float = 8000.0,
    lowpass_damping: float = 0.5,
) -> list[control.TransferFunction]:
    """The IEEJ benchmark's PID example with notches at 4.1/5/7 kHz and a low-pass (factors).

    ``C(z) = (72 - 141.95 z^-1 + 70 z^-2) / (1 - z^-1) / gain`` (the benchmark's
    ``followdemo.m`` PID; its ``g_adjust = 1.665e3`` was set for the v1 force constant
    0.9512 N/A, so the default divides it by 0.9512 for v2's 1 N/A), notches (5.14) at the
    4.1, 5 and 7 kHz modes (zero damping = the mode's, pole damping assumed 0.5) and a
    second-order low-pass at 8 kHz (damping assumed 0.5), each filter by prewarped Tustin.
    With the exact ZOH benchmark plant (10 us delay) the loop has 25 states. The notch
    and low-pass parameters are assumptions (the benchmark's v2 example does not give
    them): the loop gives PM 33.4 deg at 973 Hz, GM 4.30 dB at 1634 Hz and a delay margin
    of 95.5 us (tests/test_margins_cases.py), near the 35.17 deg / 4.11 dB at 1626 Hz /
    97.68 us of issue 20's loop, whose filter data were not given.

    Parameters
    ----------
    dt : float
        Sampling period [s].
    gain : float
        Divisor of the PID.
    notch_pole_damping : float
        Damping of the notch poles.
    lowpass_hz, lowpass_damping : float
        Low-pass corner [Hz] and damping.

    Returns
    -------
    list of TransferFunction
        ``[PID, notch 4.1 kHz, notch 5 kHz, notch 7 kHz, low-pass]``, discrete at ``dt``.
    """
    h = check_positive("dt", dt, "s")
    pid = control.tf(list(IEEJ_PID_NUM), [1.0, -1.0, 0.0], h) * (1.0 / gain)
    out = [pid]
    for f, zeta in ((4100.0, 0.03), (5000.0, 0.01), (7000.0, 0.01)):
        w = 2 * np.pi * f  # notch (5.14) with fD = fR (models sit below feedback)
        section = control.tf([1.0, 2 * zeta * w, w * w], [1.0, 2 * notch_pole_damping * w, w * w])
        out.append(_tustin(section, h, f))
    w = 2 * np.pi * lowpass_hz
    low = control.tf([w * w], [1.0, 2 * lowpass_damping * w, w * w])
    out.append(_tustin(low, h, lowpass_hz))
    return out
