"""Stability margins evaluated on the loop frequency response, exact delay included.

python-control's ``stability_margins`` converts the loop to a polynomial ratio and finds
crossings from polynomial roots; on high-order discrete loops this both overflows and
reports spurious crossings (on the 23-state §4.5 loop it gives PM 19.9° at 317 Hz,
where |L| = 2.7). Here the loop is evaluated directly at s = jω (or z = e^{jωT}) on a
dense logarithmic grid; every sign change of log|L| (gain crossover) and of sin(arg L)
with cos(arg L) < 0 (phase crossover) is refined by Brent's method on the exact
response. A delay multiplies the response by e^{-jωτ} exactly (no Padé).

Definitions
-----------
* Phase margin at a gain crossover ωc: ``180° + arg L(jωc)``, wrapped into (−180, 180].
  The headline :attr:`Margins.phase_margin_deg` is the one at the first (lowest) gain
  crossover, the book's convention for phase-stabilised loops, whose resonance peaks
  cross 0 dB again with any phase; every crossover is listed in ``phase_margins_deg``.
* Gain margin at a phase crossover ω180: ``−20 log10 |L(jω180)|`` [dB]. The headline
  :attr:`Margins.gain_margin_db` is the one closest to 0 dB (the nearest gain change
  that reaches instability, upward (> 0 dB) or downward (< 0 dB) for conditionally
  stable loops).
* Delay margin (of a stable closed loop): the smallest τ with L(jωc)e^{-jωcτ} = −1 at
  some crossover, ``min_k (PM_k mod 360°) / ωc,k``; PM / ωc for one crossover.
* Second phase margin (phase-stabilised loops, §5.3.3.1, Table 5.4): the phase margin
  at the second gain crossover (the resonance peak rising through 0 dB), reported in
  [0°, 360°) so that a phase-stabilised peak reads e.g. 223.8°, as the book prints it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import control
import numpy as np
from scipy.optimize import brentq

from servokit.errors import ServokitTypeError, ServokitValueError, check_count, check_finite

__all__ = ["Margins", "stability_margins", "loop_response"]

Response = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Margins:
    """Every crossing of a loop and the margins derived from them (frequencies in Hz)."""

    gain_margin_db: float
    phase_margin_deg: float
    gm_freq_hz: float
    pm_freq_hz: float
    delay_margin_s: float
    gain_crossovers_hz: tuple[float, ...]
    phase_margins_deg: tuple[float, ...]
    phase_crossovers_hz: tuple[float, ...]
    gain_margins_db: tuple[float, ...]
    second_phase_margin_deg: float

    @property
    def gain_crossover_hz(self) -> float:
        """Frequency of the headline phase margin [Hz] (alias of ``pm_freq_hz``)."""
        return self.pm_freq_hz

    @property
    def phase_crossover_hz(self) -> float:
        """Frequency of the headline gain margin [Hz] (alias of ``gm_freq_hz``)."""
        return self.gm_freq_hz

    @property
    def gain_margin(self) -> float:
        """Headline gain margin as a linear factor (not dB)."""
        return float(10.0 ** (self.gain_margin_db / 20.0))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (snake_case keys with unit suffixes; inf stays a float)."""
        return {
            "gain_margin_db": self.gain_margin_db,
            "phase_margin_deg": self.phase_margin_deg,
            "gm_freq_hz": self.gm_freq_hz,
            "pm_freq_hz": self.pm_freq_hz,
            "delay_margin_s": self.delay_margin_s,
            "second_phase_margin_deg": self.second_phase_margin_deg,
            "gain_crossovers_hz": list(self.gain_crossovers_hz),
            "phase_margins_deg": list(self.phase_margins_deg),
            "phase_crossovers_hz": list(self.phase_crossovers_hz),
            "gain_margins_db": list(self.gain_margins_db),
        }


def _timebase(sys: Any) -> float | None:
    dt = getattr(sys, "dt", None)
    if dt is None or dt is False or dt == 0:
        return None
    if dt is True:
        raise ServokitValueError("loop: a discrete loop needs a numeric sampling period dt")
    return float(dt)


def _lti_response(sys: control.LTI) -> tuple[Response, float | None]:
    if not (sys.ninputs == 1 and sys.noutputs == 1):
        raise ServokitValueError("loop must be single-input single-output")
    dt = _timebase(sys)

    def resp(f: np.ndarray) -> np.ndarray:
        w = 2.0 * np.pi * np.asarray(f, dtype=float)
        x = np.exp(1j * w * dt) if dt is not None else 1j * w
        with np.errstate(all="ignore"):  # poles on the grid give inf, handled by callers
            out = sys(x, warn_infinite=False)
        return np.asarray(out, dtype=complex).reshape(np.shape(f))

    return resp, dt


def _factor(item: Any) -> tuple[Response, float | None]:
    if isinstance(item, control.LTI):
        return _lti_response(item)
    if hasattr(item, "freqresp") and hasattr(item, "modes"):  # ModalPlant: exact, with delay
        return (lambda f: np.asarray(item.freqresp(f), dtype=complex)), None
    if callable(item):
        return (lambda f: np.asarray(item(f), dtype=complex)), getattr(item, "dt", None)
    raise ServokitTypeError(
        f"loop factor of type {type(item).__name__} is not supported; pass a python-control "
        "LTI system, a ModalPlant or a callable freq_hz -> complex response"
    )


def loop_response(loop: Any, delay: float = 0.0) -> tuple[Response, float | None]:
    """Return ``(L(freq_hz), dt)`` for a loop given as one factor or a sequence of factors.

    Factors are python-control LTI systems, :class:`~servokit.models.ModalPlant` objects or
    callables ``freq_hz -> complex``; a sequence is multiplied point by point, so a
    high-order loop never becomes one ill-conditioned polynomial ratio. All discrete
    factors must share one sampling period ``dt``.
    """
    items: Sequence[Any] = loop if isinstance(loop, list | tuple) else [loop]
    if not items:
        raise ServokitValueError("loop must hold at least one factor")
    factors = [_factor(it) for it in items]
    dts = {dt for _, dt in factors if dt is not None}
    if len(dts) > 1:
        raise ServokitValueError(f"loop factors have different sampling periods {sorted(dts)}")
    dt = dts.pop() if dts else None
    tau = float(check_finite("delay", delay))
    if tau < 0:
        raise ServokitValueError(f"delay must be >= 0 s (got {tau})")

    def resp(f: np.ndarray) -> np.ndarray:
        f = np.asarray(f, dtype=float)
        out = np.exp(-2j * np.pi * f * tau) if tau else np.ones(f.shape, dtype=complex)
        for r, _ in factors:
            out = out * r(f)
        return out

    return resp, dt


def _default_band(dt: float | None) -> tuple[float, float]:
    if dt is not None:
        return 1e-4 / dt, 0.5 / dt
    return 1e-4, 1e6


def _roots(
    g: Callable[[float], float], f: np.ndarray, vals: np.ndarray, keep: np.ndarray
) -> list[float]:
    """Refine each sign change of ``vals`` on the grid ``f`` (where ``keep``) by brentq."""
    out: list[float] = []
    s = np.sign(vals)
    idx = np.nonzero((s[:-1] * s[1:] <= 0) & keep[:-1] & np.isfinite(vals[:-1] + vals[1:]))[0]
    for i in idx:
        if vals[i] == 0:
            out.append(float(f[i]))
        elif vals[i + 1] != 0:
            out.append(float(brentq(g, f[i], f[i + 1], xtol=1e-12 * f[i + 1], rtol=1e-12)))
    return sorted(set(out))


def _wrap_deg(x: np.ndarray | float) -> np.ndarray:
    """Wrap degrees into (−180, 180]."""
    return 180.0 - np.mod(180.0 - np.asarray(x, dtype=float), 360.0)


def stability_margins(
    loop: Any,
    delay: float = 0.0,
    *,
    fmin: float | None = None,
    fmax: float | None = None,
    n_freq: int = 20000,
) -> Margins:
    """Gain, phase, delay and second phase margins of a SISO loop L, exact delay included.

    Parameters
    ----------
    loop : LTI, ModalPlant, callable or sequence of them
        The open loop L = P C (continuous or discrete; see :func:`loop_response`).
    delay : float
        Extra pure delay τ [s] in the loop, applied exactly as e^{-jωτ}.
    fmin, fmax : float, optional
        Search band [Hz]; defaults 1e-4/dt .. Nyquist for discrete loops and
        1e-4 Hz .. 1 MHz for continuous ones.
    n_freq : int
        Points of the logarithmic search grid before root refinement.

    Returns
    -------
    Margins
        Headline margins (infinite when there is no crossing) and every crossing.
    """
    resp, dt = loop_response(loop, delay)
    n = check_count("n_freq", n_freq, lo=16, hi=10_000_000)
    lo, hi = _default_band(dt)
    lo = lo if fmin is None else float(fmin)
    hi = hi if fmax is None else float(fmax)
    if not (0 < lo < hi) or not np.isfinite(hi):
        raise ServokitValueError(f"need 0 < fmin < fmax (got fmin={lo:g}, fmax={hi:g})")
    if dt is not None and hi > 0.5 / dt * (1 + 1e-12):
        raise ServokitValueError(f"fmax must not exceed the Nyquist frequency {0.5 / dt:g} Hz")
    f = np.geomspace(lo, hi, n)
    L = resp(f)
    with np.errstate(divide="ignore", invalid="ignore"):
        logmag = np.log(np.abs(L))
        unit = L / np.abs(L)

    def g_mag(x: float) -> float:
        return float(np.log(np.abs(resp(np.array([x]))[0])))

    def g_phase(x: float) -> float:
        v = resp(np.array([x]))[0]
        return float(v.imag / abs(v))

    wc = _roots(g_mag, f, logmag, np.ones(n, dtype=bool))
    w180 = _roots(g_phase, f, unit.imag, unit.real < 0)
    return _assemble(resp, wc, w180)


def _assemble(resp: Response, wc: list[float], w180: list[float]) -> Margins:
    lc = resp(np.array(wc, dtype=float))
    pms = _wrap_deg(180.0 + np.degrees(np.angle(lc)))
    l180 = resp(np.array(w180, dtype=float))
    gms = -20.0 * np.log10(np.abs(l180))
    if wc:
        pm, pm_f = float(pms[0]), wc[0]
        # the delay that first turns some crossover onto -1: phase lost = PM mod 360
        dm = float(np.min(np.radians(np.mod(pms, 360.0)) / (2 * np.pi * np.asarray(wc))))
    else:
        pm, pm_f, dm = np.inf, np.nan, np.inf
    if w180:
        k = int(np.argmin(np.abs(gms)))
        gm, gm_f = float(gms[k]), w180[k]
    else:
        gm, gm_f = np.inf, np.nan
    second = float(np.mod(pms[1], 360.0)) if len(wc) > 1 else np.nan
    return Margins(
        gain_margin_db=gm,
        phase_margin_deg=pm,
        gm_freq_hz=float(gm_f),
        pm_freq_hz=float(pm_f),
        delay_margin_s=dm,
        gain_crossovers_hz=tuple(float(x) for x in wc),
        phase_margins_deg=tuple(float(x) for x in pms),
        phase_crossovers_hz=tuple(float(x) for x in w180),
        gain_margins_db=tuple(float(x) for x in gms),
        second_phase_margin_deg=second,
    )
