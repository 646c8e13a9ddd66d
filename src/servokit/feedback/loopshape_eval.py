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

Below the grid. The measured grid starts at ``f_0 > 0``, and the asymptote rule above
takes ``arg L`` to travel less than 90° over ``(0, f_0]``. That holds for a plant measured
from low enough a frequency, but not for a controller with zeros or poles below ``f_0``:
a loop-shaping step that put a lag zero pair at 6 Hz, under a stage FRF starting at
10 Hz, made ``K`` travel 99° there, and the rule counted one unstable pole in a loop whose
exact closed-loop poles lie inside the unit circle (largest modulus 0.9989); other steps,
with a controller pole pair at modulus 1.138 the count did not know of, were counted
stable. The controller
is known exactly (its ``x`` and ``y``, ``controller_coefficients``), and below ``f_0`` the
plant is taken at its asymptote ``g/(z - 1)^m`` (``g`` real: the modulus of
``(z - 1)^m L/K`` at ``f_0`` with the sign of its real part). Then ``1 + L`` below the
grid is ``φ/((1 - q)^m y)`` with ``φ = (1 - q)^m y + g q^m x`` (``q = z^{-1}``), and its
travel over ``(0, ω_0]`` is that of ``φ`` less that of the denominator, each summed over
root factors in closed form (:func:`poly_travel`): a factor ``1 - q/s`` with ``|s| > 1``
stays in a half plane (``|q/s| < 1``), so its travel is the principal
``arg((1 - q_0/s)/(1 - 1/s))``; with ``|s| < 1`` it is ``-(q/s)(1 - s/q)``, travelling
``-ω_0`` plus the principal ``arg((1 - s/q_0)/(1 - s))``; each root at ``q = 1`` travels
``-ω_0/2`` and each leading ``q`` ``-ω_0``. This also holds where ``|L|`` dips below 1
under the grid (a lag zero pair). The measured ``1 + L(f_0)`` joins it through the
principal angle to ``1 + L_asymptote(f_0)``. ``resolved`` is False when that angle exceeds
90°, when the plant at ``f_0`` is more than 45° (``ASYMPTOTE_ANGLE``) from its asymptote
(the sign rule alone keeps that angle within 90°), and, on either path, when ``Z_out`` is
not within 0.25 of a whole number ``>= 0``. Roots at ``z = 1`` are divided out only from
``y`` (the structure's integrators, ``controller_integrators``, else those within
``UNIT_ROOT_TOL``), never from ``x`` or ``φ``: a cluster of lag zeros near ``z = 1`` once
took ``x(1)`` to 1.6e-13 of ``Σ|x_k|`` and passed for an integrator; a controller zero
exactly at ``z = 1`` leaves a closed-loop pole there, counted not stable and unresolved.
The controller's poles outside the unit disc are counted from ``y`` (a free denominator
can move there). Checked against the roots of
the characteristic polynomial of exact discrete loops (tests); a closed-loop pole closer
to the unit circle than the plant's departure from its asymptote (``~ω/2`` for a ZOH
double integrator) can fall on either side.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "LoopTable",
    "LoopRow",
    "closed_loop_unstable",
    "controller_unstable_poles",
    "poly_travel",
    "asymptote_gain",
    "evaluate_loop",
    "evaluate_set",
]

#: Largest phase step of 1 + L between grid neighbours for a trusted winding count [rad].
MAX_PHASE_STEP = np.pi / 2
#: ``|x(1)| <= UNIT_ROOT_TOL * sum |x_k|``: a root of a controller polynomial at ``z = 1``
#: (an integrator: a factor ``1 - z^{-1}`` multiplied out leaves ``x(1)`` at rounding level)
UNIT_ROOT_TOL = 1e-12
#: Largest angle between the plant at the first grid point and its asymptote ``g/(z-1)^m``
#: for a trusted count below the grid [rad]
ASYMPTOTE_ANGLE = np.pi / 4


def _unit_roots(x: np.ndarray, count: int | None = None) -> tuple[np.ndarray, int]:
    """``x`` (ascending powers of ``q = z^{-1}``) with its roots at ``q = 1`` divided out:
    ``count`` of them, or as many as :data:`UNIT_ROOT_TOL` finds."""
    m = 0
    while x.size > 1 and (
        m < count if count is not None else abs(x.sum()) <= UNIT_ROOT_TOL * np.abs(x).sum()
    ):
        x = np.cumsum(x)[:-1]  # x = (1 - q) r: r_k = x_0 + ... + x_k
        m += 1
    return x, m


def poly_travel(x: Any, w0: float, unit_roots: int | None = None) -> float:
    """Continuous change of ``arg x(e^{-jω})`` from ``ω = 0+`` to ``w0`` (module doc).

    Parameters
    ----------
    x : array_like
        Nonzero polynomial in ascending powers of ``q = z^{-1}``.
    w0 : float
        End of the arc [rad/sample], in ``(0, π]``.
    unit_roots : int, optional
        Roots at ``q = 1`` known from the structure (divided out exactly); by default
        those within :data:`UNIT_ROOT_TOL`.

    Returns
    -------
    float
        The travel [rad]: per root ``|s| > 1`` the principal ``arg((1 - q_0/s)/(1 - 1/s))``;
        per root ``|s| < 1`` the principal ``arg((1 - s/q_0)/(1 - s)) - w0``; ``-w0/2``
        per root at ``q = 1``; ``-w0`` per leading power of ``q``.
    """
    x = np.trim_zeros(np.atleast_1d(np.asarray(x, dtype=float)), "b")
    x, m = _unit_roots(x, unit_roots)
    nz = np.flatnonzero(x)
    lead = int(nz[0])
    roots = np.roots(x[lead : nz[-1] + 1][::-1])
    return float(_roots_travel(roots[None, :], w0)[0]) - lead * w0 - m * w0 / 2


def _roots_travel(roots: np.ndarray, w0: float) -> np.ndarray:
    """Per row of ``roots`` (q-roots, none at ``q = 1`` or 0), the summed factor travels."""
    q0 = np.exp(-1j * w0)
    inside = np.abs(roots) < 1.0
    safe = np.where(inside, 2.0, roots)  # (the other branch's value, dropped below)
    # |s| > 1: 1 - q/s stays in a half plane, its travel is the principal angle;
    # |s| < 1: 1 - q/s = -(q/s)(1 - s/q), where q turns by -w0 and 1 - s/q is as above
    out = np.angle((1.0 - q0 / safe) / (1.0 - 1.0 / safe))
    small = np.where(inside, roots, 0.5)
    ins = np.angle((1.0 - small / q0) / (1.0 - small)) - w0
    travel = np.where(inside, ins, out).sum(axis=1)
    # a root at z = 1 that is no structural integrator (a controller zero cancelling one):
    # a closed-loop pole on the unit circle, no travel to count
    return np.where(np.any(np.abs(roots - 1.0) < 1e-12, axis=1), np.nan, travel)


def controller_unstable_poles(den: Any, integrators: int | None = None) -> int:
    """Roots of ``y`` (ascending powers of ``q = z^{-1}``) outside the unit disc in ``z``.

    A root ``s`` in ``q`` is the pole ``z = 1/s``; roots at ``z = 1`` (integrators) are
    divided out first, as :func:`poly_travel` does.

    Parameters
    ----------
    den : array_like
        Controller denominator ``y`` in ascending powers of ``z^{-1}``.
    integrators : int, optional
        Roots of ``y`` at ``z = 1`` known from the structure; by default those within
        :data:`UNIT_ROOT_TOL`.

    Returns
    -------
    int
        Number of poles with ``|z| > 1``.
    """
    y = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "b")
    y = _unit_roots(y, integrators)[0]
    y = y[np.flatnonzero(y)[0] :]
    return int(np.count_nonzero(np.abs(np.roots(y[::-1])) < 1.0))


def asymptote_gain(response0: Any, z0: complex, m: int) -> tuple[np.ndarray, np.ndarray]:
    """The real gain ``g`` of a plant's asymptote ``g / (z - 1)^m`` below the grid.

    Parameters
    ----------
    response0 : array_like of complex
        Plant responses at the first grid point (one per plant).
    z0 : complex
        ``e^{jω_0 T}`` of that point.
    m : int
        Plant poles at ``z = 1``.

    Returns
    -------
    tuple of ndarray
        ``g`` (the modulus of ``(z_0 - 1)^m P`` with the sign of its real part) and that
        complex value itself, whose angle to ``g`` says how near the asymptote the plant is.
    """
    gc = np.asarray(response0, dtype=complex) * (z0 - 1.0) ** m
    return np.where(gc.real >= 0, 1.0, -1.0) * np.abs(gc), gc


def _low_travel(
    x: np.ndarray, y: np.ndarray, g: np.ndarray, m: int, my: int, w0: float
) -> np.ndarray:
    """Per plant, the travel of ``arg(1 + L)`` over ``(0, w0]`` with the plant at its
    asymptote ``g / (z - 1)^m`` and the controller ``x / y``, ``y`` with ``my`` roots at
    ``z = 1`` (module doc)."""
    den = np.convolve(_one_minus_q(m), y)  # (1 - q)^m y; and g q^m x beside it:
    shifted = np.concatenate([np.zeros(m), x])
    n = max(den.size, shifted.size)
    den, shifted = (np.pad(v, (0, n - v.size)) for v in (den, shifted))
    # roots at z = 1 from the structure, never from a tolerance on phi or x: phi(1) =
    # g x(1) is small but not zero under lag zeros near z = 1 (a cluster of them took
    # x(1) to 1.6e-13 of sum |x| and was once mistaken for a numerator integrator)
    base = poly_travel(den, w0, m + my)
    phi = den[None, :] + g[:, None] * shifted[None, :]
    if phi.shape[1] < 2 or np.any(phi[:, 0] == 0) or np.any(phi[:, -1] == 0):
        return np.array([poly_travel(den + gi * shifted, w0, 0) - base for gi in g.tolist()])
    # every row's q-roots at once: eigenvalues of the companion matrices (numpy's roots)
    k = phi.shape[1] - 1
    comp = np.zeros((phi.shape[0], k, k))
    comp[:, 0, :] = -phi[:, -2::-1] / phi[:, -1:]
    comp[:, np.arange(1, k), np.arange(k - 1)] = 1.0
    return _roots_travel(np.linalg.eigvals(comp), w0) - base


def _one_minus_q(m: int) -> np.ndarray:
    out = np.ones(1)
    for _ in range(m):
        out = np.convolve(out, [1.0, -1.0])
    return out


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


def _known(coeffs, integrators: int | None):
    """``(x, y, integrators)`` for the count, or None without coefficients."""
    return None if coeffs is None else (coeffs[0], coeffs[1], integrators)


def _first_travel(freq_hz, L: np.ndarray, dt: float, n_integrators: int, coeffs):
    """Per row, the travel of ``arg(1 + L)`` from ``ω = 0+`` to the first grid point and
    whether the assumptions below the grid hold there (module doc)."""
    w = 2 * np.pi * freq_hz[0] * dt
    z0 = np.exp(1j * w)
    r0 = 1.0 + L[:, 0]
    if coeffs is None:  # the whole loop by the asymptote rule
        g = L[:, 0] * (z0 - 1.0) ** n_integrators
        start = np.where(g.real >= 0, 0.0, np.pi) - n_integrators * np.pi / 2
        first = np.angle(r0 * np.exp(-1j * start))
        return first, np.abs(first) < MAX_PHASE_STEP
    x, y = (np.trim_zeros(np.asarray(v, dtype=float), "b") for v in coeffs[:2])
    my = coeffs[2] if len(coeffs) > 2 and coeffs[2] is not None else _unit_roots(y)[1]
    m = n_integrators - my  # the plant's
    k0 = np.polyval(x[::-1], 1 / z0) / np.polyval(y[::-1], 1 / z0)
    if m < 0:  # fewer loop integrators than the controller has: no asymptote
        return np.zeros(L.shape[0]), np.zeros(L.shape[0], dtype=bool)
    g, gc = asymptote_gain(L[:, 0] / k0, z0, m)  # the plant's, from P = L / K
    near = np.angle(r0 / (1.0 + g / (z0 - 1.0) ** m * k0))  # measured against asymptote
    first = _low_travel(x, y, g, m, my, w) + near
    # |angle(gc/g)| <= 90 deg by the choice of g's sign: the plant must be nearer than that
    at_asymptote = np.abs(np.angle(gc / g)) < ASYMPTOTE_ANGLE
    return first, at_asymptote & (np.abs(near) < MAX_PHASE_STEP)


def _unstable(freq_hz, L: np.ndarray, dt: float, n_integrators: int, n_unstable: int, coeffs=None):
    """Per row, ``Z_out`` and whether the grid resolved the phase (:func:`closed_loop_unstable`)."""
    r = 1.0 + L
    steps = np.angle(r[:, 1:] / r[:, :-1])
    first, first_ok = _first_travel(freq_hz, L, dt, n_integrators, coeffs)
    delta = first + steps.sum(axis=1)
    if coeffs is not None:  # a free denominator can leave the unit disc: count its poles
        n_unstable += controller_unstable_poles(coeffs[1], coeffs[2] if len(coeffs) > 2 else None)
    z_out = n_unstable + n_integrators / 2 - delta / np.pi
    # an exact count is an integer >= 0: anything else means an assumption failed
    whole = (np.abs(z_out - np.rint(z_out)) < 0.25) & (np.rint(z_out) >= 0)
    resolved = np.all(np.abs(steps) < MAX_PHASE_STEP, axis=1) & first_ok & whole
    # 1 + L = 0 on the grid (a closed-loop pole on the unit circle): no count, not stable
    return _pole_count(z_out), resolved & np.isfinite(z_out)


def _pole_count(z_out: np.ndarray) -> np.ndarray:
    """Rounded ``Z_out``; 1 where it is not finite (the loop passes through -1 on the grid:
    a closed-loop pole on the unit circle, counted as one not stable)."""
    finite = np.isfinite(z_out)
    return np.where(finite, np.rint(np.where(finite, z_out, 0.0)), 1.0).astype(int)


def closed_loop_unstable(
    freq_hz: np.ndarray,
    L: np.ndarray,
    dt: float,
    *,
    n_integrators: int,
    n_unstable: int = 0,
    controller_coefficients: tuple[np.ndarray, np.ndarray] | None = None,
    controller_integrators: int | None = None,
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
        Open-loop poles outside the unit disc (the plant's only when
        ``controller_coefficients`` are given).
    controller_coefficients : tuple of ndarray, optional
        The controller's ``x`` and ``y`` in ascending powers of ``z^{-1}``: the loop below
        the first grid point is then the plant's asymptote times the exact controller,
        and the controller's poles outside the unit disc are counted from ``y`` (module
        doc); without them the whole loop is taken at its asymptote there.
    controller_integrators : int, optional
        Roots of ``y`` at ``z = 1`` known from the structure; by default those within
        :data:`UNIT_ROOT_TOL` of ``y(1) = 0`` (the numerator's are never inferred: a
        controller zero at ``z = 1`` leaves a closed-loop pole there, counted not stable).

    Returns
    -------
    tuple of (int, bool)
        ``Z_out`` (0 for a stable loop) and whether the grid resolved every phase step.
    """
    z_out, resolved = _unstable(
        freq_hz,
        np.asarray(L)[None, :],
        dt,
        n_integrators,
        n_unstable,
        _known(controller_coefficients, controller_integrators),
    )
    return int(z_out[0]), bool(resolved[0])


def _loop_rows(freq_hz, L: np.ndarray, dt: float, n_integrators: int, n_unstable: int, coeffs=None):
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
    z_out, resolved = _unstable(freq_hz, L, dt, n_integrators, n_unstable, coeffs)
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
    freq_hz: np.ndarray,
    L: np.ndarray,
    dt: float,
    *,
    n_integrators: int,
    n_unstable: int = 0,
    controller_coefficients: tuple[np.ndarray, np.ndarray] | None = None,
    controller_integrators: int | None = None,
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
        Open-loop poles outside the unit disc (the plant's only when
        ``controller_coefficients`` are given).
    controller_coefficients : tuple of ndarray, optional
        The controller's ``x`` and ``y`` in ascending powers of ``z^{-1}``
        (:func:`closed_loop_unstable`).
    controller_integrators : int, optional
        Roots of ``y`` at ``z = 1`` known from the structure; by default those within
        :data:`UNIT_ROOT_TOL` of ``y(1) = 0`` (the numerator's are never inferred: a
        controller zero at ``z = 1`` leaves a closed-loop pole there, counted not stable).

    Returns
    -------
    LoopRow
        Lowest crossover with its phase margin, gain and delay margins, ``‖S‖∞`` and
        ``‖T‖∞`` [dB] and the count of unstable closed-loop poles.
    """
    L2 = np.asarray(L)[None, :]
    cols = _loop_rows(
        freq_hz,
        L2,
        dt,
        n_integrators,
        n_unstable,
        _known(controller_coefficients, controller_integrators),
    )
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
    controller_coefficients: tuple[np.ndarray, np.ndarray] | None = None,
    controller_integrators: int | None = None,
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
    controller_coefficients : tuple of ndarray, optional
        The controller's ``x`` and ``y`` in ascending powers of ``z^{-1}``
        (:func:`closed_loop_unstable`).
    controller_integrators : int, optional
        Roots of ``y`` at ``z = 1`` known from the structure; by default those within
        :data:`UNIT_ROOT_TOL` of ``y(1) = 0`` (the numerator's are never inferred: a
        controller zero at ``z = 1`` leaves a closed-loop pole there, counted not stable).

    Returns
    -------
    LoopTable
        One row per plant.
    """
    out: list[LoopRow] = []
    for lo in range(0, len(responses), CHUNK):
        L = responses[lo : lo + CHUNK] * controller_response[None, :]
        cols = _loop_rows(
            freq_hz,
            L,
            dt,
            n_integrators,
            n_unstable,
            _known(controller_coefficients, controller_integrators),
        )
        out += _rows_of(cols)
    rows = tuple(out)
    names = names or tuple(str(i) for i in range(len(rows)))
    return LoopTable(rows=rows, names=tuple(names))
