"""The per-loop evaluation as it was before the batched one (issue 24): the reference.

:func:`servokit.feedback.loopshape_eval.evaluate_set` now evaluates the loops of a set
together, in 2-D arrays; these are the one-loop functions it replaced, kept verbatim
(docstrings shortened) so the tests can require the same numbers bit for bit.
"""

from __future__ import annotations

import numpy as np

from servokit.feedback.loopshape_eval import MAX_PHASE_STEP, LoopRow


def _interp_at(logf: np.ndarray, y: np.ndarray, i: np.ndarray, frac: np.ndarray) -> np.ndarray:
    return y[i] + frac * (y[i + 1] - y[i])


def _crossings(freq_hz: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    logf = np.log(freq_hz)
    lm = np.log(np.abs(L))
    i = np.nonzero(np.sign(lm[:-1]) * np.sign(lm[1:]) < 0)[0]
    frac = lm[i] / (lm[i] - lm[i + 1])
    fc = np.exp(_interp_at(logf, logf, i, frac))
    step = np.angle(L[i + 1] / L[i])
    ph = np.angle(L[i]) + frac * step
    pm = 180.0 - np.mod(180.0 - (180.0 + np.degrees(ph)), 360.0)
    return fc, pm


def _gain_margin_db(L: np.ndarray) -> float:
    im = L.imag
    i = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) <= 0) & (L.real[:-1] < 0))[0]
    if i.size == 0:
        return float("inf")
    frac = np.where(im[i] != im[i + 1], im[i] / (im[i] - im[i + 1] + 1e-300), 0.0)
    re = L.real[i] + frac * (L.real[i + 1] - L.real[i])
    gms = -20.0 * np.log10(np.abs(re))
    return float(gms[np.argmin(np.abs(gms))])


def closed_loop_unstable(freq_hz, L, dt, *, n_integrators, n_unstable=0) -> tuple[int, bool]:
    """Nyquist count of one loop (the reference)."""
    w = 2 * np.pi * freq_hz[0] * dt
    g = L[0] * (np.exp(1j * w) - 1.0) ** n_integrators
    start = (0.0 if g.real >= 0 else np.pi) - n_integrators * np.pi / 2
    r = 1.0 + L
    steps = np.angle(r[1:] / r[:-1])
    first = np.angle(r[0] * np.exp(-1j * start))
    delta = first + steps.sum()
    z_out = n_unstable + n_integrators / 2 - delta / np.pi
    resolved = bool(np.all(np.abs(steps) < MAX_PHASE_STEP)) and bool(abs(first) < MAX_PHASE_STEP)
    if not np.isfinite(z_out):  # 1 + L = 0 on the grid: a pole on the circle, not stable
        return 1, False
    # a count that is not a whole number >= 0 means an assumption of the count failed
    whole = abs(z_out - round(z_out)) < 0.25 and round(z_out) >= 0
    return int(np.rint(z_out)), resolved and whole


def evaluate_loop(freq_hz, L, dt, *, n_integrators, n_unstable=0) -> LoopRow:
    """Margins of one loop (the reference)."""
    fc, pm = _crossings(freq_hz, L)
    down = np.nonzero(np.abs(L[:-1]) >= 1.0)[0]
    if fc.size:
        crossover, pm0 = float(fc[0]), float(pm[0])
        dm = float(np.min(np.radians(np.mod(pm, 360.0)) / (2 * np.pi * fc)))
    else:
        crossover, pm0, dm = (float(freq_hz[0]) if down.size == 0 else float("nan")), 0.0, 0.0
    with np.errstate(divide="ignore"):
        s = 20 * np.log10(np.max(np.abs(1.0 / (1.0 + L))))
        t = 20 * np.log10(np.max(np.abs(L / (1.0 + L))))
    z_out, resolved = closed_loop_unstable(
        freq_hz, L, dt, n_integrators=n_integrators, n_unstable=n_unstable
    )
    return LoopRow(
        crossover_hz=crossover,
        phase_margin_deg=pm0,
        gain_margin_db=_gain_margin_db(L),
        delay_margin_s=dm,
        s_peak_db=float(s),
        t_peak_db=float(t),
        unstable_poles=z_out,
        resolved=resolved,
    )
