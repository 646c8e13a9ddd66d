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


def _interp_at(logf: np.ndarray, y: np.ndarray, i: np.ndarray, frac: np.ndarray) -> np.ndarray:
    return y[i] + frac * (y[i + 1] - y[i])


def _crossings(freq_hz: np.ndarray, L: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every gain crossover (frequency, phase margin in degrees), by log-log interpolation."""
    logf = np.log(freq_hz)
    lm = np.log(np.abs(L))
    i = np.nonzero(np.sign(lm[:-1]) * np.sign(lm[1:]) < 0)[0]
    frac = lm[i] / (lm[i] - lm[i + 1])
    fc = np.exp(_interp_at(logf, logf, i, frac))
    # phase between neighbours along the shorter arc, so a wrap does not corrupt it
    step = np.angle(L[i + 1] / L[i])
    ph = np.angle(L[i]) + frac * step
    pm = 180.0 - np.mod(180.0 - (180.0 + np.degrees(ph)), 360.0)
    return fc, pm


def _gain_margin_db(L: np.ndarray) -> float:
    """Phase-crossover margin nearest 0 dB (sign changes of Im L with Re L < 0)."""
    im = L.imag
    i = np.nonzero((np.sign(im[:-1]) * np.sign(im[1:]) <= 0) & (L.real[:-1] < 0))[0]
    if i.size == 0:
        return float("inf")
    frac = np.where(im[i] != im[i + 1], im[i] / (im[i] - im[i + 1] + 1e-300), 0.0)
    re = L.real[i] + frac * (L.real[i + 1] - L.real[i])
    gms = -20.0 * np.log10(np.abs(re))
    return float(gms[np.argmin(np.abs(gms))])


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
    w = 2 * np.pi * freq_hz[0] * dt
    g = L[0] * (np.exp(1j * w) - 1.0) ** n_integrators
    start = (0.0 if g.real >= 0 else np.pi) - n_integrators * np.pi / 2
    r = 1.0 + L
    steps = np.angle(r[1:] / r[:-1])
    first = np.angle(r[0] * np.exp(-1j * start))
    delta = first + steps.sum()
    z_out = n_unstable + n_integrators / 2 - delta / np.pi
    resolved = bool(np.all(np.abs(steps) < MAX_PHASE_STEP)) and bool(abs(first) < MAX_PHASE_STEP)
    return int(np.rint(z_out)), resolved


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
    rows = tuple(
        evaluate_loop(
            freq_hz,
            p * controller_response,
            dt,
            n_integrators=n_integrators,
            n_unstable=n_unstable,
        )
        for p in responses
    )
    names = names or tuple(str(i) for i in range(len(rows)))
    return LoopTable(rows=rows, names=tuple(names))
