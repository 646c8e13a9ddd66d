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

The IEEJ benchmark's own example loop (its ``followdemo.m`` PID, notches at 4.1/5/7 kHz
and an 8 kHz low-pass) is :func:`ieej_example_controller`, and issue 20's version of it,
on the benchmark file's plant, :func:`ieej_benchmark_loop` (sources, assumed and fitted
parameters in their docstrings and in docs/guide/margins.md).
"""

from __future__ import annotations

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_positive
from servokit.models.catalogue import HDD_BENCHMARK_TS, hdd_benchmark, ieej_benchmark_plant
from servokit.models.modal import ModalPlant
from servokit.models.rational import RationalTF

__all__ = [
    "BENCHMARK_NOTCHES",
    "IEEJ_FITTED_CROSSOVER_HZ",
    "IEEJ_FITTED_LOWPASS_DAMPING",
    "IEEJ_G_ADJUST",
    "IEEJ_NOTCHES",
    "IEEJ_PID_NUM",
    "benchmark_controller",
    "benchmark_controller_data",
    "ieej_benchmark_loop",
    "ieej_example_controller",
]

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
        Discrete ``C(z)`` at ``dt`` (:func:`benchmark_controller_data`, the same
        coefficients).
    """
    c = benchmark_controller_data(crossover_hz, dt=dt, notches=notches, zoh="expm")
    return c.to_control()


def benchmark_controller_data(
    crossover_hz: float = 1000.0,
    *,
    dt: float = HDD_BENCHMARK_TS,
    notches: tuple[tuple[float, float, float], ...] = BENCHMARK_NOTCHES,
    zoh: str = "modal",
) -> RationalTF:
    """:func:`benchmark_controller` as numpy coefficients, python-control left unloaded.

    The prewarped Tustin map of :meth:`RationalTF.tustin` is python-control's
    ``sample_system(..., "tustin", prewarp_frequency)`` arithmetic, and the products are
    the same polynomial products, so with ``zoh="expm"`` the coefficients are
    :func:`benchmark_controller`'s bit for bit (tests/test_numpy_loops.py).

    Parameters
    ----------
    crossover_hz, dt, notches : float, float, tuple
        As :func:`benchmark_controller` (crossover [Hz], sampling period [s], notches).
    zoh : {"modal", "expm"}
        The plant's exact ZOH at the crossover (:meth:`ModalPlant.discretize_data`):
        closed form per mode (numpy only; the gain agrees to ~1e-15) or
        ``scipy.linalg.expm`` (what :func:`benchmark_controller` uses).

    Returns
    -------
    RationalTF
        Discrete ``C(z)`` at ``dt``.
    """
    fc = check_positive("crossover_hz", crossover_hz, "Hz")
    h = check_positive("dt", dt, "s")
    wc = 2 * np.pi * fc
    pid = RationalTF([1.0, wc / 8], [1.0, 0.0]) * RationalTF(
        [1 / (wc / 3), 1.0], [1 / (3 * wc), 1.0]
    )
    c = pid.tustin(h, 2 * np.pi * fc)
    for f, z, zd in notches:
        w = 2 * np.pi * f
        notch = RationalTF([1.0, 2 * z * w, w * w], [1.0, 2 * zd * w, w * w])
        c = c * notch.tustin(h, 2 * np.pi * f)
    z_c = np.exp(1j * wc * h)
    plant = hdd_benchmark().discretize_data(h, method=zoh)
    gain = 1.0 / abs(complex(c(z_c)) * complex(plant(z_c)[0, 0]))
    return c * gain


#: PID of the HDD benchmark's own track-following example (``followdemo.m``):
#: P 2, I 0.05, D 70 as ``2 (1 - z^-1) + 0.05 + 70 (1 - z^-1)^2`` over ``1 - z^-1``.
IEEJ_PID_NUM = (72.0, -141.95, 70.0)
#: ``g_adjust`` of ``followdemo.m`` (set for the v1 plant, force constant 0.9512 N/A).
IEEJ_G_ADJUST = 1.665e3
#: (frequency [Hz], zero damping = the mode's, Table 2.2) of the three notches.
IEEJ_NOTCHES: tuple[tuple[float, float], ...] = ((4100.0, 0.03), (5000.0, 0.01), (7000.0, 0.01))


def _section(
    num: list[float], den: list[float], h: float, f: float, method: str
) -> control.TransferFunction:
    """One continuous section sampled at ``h``: prewarped Tustin, or matched pole-zero
    with unit DC gain (how ``followdemo.m``'s notches are built)."""
    if method == "tustin":
        return _tustin(control.tf(num, den), h, f)
    d = control.sample_system(control.tf(num, den), h, method="matched")
    # matched maps the finite zeros only: a low-pass gets its missing zeros at z = -1
    # (the Nyquist point), as the matched design places them
    num, den = np.asarray(d.num[0][0], dtype=float), np.asarray(d.den[0][0], dtype=float)
    if den.size > num.size:
        d = control.tf(np.convolve(num, np.poly(-np.ones(den.size - num.size))), den, h)
    return d * (1.0 / float(np.real(d(1.0))))


def ieej_example_controller(
    *,
    dt: float = HDD_BENCHMARK_TS,
    gain: float = IEEJ_G_ADJUST / 0.9512,
    notch_pole_damping: float | tuple[float, float, float] = 0.5,
    lowpass_hz: float = 8000.0,
    lowpass_damping: float = 0.5,
    crossover_hz: float | None = None,
    method: str = "tustin",
    plant: ModalPlant | None = None,
) -> list[control.TransferFunction]:
    """The IEEJ benchmark's PID example with notches at 4.1/5/7 kHz and a low-pass (factors).

    Sources (public): the HDD Benchmark Problem's ``example1/followdemo.m`` (Ver.3.1,
    HDD benchmark working group; mirrored at github.com/macs-lab/NSS-HDD-Benchmark)
    gives the PID ``(72 - 141.95 z^-1 + 70 z^-2) / (1 - z^-1)``, the divisor
    ``g_adjust = 1.665e3`` and the zero-cross target ``Freq_zc = 1000`` Hz. Its notches
    belong to the v1 plant (4.1/5/8.2/12.3 kHz, state space at ``Ts/2``); read back,
    they are matched pole-zero sections with unit DC gain, zero/pole dampings
    0.065/0.206 (4.1 kHz, -10 dB deep), 0.0136/0.136, 0.036/0.362 and 0.030/0.303
    (-20 dB). The file has no low-pass and no 7 kHz notch: the v2 loop's filter data are
    not public, so here the notch zeros take the mode's damping (Table 2.2, eq. 5.14 with
    ``fD = fR``), and the notch pole damping, the second-order low-pass at 8 kHz and its
    damping are parameters, ASSUMED 0.5 by default.

    The default gain is ``g_adjust / 0.9512`` (v1's loop gain for v2's 1 N/A); with
    ``crossover_hz`` the gain instead puts ``|L| = 1`` there on ``plant`` discretised
    exactly (10 us delay included). With the defaults, on the book's plant
    (:func:`hdd_benchmark`, rigid body), the loop (25 states) gives PM 33.45 deg at
    972.6 Hz, GM 4.307 dB at 1634 Hz and a delay margin of 95.54 us
    (tests/test_margins_cases.py). Issue 20's loop (PM 35.17 deg, GM 4.11 dB at 1626 Hz,
    delay margin 97.68 us) is :func:`ieej_benchmark_loop`: the same controller with a
    fitted low-pass damping and crossover on the benchmark file's plant (first mode
    90 Hz); on the book's plant no choice of dampings reproduces it
    (``examples/ieej_benchmark_loop.py`` shows the fits and what stays unexplained).

    Parameters
    ----------
    dt : float
        Sampling period [s].
    gain : float
        Divisor of the PID (ignored when ``crossover_hz`` is given).
    notch_pole_damping : float or tuple of 3 floats
        Damping of the notch poles (one for all, or per notch 4.1/5/7 kHz).
    lowpass_hz, lowpass_damping : float
        Low-pass corner [Hz] and damping.
    crossover_hz : float, optional
        Gain crossover [Hz] on ``plant`` (``followdemo.m``'s ``Freq_zc``).
    method : {"tustin", "matched"}
        Discretisation of the filters: Tustin prewarped at each filter's frequency, or
        matched pole-zero with unit DC gain (``followdemo.m``'s notches).
    plant : ModalPlant, optional
        Plant of the crossover normalisation (default :func:`hdd_benchmark`).

    Returns
    -------
    list of TransferFunction
        ``[PID, notch 4.1 kHz, notch 5 kHz, notch 7 kHz, low-pass]``, discrete at ``dt``.
    """
    h = check_positive("dt", dt, "s")
    if method not in ("tustin", "matched"):
        raise ServokitValueError(f"method must be 'tustin' or 'matched' (got {method!r})")
    zp = np.broadcast_to(np.asarray(notch_pole_damping, dtype=float), (3,))
    for name, value in (("notch_pole_damping", z) for z in zp):
        check_positive(name, float(value))
    check_positive("lowpass_damping", lowpass_damping)
    out = [control.tf(list(IEEJ_PID_NUM), [1.0, -1.0, 0.0], h)]
    for (f, zeta), zd in zip(IEEJ_NOTCHES, zp, strict=True):
        w = 2 * np.pi * f  # notch (5.14) with fD = fR (models sit below feedback)
        out.append(_section([1.0, 2 * zeta * w, w * w], [1.0, 2 * zd * w, w * w], h, f, method))
    w = 2 * np.pi * check_positive("lowpass_hz", lowpass_hz, "Hz")
    out.append(_section([w * w], [1.0, 2 * lowpass_damping * w, w * w], h, lowpass_hz, method))
    if crossover_hz is not None:
        z = np.exp(2j * np.pi * check_positive("crossover_hz", crossover_hz, "Hz") * h)
        p = (hdd_benchmark() if plant is None else plant).discretize(h)
        loop = complex(p(z)) * np.prod([complex(c(z)) for c in out])
        gain = abs(loop)
    out[0] = out[0] * (1.0 / check_positive("gain", gain))
    return out


#: Low-pass damping and crossover [Hz] of issue 20's loop: FITTED (zeta_lp, fc) to its
#: PM 35.17 deg and delay margin 97.68 us on :func:`ieej_benchmark_plant` with the notch
#: pole damping 0.5, rounded; :func:`servokit.feedback.fit_ieej_loop` is the fit and
#: ``tests/test_margins_cases.py`` checks these values against it (its GM 4.11 dB and
#: phase crossover 1626 Hz then follow, within the quoted digits).
IEEJ_FITTED_LOWPASS_DAMPING = 0.6923
IEEJ_FITTED_CROSSOVER_HZ = 1000.15


def ieej_benchmark_loop(dt: float = HDD_BENCHMARK_TS) -> list[control.LTI]:
    """Issue 20's IEEJ benchmark tracking loop, as factors ``[P_d, C...]`` (25 states).

    The plant is :func:`ieej_benchmark_plant` (the benchmark's parameter file: first mode
    90 Hz, not the book's rigid body) discretised exactly with its 10 us delay; the
    controller is :func:`ieej_example_controller` with Tustin notches of pole damping 0.5
    (ASSUMED) and the low-pass damping and crossover FITTED to two of the issue's four
    numbers (:data:`IEEJ_FITTED_LOWPASS_DAMPING`, :data:`IEEJ_FITTED_CROSSOVER_HZ`).
    On the book's rigid-body plant no damping reproduces the issue's numbers
    (``examples/ieej_benchmark_loop.py``).

    Parameters
    ----------
    dt : float
        Sampling period [s].

    Returns
    -------
    list of python-control systems
        ``[P_d (StateSpace), PID, notch 4.1 kHz, notch 5 kHz, notch 7 kHz, low-pass]``.
    """
    plant = ieej_benchmark_plant()
    ctrl = ieej_example_controller(
        dt=dt,
        lowpass_damping=IEEJ_FITTED_LOWPASS_DAMPING,
        crossover_hz=IEEJ_FITTED_CROSSOVER_HZ,
        plant=plant,
    )
    return [plant.discretize(dt), *ctrl]
