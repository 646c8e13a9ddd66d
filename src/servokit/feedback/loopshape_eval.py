"""Exact per-loop evaluation on a measured frequency grid (loop shaping from FRFs, issue 25).

Every number here comes from the loop response ``L = P K`` on the given grid, with no model:

* lowest gain crossover: the first fall of ``|L|`` through 1, refined by linear interpolation
  of ``log|L|`` against ``log f`` between the two bracketing grid points;
* phase margin ``180° + arg L`` at that crossover (phase interpolated the same way),
  delay margin ``min_k (PM_k mod 360°) / ω_k`` over every gain crossover, gain margin the
  phase-crossover value of ``-20 log10 |L|`` nearest 0 dB (the conventions of
  :mod:`servokit.feedback.margins`);
* ``‖S‖∞`` the largest ``|1 / (1 + L)|`` on the grid;
* stability by the discrete Nyquist criterion counted on the half circle. With ``n`` open-loop
  poles, ``m`` of them at ``z = 1`` (integrators, rigid body) and ``n_out`` outside the unit
  disc, the characteristic polynomial ``φ = (1 + L) D_L`` has ``Z_in`` roots inside with
  ``Δarg φ = π Z_in`` over ``ω ∈ (0, π]`` (conjugate symmetry). ``D_L`` contributes
  ``π (n - n_out - m) + m π/2`` (each root at ``z = 1`` gives ``arg(e^{jω} - 1) = ω/2 + π/2``),
  hence the number of unstable closed-loop poles is

      ``Z_out = n_out + m/2 - Δarg(1 + L)/π``,

  where ``Δarg(1 + L)`` runs from ``ω = 0+`` (asymptote ``arg L → arg g - mπ/2``, ``g`` the
  real limit of ``(z - 1)^m L``) to the last grid point (Nyquist, where ``1 + L`` is real).
  Checked on ``L = k/(z - 1)``: ``Δ = π/2`` (``Z_out = 0``) for ``0 < k < 2`` and ``-π/2``
  (``Z_out = 1``) for ``k > 2``. The count is exact when the grid starts where ``|L| >> 1`` at
  its asymptotic phase, ends at Nyquist and resolves every phase swing of ``1 + L``
  (``resolved`` is False when two neighbours differ by more than 90°).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["LoopTable", "LoopRow", "evaluate_loop", "evaluate_set", "closed_loop_unstable"]

#: Largest phase step of 1 + L between grid neighbours for a trusted winding count [rad].
MAX_PHASE_STEP = np.pi / 2


@dataclass(frozen=True)
class LoopRow:
    """Margins of one loop on its grid (frequencies in Hz)."""

    crossover_hz: float
    phase_margin_deg: float
    gain_margin_db: float
    delay_margin_s: float
    s_peak_db: float
    t_peak_db: float
    unstable_poles: int
    resolved: bool

    @property
    def stable(self) -> bool:
        """True when the winding count gives no closed-loop pole outside the unit disc."""
        return self.unstable_poles == 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (snake_case keys with unit suffixes)."""
        return {
            "crossover_hz": self.crossover_hz,
            "phase_margin_deg": self.phase_margin_deg,
            "gain_margin_db": self.gain_margin_db,
            "delay_margin_s": self.delay_margin_s,
            "s_peak_db": self.s_peak_db,
            "t_peak_db": self.t_peak_db,
            "stable": self.stable,
            "unstable_poles": self.unstable_poles,
            "resolved": self.resolved,
        }


@dataclass(frozen=True)
class LoopTable:
    """One :class:`LoopRow` per plant, with the worst case over the set."""

    rows: tuple[LoopRow, ...]
    names: tuple[str, ...]

    @property
    def min_crossover_hz(self) -> float:
        """Lowest crossover over the set [Hz]."""
        return float(np.min([r.crossover_hz for r in self.rows]))

    @property
    def max_crossover_hz(self) -> float:
        """Highest crossover over the set [Hz]."""
        return float(np.max([r.crossover_hz for r in self.rows]))

    @property
    def worst_s_peak_db(self) -> float:
        """Largest ``‖S‖∞`` over the set [dB]."""
        return float(np.max([r.s_peak_db for r in self.rows]))

    @property
    def worst_phase_margin_deg(self) -> float:
        """Smallest phase margin over the set [deg]."""
        return float(np.min([r.phase_margin_deg for r in self.rows]))

    @property
    def worst_gain_margin_db(self) -> float:
        """Smallest gain margin over the set [dB]."""
        return float(np.min([r.gain_margin_db for r in self.rows]))

    @property
    def all_stable(self) -> bool:
        """True when every loop of the set is closed-loop stable."""
        return all(r.stable for r in self.rows)

    def summary(self) -> dict[str, Any]:
        """Worst-case numbers over the set (JSON-ready)."""
        return {
            "n_plants": len(self.rows),
            "min_crossover_hz": self.min_crossover_hz,
            "max_crossover_hz": self.max_crossover_hz,
            "worst_s_peak_db": self.worst_s_peak_db,
            "worst_phase_margin_deg": self.worst_phase_margin_deg,
            "worst_gain_margin_db": self.worst_gain_margin_db,
            "all_stable": self.all_stable,
            "n_unstable": sum(not r.stable for r in self.rows),
        }

    def to_dicts(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per plant (with its name)."""
        return [{"plant": n, **r.to_dict()} for n, r in zip(self.names, self.rows, strict=True)]


def _crossings(freq_hz: np.ndarray, L: np.ndarray, mag: np.ndarray):
    """Every gain crossover of the loops ``L`` (rows): (row, frequency, phase margin [deg]).

    Log-log interpolation between the bracketing grid points; rows in order, each row's
    crossovers by increasing frequency. ``mag`` is ``|L|``: ``log|L|`` changes sign
    where ``|L|`` passes 1 (``log`` is monotone with ``log 1 = 0``), so the logarithm is
    taken only at the bracketing points.
    """
    logf = np.log(freq_hz)
    below, above = mag < 1.0, mag > 1.0
    r, i = np.nonzero((below[:, :-1] & above[:, 1:]) | (above[:, :-1] & below[:, 1:]))
    lo, hi = np.log(mag[r, i]), np.log(mag[r, i + 1])
    frac = lo / (lo - hi)
    fc = np.exp(logf[i] + frac * (logf[i + 1] - logf[i]))
    # phase between neighbours along the shorter arc, so a wrap does not corrupt it
    step = np.angle(L[r, i + 1] / L[r, i])
    ph = np.angle(L[r, i]) + frac * step
    pm = 180.0 - np.mod(180.0 - (180.0 + np.degrees(ph)), 360.0)
    return r, fc, pm


def _first_per_row(r: np.ndarray) -> np.ndarray:
    """Mask of the first entry of each row in the row-sorted indices ``r``."""
    first = np.ones(r.size, dtype=bool)
    first[1:] = r[1:] != r[:-1]
    return first


def _gain_margins_db(L: np.ndarray) -> np.ndarray:
    """Per row, the phase-crossover margin nearest 0 dB (sign changes of Im L, Re L < 0)."""
    a, b = L.imag[:, :-1], L.imag[:, 1:]
    # sign(a) sign(b) <= 0 without np.sign (False for NaN as there)
    r, i = np.nonzero((((a <= 0) & (b >= 0)) | ((a >= 0) & (b <= 0))) & (L.real[:, :-1] < 0))
    a, b = L.imag[r, i], L.imag[r, i + 1]
    frac = np.where(a != b, a / (a - b + 1e-300), 0.0)
    re = L.real[r, i] + frac * (L.real[r, i + 1] - L.real[r, i])
    gms = -20.0 * np.log10(np.abs(re))
    order = np.lexsort((np.abs(gms), r))  # stable: the first of equal |GM| in a row
    pick = order[_first_per_row(r[order])]
    out = np.full(L.shape[0], np.inf)
    out[r[pick]] = gms[pick]
    return out


def _unstable(freq_hz, L: np.ndarray, dt: float, n_integrators: int, n_unstable: int):
    """Per row, ``Z_out`` and whether the grid resolved the phase (:func:`closed_loop_unstable`)."""
    w = 2 * np.pi * freq_hz[0] * dt
    g = L[:, 0] * (np.exp(1j * w) - 1.0) ** n_integrators
    start = np.where(g.real >= 0, 0.0, np.pi) - n_integrators * np.pi / 2
    r = 1.0 + L
    steps = np.angle(r[:, 1:] / r[:, :-1])
    first = np.angle(r[:, 0] * np.exp(-1j * start))
    delta = first + steps.sum(axis=1)
    z_out = n_unstable + n_integrators / 2 - delta / np.pi
    resolved = np.all(np.abs(steps) < MAX_PHASE_STEP, axis=1) & (np.abs(first) < MAX_PHASE_STEP)
    # 1 + L = 0 on the grid (a closed-loop pole on the unit circle): no count, not stable
    return _pole_count(z_out), resolved & np.isfinite(z_out)


def _pole_count(z_out: np.ndarray) -> np.ndarray:
    """Rounded ``Z_out``; 1 where it is not finite (the loop passes through -1 on the grid:
    a closed-loop pole on the unit circle, counted as one not stable)."""
    finite = np.isfinite(z_out)
    return np.where(finite, np.rint(np.where(finite, z_out, 0.0)), 1.0).astype(int)


def closed_loop_unstable(
    freq_hz: np.ndarray, L: np.ndarray, dt: float, *, n_integrators: int, n_unstable: int = 0
) -> tuple[int, bool]:
    """Number of closed-loop poles outside the unit disc by the Nyquist count (module doc).

    Parameters
    ----------
    freq_hz : ndarray
        Increasing grid [Hz] from well below the crossover up to Nyquist ``0.5/dt``.
    L : ndarray
        Open-loop response on the grid.
    dt : float
        Sampling period [s].
    n_integrators : int
        Open-loop poles at ``z = 1`` (plant rigid body plus controller integrators).
    n_unstable : int
        Open-loop poles outside the unit disc.

    Returns
    -------
    tuple of (int, bool)
        ``Z_out`` (0 for a stable loop) and whether the grid resolved every phase step.
    """
    z_out, resolved = _unstable(freq_hz, np.asarray(L)[None, :], dt, n_integrators, n_unstable)
    return int(z_out[0]), bool(resolved[0])


def _loop_rows(freq_hz, L: np.ndarray, dt: float, n_integrators: int, n_unstable: int):
    """:class:`LoopRow` of each row of ``L`` (loops on one grid), as arrays per column."""
    m, mag = L.shape[0], np.abs(L)
    r, fc, pm = _crossings(freq_hz, L, mag)
    first = _first_per_row(r)
    down = np.any(mag[:, :-1] >= 1.0, axis=1)
    crossover = np.where(down, np.nan, float(freq_hz[0]))
    crossover[r[first]] = fc[first]
    pm0, dm = np.zeros(m), np.full(m, np.inf)
    pm0[r[first]] = pm[first]
    np.minimum.at(dm, r, np.radians(np.mod(pm, 360.0)) / (2 * np.pi * fc))
    dm[np.isinf(dm)] = 0.0
    ret = 1.0 + L
    with np.errstate(divide="ignore"):
        s = 20 * np.log10(_peak(np.ones(1), ret, 1.0 / np.abs(ret)))
        t = 20 * np.log10(_peak(L, ret, mag / np.abs(ret)))
    z_out, resolved = _unstable(freq_hz, L, dt, n_integrators, n_unstable)
    return (crossover, pm0, _gain_margins_db(L), dm, s, t, z_out, resolved)


def _peak(num: np.ndarray, den: np.ndarray, approx: np.ndarray) -> np.ndarray:
    """Per row, ``max |num / den|`` with the complex division done only where it can win.

    ``approx`` is ``|num| / |den|`` in real arithmetic, within a few ulp of the computed
    ``|num / den|``: only the entries within 1e-9 of a row's largest can hold its largest
    computed value, so the result is that of dividing everywhere (NaN rows included).
    """
    top = approx.max(axis=1)
    if not np.all(np.isfinite(top)):  # inf or NaN: as numpy gives it
        return np.max(np.abs(np.broadcast_to(num, den.shape) / den), axis=1)
    r, i = np.nonzero(approx >= top[:, None] * (1.0 - 1e-9))
    nums = num[r, i] if num.ndim == 2 else np.broadcast_to(num, r.shape)
    out = np.full(den.shape[0], -np.inf)
    np.maximum.at(out, r, np.abs(nums / den[r, i]))
    return out


def _rows_of(cols) -> list[LoopRow]:
    """One :class:`LoopRow` per entry of the column arrays of :func:`_loop_rows`."""
    return [
        LoopRow(*(float(v) for v in vals[:6]), int(vals[6]), bool(vals[7]))
        for vals in zip(*(c.tolist() for c in cols), strict=True)
    ]


def evaluate_loop(
    freq_hz: np.ndarray, L: np.ndarray, dt: float, *, n_integrators: int, n_unstable: int = 0
) -> LoopRow:
    """Margins, sensitivity peaks and the stability count of one loop on its grid.

    Parameters
    ----------
    freq_hz : ndarray
        Increasing grid [Hz] ending at Nyquist.
    L : ndarray
        Open-loop response ``P K`` on the grid.
    dt : float
        Sampling period [s].
    n_integrators : int
        Open-loop poles at ``z = 1``.
    n_unstable : int
        Open-loop poles outside the unit disc.

    Returns
    -------
    LoopRow
        Lowest crossover with its phase margin, gain and delay margins, ``‖S‖∞`` and
        ``‖T‖∞`` [dB] and the count of unstable closed-loop poles.
    """
    cols = _loop_rows(freq_hz, np.asarray(L)[None, :], dt, n_integrators, n_unstable)
    return _rows_of(cols)[0]


#: loops evaluated together by :func:`evaluate_set` (complex blocks of ~3 MB at 3000 points)
CHUNK = 128


def evaluate_set(
    freq_hz: np.ndarray,
    responses: np.ndarray,
    controller_response: np.ndarray,
    dt: float,
    *,
    n_integrators: int,
    n_unstable: int = 0,
    names: tuple[str, ...] | None = None,
) -> LoopTable:
    """Per-plant table of :func:`evaluate_loop` for one controller over a set of FRFs.

    Parameters
    ----------
    freq_hz : ndarray
        Common grid [Hz], shape ``(n,)``.
    responses : ndarray
        Plant FRFs, shape ``(M, n)``.
    controller_response : ndarray
        ``K(e^{jωT})`` on the grid, shape ``(n,)``.
    dt : float
        Sampling period [s].
    n_integrators : int
        Open-loop poles at ``z = 1`` (plant and controller together).
    n_unstable : int
        Open-loop poles outside the unit disc.
    names : tuple of str, optional
        Plant names for the table (default ``"0"``, ``"1"``, ...).

    Returns
    -------
    LoopTable
        One row per plant.
    """
    out: list[LoopRow] = []
    for lo in range(0, len(responses), CHUNK):
        L = responses[lo : lo + CHUNK] * controller_response[None, :]
        out += _rows_of(_loop_rows(freq_hz, L, dt, n_integrators, n_unstable))
    rows = tuple(out)
    names = names or tuple(str(i) for i in range(len(rows)))
    return LoopTable(rows=rows, names=tuple(names))
