"""Stability margins on the exact loop frequency response, every crossing, a stability verdict.

python-control's ``stability_margins`` converts the loop to one polynomial ratio and finds
crossings from polynomial roots; on high-order discrete loops this reports spurious
crossings (on the 23-state §4.5 loop it gives PM 19.9° at 317 Hz, where |L| = 2.7). Here
the loop is a product of factors, each evaluated exactly from a reduced form computed
once (:mod:`~servokit.feedback.factor_response`), on a grid packed around every lightly
damped pole and zero (:mod:`~servokit.models.frequency_grid`) and refined adaptively;
every crossing is bracketed, shrunk and verified on the exact response
(:mod:`~servokit.feedback.crossings`). A delay multiplies the response by ``e^{-jωτ}``
exactly (no Padé).

Definitions (allmargin-style: every crossing is listed with its own margin)
-----------------------------------------------------------------------------
* Phase margin at a gain crossover ωc: ``180° + arg L(jωc)``, wrapped into (−180, 180].
  The headline :attr:`Margins.phase_margin_deg` is the one at the first (lowest) gain
  crossover, the book's convention for phase-stabilised loops, whose resonance peaks
  cross 0 dB again with any phase; every crossover is listed in ``phase_margins_deg``.
* Gain margin at a phase crossover ω180: ``−20 log10 |L(jω180)|`` [dB]. The headline is
  the one closest to 0 dB (the nearest gain change that reaches instability, upward or
  downward for conditionally stable loops).
* Delay margin at each gain crossover k: the smallest extra delay τ ≥ 0 that puts
  ``L(jωk) e^{-jωk τ}`` on −1: ``τk = (PMk mod 360°) / ωk`` (the modulo matters: a
  crossover with PM = −100° is reached after a 260° lag, not never). The headline
  ``delay_margin_s`` is the minimum over all crossovers (not the crossover of smallest
  PM, which is wrong when a resonance peak crosses 0 dB at high frequency); 0 when the
  closed loop is already unstable. For a discrete loop the extra delay is the
  frequency-response factor ``e^{-jωτ}`` (a whole number of samples is exactly ``z^-d``).
* Modulus margin: ``min_ω |1 + L|`` (the inverse of the sensitivity peak), located
  exactly (bounded Brent around the grid minimum).
* Closed-loop stability: Nyquist winding count with the open-loop unstable poles,
  boundary poles indented (:mod:`~servokit.feedback.nyquist`); None when a factor is a
  black-box callable without ``poles``.
* Second phase margin (phase-stabilised loops, §5.3.3.1, Table 5.4): the phase margin
  at the second gain crossover, in [0°, 360°) (e.g. 223.8°, as the book prints it).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from servokit.errors import ServokitValueError, check_count, check_finite
from servokit.feedback.accurate_response import accurate_evaluator
from servokit.feedback.crossings import MAX_POINTS, MAX_STEP, TINY, adapt_grid, cut_intervals
from servokit.feedback.crossings import find_crossings as _find
from servokit.feedback.factor_response import Factor, loop_evaluator, make_factor
from servokit.feedback.nyquist import BoundaryPoles, boundary_poles, winding_verdict
from servokit.models.frequency_grid import factor_frequencies, pack_around

__all__ = ["Margins", "stability_margins", "loop_response", "loop_factors"]

Response = Callable[[np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Margins:
    """Every crossing of a loop, the margins derived from them (Hz) and a stability verdict."""

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
    delay_margins_s: tuple[float, ...] = ()
    modulus_margin: float = np.nan
    modulus_margin_freq_hz: float = np.nan
    closed_loop_stable: bool | None = None

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
            "closed_loop_stable": self.closed_loop_stable,
            "gain_margin_db": self.gain_margin_db,
            "phase_margin_deg": self.phase_margin_deg,
            "gm_freq_hz": self.gm_freq_hz,
            "pm_freq_hz": self.pm_freq_hz,
            "delay_margin_s": self.delay_margin_s,
            "modulus_margin": self.modulus_margin,
            "modulus_margin_freq_hz": self.modulus_margin_freq_hz,
            "second_phase_margin_deg": self.second_phase_margin_deg,
            "gain_crossovers_hz": list(self.gain_crossovers_hz),
            "phase_margins_deg": list(self.phase_margins_deg),
            "delay_margins_s": list(self.delay_margins_s),
            "phase_crossovers_hz": list(self.phase_crossovers_hz),
            "gain_margins_db": list(self.gain_margins_db),
        }


def loop_factors(loop: Any) -> tuple[list[Factor], float | None]:
    """The loop's factors (see :func:`loop_response`) and their common sampling period.

    Parameters
    ----------
    loop : LTI, ModalPlant, callable or sequence of them
        The loop factors.

    Returns
    -------
    tuple of (list of Factor, float or None)
    """
    items: Sequence[Any] = loop if isinstance(loop, list | tuple) else [loop]
    if not items:
        raise ServokitValueError("loop must hold at least one factor")
    factors = [make_factor(it) for it in items]
    dts = {fa.dt for fa in factors if fa.dt is not None}
    if len(dts) > 1:
        raise ServokitValueError(f"loop factors have different sampling periods {sorted(dts)}")
    dt = dts.pop() if dts else None
    if dt is not None and any(fa.continuous_lti for fa in factors):
        raise ServokitValueError(
            "loop mixes continuous and discrete factors; discretise the continuous ones "
            "(ModalPlant.discretize(dt), control.sample_system)"
        )
    return factors, dt


def _delay(delay: float) -> float:
    tau = float(check_finite("delay", delay))
    if tau < 0:
        raise ServokitValueError(f"delay must be >= 0 s (got {tau})")
    return tau


def loop_response(loop: Any, delay: float = 0.0) -> tuple[Response, float | None]:
    """Return ``(L(freq_hz), dt)`` for a loop given as one factor or a sequence of factors.

    Factors are python-control LTI systems, :class:`~servokit.models.ModalPlant` objects or
    callables ``freq_hz -> complex``; a sequence is multiplied point by point, so a
    high-order loop never becomes one ill-conditioned polynomial ratio. All discrete
    factors must share one sampling period ``dt``; continuous and discrete LTI factors
    cannot be mixed.

    Parameters
    ----------
    loop : LTI, ModalPlant, callable or sequence of them
        The loop factors.
    delay : float
        Extra pure delay [s], applied exactly.

    Returns
    -------
    tuple of (callable, float or None)
        The response ``L(freq_hz)`` (complex array) and the sampling period (None if
        continuous).
    """
    factors, dt = loop_factors(loop)
    return loop_evaluator(factors, _delay(delay), dt), dt


def _wrap_deg(x: np.ndarray | float) -> np.ndarray:
    """Wrap degrees into (−180, 180]."""
    return 180.0 - np.mod(180.0 - np.asarray(x, dtype=float), 360.0)


def _band(
    factors: list[Factor], dt: float | None, tau: float, fmin: float | None, fmax: float | None
) -> tuple[float, float, np.ndarray, np.ndarray]:
    """Search band and the critical frequencies/dampings of all factors.

    A continuous loop with a delay has phase crossovers every ``1/τ`` Hz for ever; the
    default band then stops at ``max(10 f_max, 10/τ)`` (f_max the highest pole or zero),
    not at 1 MHz.
    """
    crit = [factor_frequencies(fa.poles, fa.zeros, fa.dt) for fa in factors if fa.poles is not None]
    f0 = np.concatenate([c[0] for c in crit]) if crit else np.zeros(0)
    z = np.concatenate([c[1] for c in crit]) if crit else np.zeros(0)
    if dt is not None:
        lo, hi = 1e-4 / dt, 0.5 / dt
    else:
        lo, hi = 1e-4, 1e6
        if f0.size:
            lo, hi = min(lo, f0.min() / 10), max(hi, f0.max() * 10)
        if tau > 0:
            hi = min(hi, max(10.0 / tau, 10 * f0.max() if f0.size else 0.0))
    lo = lo if fmin is None else float(fmin)
    hi = hi if fmax is None else float(fmax)
    if not (0 < lo < hi) or not np.isfinite(hi):
        raise ServokitValueError(f"need 0 < fmin < fmax (got fmin={lo:g}, fmax={hi:g})")
    if dt is not None and hi > 0.5 / dt * (1 + 1e-12):
        raise ServokitValueError(f"fmax must not exceed the Nyquist frequency {0.5 / dt:g} Hz")
    return lo, hi, f0, z


def _contour_grid(
    resp: Response,
    lo: float,
    hi: float,
    n: int,
    f0: np.ndarray,
    z: np.ndarray,
    bp: BoundaryPoles | None,
    dt: float | None,
) -> tuple[np.ndarray, float]:
    """Starting grid over the whole positive half of the Nyquist contour, and its top."""
    small = f0[f0 > 0]
    start = min(lo, (small.min() if small.size else lo) * 1e-3)
    if bp is None or bp.at_zero:
        # not closer to a pole at dc than its computed position is accurate (a Jordan
        # block's eigenvalues split by ~sqrt(eps)): 1e-6 rad per sample, 1e-7 of the top
        floor = 1e-6 / (2 * np.pi * dt) if dt is not None else 1e-7 * max(hi, f0.max(initial=0))
        start = max(start, min(floor, lo))
    else:  # finite at dc: down to where |L| is on the side of 1 that L(0) is
        start = _below_dc_crossing(resp, start)
    if dt is not None:
        top = 0.5 / dt * (1 - 1e-9 if bp is not None and bp.at_nyquist else 1.0)
    else:
        top = max(hi, (f0.max() if f0.size else hi) * 1e3)
        for _ in range(12):  # continue until |L| < 1 for good
            if abs(resp(np.array([top]))[0]) < 0.5:
                break
            top *= 10.0
    f = np.geomspace(start, top, n)
    packed = pack_around(f0, z)
    parts = [f, packed[(packed > start) & (packed < top)], [lo, hi]]
    if bp is not None and bp.freqs_hz.size:
        b = bp.freqs_hz
        parts.append(np.r_[b * (1 - 1e-8), b * (1 + 1e-8)])
        f = np.unique(np.concatenate(parts))
        f = f[np.abs(f[:, None] - b[None, :]).min(axis=1) > 1e-9 * f]
        return f, top
    return np.unique(np.concatenate(parts)), top


def _below_dc_crossing(resp: Response, start: float) -> float:
    """``start``, or a lower frequency below which ``|L|`` stays on the side of 1 of ``L(0)``.

    A loop finite at dc (type 0) whose dc gain is close to 1 crosses 0 dB at a frequency
    that tends to 0 with ``|L(0)| - 1`` (``|L(jω)|²`` is even in ω); the grid must start
    below that crossing, whatever the poles and zeros.  Decades are added until the sign
    of ``log |L|`` is that of ``log |L(0)|`` (at most 30: ``|L(jω)|² - |L(0)|²`` grows at
    least as ω², so a crossing lies above ``sqrt(eps)`` times the nearest critical
    frequency).
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        mags = np.abs(resp(np.array([0.0, start])))
        dc, side = np.sign(np.log(mags))  # a zero at dc: -inf, below 1
    if not np.isfinite(mags).all() or dc == 0:
        return start
    for _ in range(30):
        if side == dc:
            break
        start /= 10.0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            side = np.sign(np.log(np.abs(resp(np.array([start]))[0])))
    return start


def stability_margins(
    loop: Any,
    delay: float = 0.0,
    *,
    fmin: float | None = None,
    fmax: float | None = None,
    n_freq: int = 500,
) -> Margins:
    """All gain, phase, delay and modulus margins of a SISO loop L, and its stability verdict.

    Parameters
    ----------
    loop : LTI, ModalPlant, callable or sequence of them
        The open loop L = P C (continuous or discrete; see :func:`loop_response`).
    delay : float
        Extra pure delay τ [s] in the loop, applied exactly as e^{-jωτ}.
    fmin, fmax : float, optional
        Band [Hz] in which crossings are listed; defaults 1e-4/dt .. Nyquist for discrete
        loops and 1e-4 Hz .. 1 MHz (widened to a decade beyond every pole and zero) for
        continuous ones; a loop finite at dc (no pole at s = 0 / z = 1) lists every
        crossing down to dc by default (a dc gain near 1 crosses 0 dB at any low
        frequency). The stability verdict always uses the whole contour.
    n_freq : int
        Points of the logarithmic background grid (the grid is also packed around every
        pole and zero and refined adaptively, so the default is right for any damping).

    Returns
    -------
    Margins
        Headline margins (infinite when there is no crossing), every crossing, the
        modulus margin and ``closed_loop_stable``.
    """
    factors, dt = loop_factors(loop)
    tau = _delay(delay)
    n = check_count("n_freq", n_freq, lo=16, hi=10_000_000)
    lo, hi, f0, z = _band(factors, dt, tau, fmin, fmax)
    if 2 * np.pi * hi * tau / MAX_STEP > MAX_POINTS / 2:
        raise ServokitValueError(
            f"delay {tau:g} s turns the phase {hi * tau:.3g} times below {hi:g} Hz: "
            "too large to resolve; give a delay below "
            f"{MAX_POINTS * MAX_STEP / (4 * np.pi * hi):.3g} s (or a smaller fmax)"
        )
    resp = loop_evaluator(factors, tau, dt)
    known = all(fa.poles is not None for fa in factors)
    bp = boundary_poles(np.concatenate([fa.poles for fa in factors]), dt) if known else None
    f, top = _contour_grid(resp, lo, hi, n, f0, z, bp, dt)
    if fmin is None and bp is not None and not bp.at_zero:
        lo = min(lo, float(f[0]))  # finite at dc: every crossing down to the grid's start
    barriers = bp.freqs_hz if bp is not None else np.zeros(0)
    f, L = adapt_grid(resp, f, barriers=barriers, quiet_above=hi)
    stable = None if bp is None else winding_verdict(f, L, bp, dt is not None)
    band = (f >= lo * (1 - 1e-12)) & (f <= hi * (1 + 1e-12))
    cut = cut_intervals(f, barriers)
    # the roots and the margins on the accurate response (cancelling partial fractions
    # replaced; accurate_response): 1e-9 relative near clustered poles too
    fine = accurate_evaluator(factors, tau, dt)
    wc, w180, lc, l180 = _crossings(resp, fine, f, L, band, cut)
    mm, mm_f = _modulus_margin(resp, f, L, band, cut)
    return _assemble(wc, w180, lc, l180, stable, mm, mm_f)


def _log_mag(L: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.log(np.abs(L))


def _sin_phase(L: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return L.imag / np.abs(L)


def _crossings(
    resp: Response,
    fine: Response,
    f: np.ndarray,
    L: np.ndarray,
    band: np.ndarray,
    cut: np.ndarray,
) -> tuple[list[float], list[float], np.ndarray, np.ndarray]:
    """Gain and phase crossovers [Hz] and the accurate response at them (one call)."""
    phase_ok = band & (np.abs(L) > TINY) & (L.real < 0)
    tests = [(_log_mag, band), (_sin_phase, phase_ok)]
    wc, w180 = _find(resp, f, L, tests, cut, exact=fine)
    both = fine(np.array([*wc, *w180], dtype=float))
    lc, l180 = both[: len(wc)], both[len(wc) :]
    # verify: L real and negative at a phase crossover
    keep = l180.real < 0
    return wc, [x for x, k in zip(w180, keep, strict=True) if k], lc, l180[keep]


def _modulus_margin(
    resp: Response, f: np.ndarray, L: np.ndarray, band: np.ndarray, cut: np.ndarray
) -> tuple[float, float]:
    """``min |1 + L|`` in the band: grid minimum, then 257-point zooming on its neighbours."""
    d = np.where(band, np.abs(1.0 + L), np.inf)
    k = int(np.argmin(d))
    if not np.isfinite(d[k]):
        return np.nan, np.nan
    lo = f[k - 1] if k > 0 and not cut[k - 1] and band[k - 1] else f[k]
    hi = f[k + 1] if k + 1 < f.size and not cut[k] and band[k + 1] else f[k]
    a, b = lo, hi
    best, val = float(f[k]), float(d[k])
    for _ in range(2):
        x = np.linspace(a, b, 257)
        dx = np.abs(1.0 + resp(x))
        j = int(np.argmin(dx))
        if dx[j] < val:
            best, val = float(x[j]), float(dx[j])
        step = (b - a) / 256
        a, b = max(lo, best - step), min(hi, best + step)
    return val, best


def _assemble(
    wc: list[float],
    w180: list[float],
    lc: np.ndarray,
    l180: np.ndarray,
    stable: bool | None,
    mm: float,
    mm_f: float,
) -> Margins:
    pms = _wrap_deg(180.0 + np.degrees(np.angle(lc)))
    gms = -20.0 * np.log10(np.abs(l180))
    # the delay that first turns crossover k onto -1: phase lost = PM_k mod 360
    dms = np.radians(np.mod(pms, 360.0)) / (2 * np.pi * np.asarray(wc, dtype=float))
    if wc:
        pm, pm_f = float(pms[0]), wc[0]
        dm = float(np.min(dms)) if stable is not False else 0.0
    else:
        pm, pm_f, dm = np.inf, np.nan, (np.inf if stable is not False else 0.0)
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
        delay_margins_s=tuple(float(x) for x in dms),
        modulus_margin=mm,
        modulus_margin_freq_hz=mm_f,
        closed_loop_stable=stable,
    )
