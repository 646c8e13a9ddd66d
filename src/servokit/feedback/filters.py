"""Resonance-compensation filters of book chapter 5 as python-control transfer functions.

All filters are continuous; :func:`discretize_filter` samples one by the bilinear
(Tustin) transform prewarped at the filter frequency, so that the notch/peak lands on
the same frequency in the discrete filter.

Book corrections
----------------
* (5.14) notch: the text says the notch damping is chosen in "√2 < ζD ≤ 1", an empty
  range (√2 > 1); the PDF lost a "/2": the intended range is √2/2 ≤ ζD ≤ 1 (no
  peaking of the filter's own poles), which :func:`notch` documents but does not enforce.
* (5.17) peak filter: the book restricts φ to [−π/2, π/2] in (5.18) but itself uses
  φ = 2.5414 rad and 4.2603 rad in §5.5.2; F is 2π-periodic in φ, so any real φ is
  accepted.
* (5.51) LTV transient-stage zero: printed φ = arg Sh(jω1) + π. The residue of
  Sh F at the filter pole p1 ≈ jω1 is ≈ K ω1 |Sh| e^{j(arg Sh + π/2 − φ)} / 2, so the
  departure angle is 180° + arg Sh + 90° − φ: (5.18) gives 180° (as printed), "+ π"
  gives 90°, not the 0° of (5.53) (nor the −180° plant departure of (5.52)). The
  printed departures need the residue of (5.18) reversed, φ = arg Sh(jω1) − π/2, which
  :func:`peak_filter_phase` uses for ``method="transient"``.
* (5.38) phase-shift zero φ = arg Sh(jω1): the same residue gives a filter departure of
  −90° for the upper-half-plane pole; the book's "+90°" (5.41) is the lower pole's.
* (5.92)-(5.94) complex lag: checked by hand; ωp ωz = ωm² and the phase of the lag at
  ωm is exactly −2φm (zero angle π/2 − φm, pole angle π/2 + φm), as printed.
"""

from __future__ import annotations

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_finite, check_positive
from servokit.models.rational import RationalTF

__all__ = [
    "notch",
    "notch_coefficients",
    "inverse_pair",
    "inverse_pair_coefficients",
    "complex_lag",
    "complex_lag_coefficients",
    "lead_lag",
    "lead_lag_coefficients",
    "lag",
    "lag_coefficients",
    "pi_controller",
    "peak_filter",
    "peak_filter_coefficients",
    "peak_filter_phase",
    "design_peak_filter",
    "ZERO_PLACEMENTS",
    "pseudo_plant",
    "discretize_filter",
    "discretize_filter_data",
    "tustin_coefficients",
]

TWO_PI = 2.0 * np.pi


def _damping(name: str, value: float, *, upper: float | None = None) -> float:
    v = float(check_finite(name, value))
    if v < 0 or (upper is not None and v > upper):
        rng = f"[0, {upper:g}]" if upper is not None else ">= 0"
        raise ServokitValueError(f"{name} must be in {rng} (got {v})")
    return v


def _second_order(freq_hz: float, damping: float) -> np.ndarray:
    """Coefficients of ``s^2 + 2 ζ ω s + ω^2`` with ω = 2π f."""
    w = TWO_PI * freq_hz
    return np.array([1.0, 2.0 * damping * w, w * w])


def notch(
    freq_hz: float,
    damping: float,
    *,
    filter_freq_hz: float | None = None,
    filter_damping: float = 0.5,
) -> control.TransferFunction:
    """Notch filter N(s) cancelling the resonant mode R(s) of (5.13), eq. (5.14).

    ``N(s) = (ωD/ωR)^2 (s^2 + 2ζR ωR s + ωR^2) / (s^2 + 2ζD ωD s + ωD^2)``, unit DC gain.

    Parameters
    ----------
    freq_hz, damping : float
        Natural frequency fR [Hz] and damping ζR (0 < ζR < 1) of the mode to cancel.
    filter_freq_hz : float, optional
        Frequency fD of the filter poles [Hz]; ``fR`` by default. ``fD > fR`` gives the
        book's high-pass notch, with less phase loss below fR.
    filter_damping : float
        ζD of the filter poles; the book's range is √2/2 ≤ ζD ≤ 1 (printed garbled as
        "√2 < ζD ≤ 1").

    Returns
    -------
    control.TransferFunction
        The continuous notch filter.
    """
    num, den = notch_coefficients(
        freq_hz, damping, filter_freq_hz=filter_freq_hz, filter_damping=filter_damping
    )
    return control.tf(num, den)


def notch_coefficients(
    freq_hz: float,
    damping: float,
    *,
    filter_freq_hz: float | None = None,
    filter_damping: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of the notch N(s) of eq. (5.14), without python-control.

    Parameters
    ----------
    freq_hz, damping : float
        Natural frequency fR [Hz] and damping ζR (0 < ζR < 1) of the mode to cancel.
    filter_freq_hz : float, optional
        Frequency fD of the filter poles [Hz]; ``fR`` by default.
    filter_damping : float
        ζD of the filter poles (> 0).

    Returns
    -------
    num, den : numpy.ndarray
        Coefficients in descending powers of s, as :func:`notch` wraps them.
    """
    f_r = check_positive("freq_hz", freq_hz, "Hz")
    z_r = _damping("damping", damping, upper=1.0)
    f_d = f_r if filter_freq_hz is None else check_positive("filter_freq_hz", filter_freq_hz, "Hz")
    z_d = _damping("filter_damping", filter_damping)
    if z_d == 0:
        raise ServokitValueError("filter_damping must be > 0 (undamped filter poles)")
    return (f_d / f_r) ** 2 * _second_order(f_r, z_r), _second_order(f_d, z_d)


def inverse_pair(
    zero_hz: float,
    pole_hz: float,
    *,
    zero_damping: float = 0.05,
    pole_damping: float = 0.05,
) -> control.TransferFunction:
    """Inverse-compensation zero/pole pair of §5.3.2, unit DC gain.

    ``(ωp/ωz)^2 (s^2 + 2ζz ωz s + ωz^2) / (s^2 + 2ζp ωp s + ωp^2)``: its zeros cancel a
    plant resonance at ``zero_hz`` and its poles restore an anti-resonance at ``pole_hz``
    (e.g. the (4449, 4775) Hz pair of §5.5.2.1, which the book lists as "zero-pole
    pairs" without damping: the dampings are parameters).

    Parameters
    ----------
    zero_hz, pole_hz : float
        Natural frequencies of the zeros and of the poles [Hz].
    zero_damping, pole_damping : float
        Their damping ratios (pole damping > 0).

    Returns
    -------
    control.TransferFunction
        The continuous second-order filter.
    """
    return control.tf(
        *inverse_pair_coefficients(
            zero_hz, pole_hz, zero_damping=zero_damping, pole_damping=pole_damping
        )
    )


def inverse_pair_coefficients(
    zero_hz: float,
    pole_hz: float,
    *,
    zero_damping: float = 0.05,
    pole_damping: float = 0.05,
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of :func:`inverse_pair`, without python-control.

    Parameters
    ----------
    zero_hz, pole_hz : float
        Natural frequencies of the zeros and of the poles [Hz].
    zero_damping, pole_damping : float
        Their damping ratios (pole damping > 0).

    Returns
    -------
    num, den : numpy.ndarray
        Coefficients in descending powers of s.
    """
    f_z = check_positive("zero_hz", zero_hz, "Hz")
    f_p = check_positive("pole_hz", pole_hz, "Hz")
    z_z = _damping("zero_damping", zero_damping, upper=1.0)
    z_p = _damping("pole_damping", pole_damping)
    if z_p == 0:
        raise ServokitValueError("pole_damping must be > 0 (undamped filter poles)")
    return (f_p / f_z) ** 2 * _second_order(f_z, z_z), _second_order(f_p, z_p)


def complex_lag(freq_hz: float, damping: float, phase_rad: float) -> control.TransferFunction:
    """Complex lag compensator Clag(s) of eqs. (5.92)-(5.94).

    ``Clag = (ωp/ωz) (s^2 + 2ζ ωz s + ωz^2) / (s^2 + 2ζ ωp s + ωp^2)`` with
    ``ωp,z = ωm (∓ζ tan φm + sqrt(ζ^2 tan^2 φm + 1))``; its phase at ωm is −2φm.

    Parameters
    ----------
    freq_hz : float
        Centre frequency fm = ωm / 2π [Hz].
    damping : float
        ζlg (> 0).
    phase_rad : float
        φm [rad], in (−π/2, π/2) (tan φm must be finite).

    Returns
    -------
    control.TransferFunction
        The continuous complex lag.
    """
    return control.tf(*complex_lag_coefficients(freq_hz, damping, phase_rad))


def complex_lag_coefficients(
    freq_hz: float, damping: float, phase_rad: float
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of :func:`complex_lag` (5.92)-(5.94), without python-control.

    Parameters
    ----------
    freq_hz : float
        Centre frequency fm [Hz].
    damping : float
        ζlg (> 0).
    phase_rad : float
        φm [rad], in (−π/2, π/2).

    Returns
    -------
    num, den : numpy.ndarray
        Coefficients in descending powers of s.
    """
    f_m = check_positive("freq_hz", freq_hz, "Hz")
    zeta = check_positive("damping", damping)
    phi = float(check_finite("phase_rad", phase_rad))
    if abs(phi) >= np.pi / 2:
        raise ServokitValueError(f"phase_rad must be in (-pi/2, pi/2) (got {phi})")
    a = zeta * np.tan(phi)
    root = np.sqrt(a * a + 1.0)
    w_m = TWO_PI * f_m
    w_p, w_z = w_m * (root - a), w_m * (root + a)
    num = (w_p / w_z) * np.array([1.0, 2.0 * zeta * w_z, w_z * w_z])
    return num, np.array([1.0, 2.0 * zeta * w_p, w_p * w_p])


def lead_lag(
    gain: float, zero_hz: float = 50.0, pole_hz: float = 30000.0
) -> control.TransferFunction:
    """Lead-lag VCM controller CCV(s) = K (s + ωz)^2 / (s (s + ωp)), eq. (5.91).

    Parameters
    ----------
    gain : float
        KCV (> 0).
    zero_hz, pole_hz : float
        Double zero and pole frequencies [Hz]; the book's are 50 Hz (ωz = 100π rad/s) and
        30 kHz.

    Returns
    -------
    control.TransferFunction
        The continuous controller.
    """
    return control.tf(*lead_lag_coefficients(gain, zero_hz, pole_hz))


def lead_lag_coefficients(
    gain: float, zero_hz: float = 50.0, pole_hz: float = 30000.0
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of :func:`lead_lag` (5.91), without python-control.

    Parameters
    ----------
    gain, zero_hz, pole_hz : float
        KCV (> 0), double zero and pole frequencies [Hz], as :func:`lead_lag`.

    Returns
    -------
    num, den : numpy.ndarray
        ``K [1, 2 wz, wz^2]`` and ``[1, wp, 0]``, descending powers of s.
    """
    k, w_z, w_p = _gain_corners(gain, zero_hz, pole_hz)
    return k * np.array([1.0, 2.0 * w_z, w_z * w_z]), np.array([1.0, w_p, 0.0])


def _gain_corners(gain: float, zero_hz: float, pole_hz: float) -> tuple[float, float, float]:
    """``K`` (> 0) and the zero and pole corners [rad/s] of a lead-lag or lag."""
    k = check_positive("gain", gain)
    w_z = TWO_PI * check_positive("zero_hz", zero_hz, "Hz")
    w_p = TWO_PI * check_positive("pole_hz", pole_hz, "Hz")
    return k, w_z, w_p


def lag(gain: float, zero_hz: float = 30000.0, pole_hz: float = 900.0) -> control.TransferFunction:
    """First-order lag CCM(s) = K (s + ωz) / (s + ωp) of zero relative degree, eq. (5.96).

    Parameters
    ----------
    gain : float
        KCM (> 0).
    zero_hz, pole_hz : float
        Zero and pole frequencies [Hz]; the book's are 30 kHz and 900 Hz.

    Returns
    -------
    control.TransferFunction
        The continuous lag.
    """
    return control.tf(*lag_coefficients(gain, zero_hz, pole_hz))


def lag_coefficients(
    gain: float, zero_hz: float = 30000.0, pole_hz: float = 900.0
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of :func:`lag` (5.96), without python-control.

    Parameters
    ----------
    gain, zero_hz, pole_hz : float
        KCM (> 0), zero and pole frequencies [Hz], as :func:`lag`.

    Returns
    -------
    num, den : numpy.ndarray
        ``[K, K wz]`` and ``[1, wp]``, descending powers of s.
    """
    k, w_z, w_p = _gain_corners(gain, zero_hz, pole_hz)
    return np.array([k, k * w_z]), np.array([1.0, w_p])


def pi_controller(gain: float, corner_hz: float) -> control.TransferFunction:
    """PI compensator K (s + ωi) / s with integral corner ωi = 2π·corner_hz.

    Parameters
    ----------
    gain : float
        Proportional gain K (> 0).
    corner_hz : float
        Integral corner frequency [Hz].

    Returns
    -------
    control.TransferFunction
        The continuous PI controller.
    """
    k = check_positive("gain", gain)
    w_i = TWO_PI * check_positive("corner_hz", corner_hz, "Hz")
    return control.tf([k, k * w_i], [1.0, 0.0])


def peak_filter(
    freq_hz: float, damping: float, gain: float, phi: float
) -> control.TransferFunction:
    """Peak filter F(s) = K s (s cos φ + ω1 sin φ) / (s^2 + 2ζ1 ω1 s + ω1^2), eq. (5.17).

    Parameters
    ----------
    freq_hz : float
        Centre frequency f1 = ω1 / 2π [Hz].
    damping : float
        ζ1 (> 0): sets the attenuation bandwidth.
    gain : float
        K (> 0).
    phi : float
        Zero-placement phase φ [rad]; any real value (F is 2π-periodic in φ). Choose it with
        :func:`peak_filter_phase`.

    Returns
    -------
    control.TransferFunction
        The continuous peak filter; at ω1 it equals ``K/(2ζ1) j e^{−jφ}``.
    """
    return control.tf(*peak_filter_coefficients(freq_hz, damping, gain, phi))


def peak_filter_coefficients(
    freq_hz: float, damping: float, gain: float, phi: float
) -> tuple[np.ndarray, np.ndarray]:
    """Numerator and denominator of :func:`peak_filter` (5.17), without python-control.

    Parameters
    ----------
    freq_hz : float
        Centre frequency f1 [Hz].
    damping : float
        ζ1 (> 0).
    gain : float
        K (> 0).
    phi : float
        Zero-placement phase φ [rad].

    Returns
    -------
    num, den : numpy.ndarray
        Coefficients in descending powers of s.
    """
    w1 = TWO_PI * check_positive("freq_hz", freq_hz, "Hz")
    zeta = check_positive("damping", damping)
    k = check_positive("gain", gain)
    p = float(check_finite("phi", phi))
    num = k * np.array([np.cos(p), w1 * np.sin(p), 0.0])
    return num, np.array([1.0, 2.0 * zeta * w1, w1 * w1])


def pseudo_plant(loop: control.LTI) -> control.LTI:
    """Pseudo plant Sh = PC / (1 + PC) seen by an add-on filter, eq. (5.16).

    Parameters
    ----------
    loop : control.LTI
        The baseline open loop P C.

    Returns
    -------
    control.LTI
        The baseline complementary sensitivity Sh.
    """
    return control.feedback(loop, 1)


#: Zero placements of the peak filter: offset added to arg Sh(jω1) [rad].
ZERO_PLACEMENTS = {
    "stable": np.pi / 2,  # (5.18) and the frequency-shift method (5.42)
    "frequency-shift": np.pi / 2,  # (5.42): (5.18) at the pseudo plant's resonance
    "phase-shift": 0.0,  # (5.38)
    "transient": -np.pi / 2,  # (5.51) corrected (printed "+ π"), the LTV transient stage
}


def peak_filter_phase(sh_at_w1: complex, method: str = "stable") -> float:
    """Zero-placement phase φ of the peak filter from Sh(jω1), wrapped into (−π, π].

    ``"stable"`` / ``"frequency-shift"``: φ = arg Sh(jω1) + π/2, eqs. (5.18), (5.42)
    (filter poles depart at 180°; for the frequency-shift method ω1 is the pseudo
    plant's resonance); ``"phase-shift"``: φ = arg Sh(jω1), eq. (5.38), filter poles
    depart at ∓90°; ``"transient"``: φ = arg Sh(jω1) − π/2, eq. (5.51) corrected (see the
    module docstring), filter poles depart at 0° and plant poles at −180°. The book states
    φ ∈ [−π/2, π/2]; the formulas give any angle and F is 2π-periodic in φ, so the full
    circle is kept.

    Parameters
    ----------
    sh_at_w1 : complex
        Sh(jω1), the pseudo plant at the filter frequency.
    method : str
        One of :data:`ZERO_PLACEMENTS`.

    Returns
    -------
    float
        φ [rad].
    """
    if method not in ZERO_PLACEMENTS:
        raise ServokitValueError(
            f"method must be one of {', '.join(ZERO_PLACEMENTS)} (got {method!r})"
        )
    return float(np.angle(complex(sh_at_w1) * np.exp(1j * ZERO_PLACEMENTS[method])))


def design_peak_filter(
    sh: control.LTI, freq_hz: float, damping: float, gain: float, method: str = "stable"
) -> tuple[control.TransferFunction, float]:
    """Peak filter (5.17) at ``freq_hz`` with its zero placed on the pseudo plant ``sh``.

    Parameters
    ----------
    sh : control.LTI
        Continuous pseudo plant Sh = PC/(1+PC) (see :func:`pseudo_plant`).
    freq_hz, damping, gain : float
        f1 [Hz], ζ1 and K of (5.17).
    method : str
        Zero placement, see :func:`peak_filter_phase`.

    Returns
    -------
    tuple of (control.TransferFunction, float)
        The filter F and its φ [rad].
    """
    f1 = check_positive("freq_hz", freq_hz, "Hz")
    phi = peak_filter_phase(complex(sh(2j * np.pi * f1)), method)
    return peak_filter(f1, damping, gain, phi), phi


def discretize_filter(filt: control.LTI, dt: float, freq_hz: float) -> control.LTI:
    """Sample a continuous filter by the Tustin transform prewarped at ``freq_hz``.

    Parameters
    ----------
    filt : control.LTI
        Continuous filter.
    dt : float
        Sampling period [s].
    freq_hz : float
        Prewarping frequency [Hz], below the Nyquist frequency: the discrete filter equals
        the continuous one there.

    Returns
    -------
    control.LTI
        The discrete filter with ``dt``.
    """
    h, f = _tustin_rate(dt, freq_hz)
    fd = control.sample_system(filt, h, method="tustin", prewarp_frequency=TWO_PI * f)
    _check_not_degenerate(fd.num[0][0], fd.den[0][0], h, f, complex(filt(1j * TWO_PI * f)))
    return fd


def discretize_filter_data(filt: RationalTF, dt: float, freq_hz: float) -> RationalTF:
    """:func:`discretize_filter` of numpy coefficients, python-control left unloaded.

    :meth:`RationalTF.tustin <servokit.models.rational.RationalTF.tustin>` is
    python-control's prewarped Tustin arithmetic: the coefficients are
    :func:`discretize_filter`'s bit for bit.

    Parameters
    ----------
    filt : RationalTF
        Continuous filter.
    dt : float
        Sampling period [s].
    freq_hz : float
        Prewarping frequency [Hz], below the Nyquist frequency.

    Returns
    -------
    RationalTF
        The discrete filter with ``dt``.
    """
    h, f = _tustin_rate(dt, freq_hz)
    fd = filt.tustin(h, TWO_PI * f)
    _check_not_degenerate(fd.numerator, fd.denominator, h, f, complex(filt(1j * TWO_PI * f)))
    return fd


def _tustin_rate(dt: float, freq_hz: float) -> tuple[float, float]:
    h = check_positive("dt", dt, "s")
    f = check_positive("freq_hz", freq_hz, "Hz")
    if f >= 0.5 / h:
        raise ServokitValueError(
            f"freq_hz must be below the Nyquist frequency {0.5 / h:g} Hz (got {f:g})"
        )
    return h, f


def tustin_coefficients(
    num: np.ndarray, den: np.ndarray, dt: float, freq_hz: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`discretize_filter` of a transfer function given by coefficients, in numpy.

    Substitutes ``s = c (z - 1)/(z + 1)`` with ``c = ω / tan(ω dt / 2)``, ω = 2π
    ``freq_hz`` (the prewarped Tustin map), and clears the ``(z + 1)`` powers; the cheap
    path of ``servokit filter`` (no python-control import). Low orders only: the
    expansion in powers of z is ill-conditioned beyond a few poles.

    Parameters
    ----------
    num, den : numpy.ndarray
        Continuous coefficients in descending powers of s (proper: ``len(num) <= len(den)``).
    dt : float
        Sampling period [s].
    freq_hz : float
        Prewarping frequency [Hz], below the Nyquist frequency.

    Returns
    -------
    num_z, den_z : numpy.ndarray
        Discrete coefficients in descending powers of z, ``den_z[0] = 1``.
    """
    h, f = _tustin_rate(dt, freq_hz)
    num, den = np.atleast_1d(np.asarray(num, float)), np.atleast_1d(np.asarray(den, float))
    n = den.size - 1
    if num.size > den.size or den[0] == 0:
        raise ServokitValueError("tustin_coefficients needs a proper filter (len(num) <= len(den))")
    c = TWO_PI * f / np.tan(np.pi * f * h)

    def mapped(coeffs: np.ndarray) -> np.ndarray:
        out = np.zeros(n + 1)
        for i, a in enumerate(coeffs[::-1]):  # a s^i -> a c^i (z-1)^i (z+1)^(n-i)
            term = np.polymul(np.poly(np.ones(i)), np.poly(-np.ones(n - i)))
            out += a * c**i * term
        return out

    num_z, den_z = mapped(num), mapped(den)
    num_z, den_z = num_z / den_z[0], den_z / den_z[0]
    asked = complex(np.polyval(num, 1j * TWO_PI * f) / np.polyval(den, 1j * TWO_PI * f))
    _check_not_degenerate(num_z, den_z, h, f, asked)
    return num_z, den_z


def _check_not_degenerate(
    num: np.ndarray, den: np.ndarray, dt: float, freq_hz: float, asked: complex
) -> None:
    """Refuse a Tustin filter whose coefficients no longer tell it from 1 (or are not finite).

    Far above the filter's frequencies the bilinear map pushes every pole and zero to
    z = 1: the numerator and denominator then agree to double precision (a notch at
    4449 Hz with dt = 1e-300 s gives num = den) and the discrete filter is a wire, not the
    filter asked for.  ``asked`` is the continuous filter at ``freq_hz``, where the
    prewarped map is exact: a filter that is 1 there (a notch whose zeros equal its
    poles, an identity) is rightly 1 after the map and passes.
    """
    num = np.atleast_1d(np.asarray(num, dtype=float))
    den = np.atleast_1d(np.asarray(den, dtype=float))
    if not (np.all(np.isfinite(num)) and np.all(np.isfinite(den))):
        raise ServokitValueError(f"dt {dt:g} s gives a non-finite Tustin filter at {freq_hz:g} Hz")
    wire = num.size == den.size and np.max(np.abs(num - den)) <= 1e3 * np.finfo(float).eps * np.max(
        np.abs(den)
    )
    if wire and not abs(asked - 1.0) <= 1e-9:
        raise ServokitValueError(
            f"dt {dt:g} s is {1 / (dt * freq_hz):.3g} samples per cycle of {freq_hz:g} Hz: the "
            "Tustin filter's numerator equals its denominator to double precision (a "
            "degenerate discretisation); give a longer sampling period"
        )
