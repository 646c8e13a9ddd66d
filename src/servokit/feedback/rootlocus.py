"""Root loci of the pseudo open loop G = Sh F (5.19): departure angles and branch margins.

For the characteristic equation 1 + k G(s) = 0 (k ≥ 0, the add-on filter loop of
Fig. 5.11 closes with SF = 1/(1 + Sh F), (5.16)), the root leaving a simple pole p of G
starts as s − p ≈ −k Res_p G, so its departure angle is exactly
``180° + arg Res_p G`` with ``Res_p G = g Π(p − z_i) / Π_{j≠p}(p − p_j)`` — the angle
condition (5.26)-(5.28) without the approximations (5.30)-(5.35).

The gain at which a branch reaches the imaginary axis is found on the frequency
response: a root at jω needs G(jω) real and negative and then k = 1/|G(jω)|. Each such
gain is assigned to the branch that crosses there by following the locus from k = 0
(the branch's starting pole) to that gain on a logarithmic grid, matching roots
between neighbouring gains by minimum total distance (Hungarian assignment; skipped when
every root's strict nearest neighbour forms a permutation, which is then the unique
optimum). :func:`branch_gain_margins` needs the branch order only at the crossing gains:
:func:`tracked_roots` solves every 16th gain of the grid, jumps a coarse step when its
nearest-root match is a permutation and every root moved less than a quarter of the
smallest root separation at both ends, and solves and matches the dense grid inside any
other coarse step, so it returns the dense tracking's rows (bit for bit in the tests on
random stable G with ζ down to 1e-6 and near-double poles). A branch that leaves and
returns within one coarse step without approaching another root is not seen; the dense
tracking would order it the same way.

Polynomials are formed in the normalised variable s/ω_ref (ω_ref the largest pole
magnitude) so that the root finder works on coefficients of order one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError
from servokit.feedback.margins import stability_margins

__all__ = [
    "RootLocus",
    "PeakFilterLocus",
    "departure_angles",
    "root_locus",
    "tracked_roots",
    "branch_gain_margins",
    "peak_filter_locus",
]


def _polys(g: control.TransferFunction) -> tuple[np.ndarray, np.ndarray, float]:
    """Numerator and denominator of G in s/ω_ref, leading denominator coefficient 1."""
    if not isinstance(g, control.TransferFunction):
        g = control.tf(g)
    if g.dt not in (None, 0):
        raise ServokitValueError("root-locus analysis needs a continuous G (dt = 0)")
    num = np.trim_zeros(np.asarray(g.num[0][0], dtype=float), "f")
    den = np.trim_zeros(np.asarray(g.den[0][0], dtype=float), "f")
    if num.size > den.size:
        raise ServokitValueError("G must be proper (numerator degree <= denominator degree)")
    w_ref = float(np.max(np.abs(np.roots(den)))) if den.size > 1 else 1.0
    w_ref = w_ref if w_ref > 0 else 1.0
    scale_d = w_ref ** np.arange(den.size - 1, -1, -1.0)
    scale_n = w_ref ** np.arange(num.size - 1, -1, -1.0)
    nd = den * scale_d
    # numerator in the same normalised variable, divided by the same leading coefficient
    nn = num * scale_n / nd[0]
    return nn, nd / nd[0], w_ref


def departure_angles(g: control.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    """Poles of G and the exact departure angle of the root locus from each.

    Parameters
    ----------
    g : control.TransferFunction
        Continuous open loop G of 1 + k G = 0.

    Returns
    -------
    tuple of (numpy.ndarray, numpy.ndarray)
        The poles and their departure angles [deg] in (−180°, 180]; a repeated pole gives
        NaN (its departure is not defined by one residue).
    """
    g = g if isinstance(g, control.TransferFunction) else control.tf(g)
    poles = np.asarray(g.poles(), dtype=complex)
    zeros = np.asarray(g.zeros(), dtype=complex)
    num = np.trim_zeros(np.asarray(g.num[0][0], dtype=float), "f")
    den = np.trim_zeros(np.asarray(g.den[0][0], dtype=float), "f")
    gain = num[0] / den[0]
    angles = np.empty(poles.size)
    for i, p in enumerate(poles):
        others = np.delete(poles, i)
        if np.any(np.isclose(others, p, rtol=1e-12, atol=0)):
            angles[i] = np.nan
            continue
        res_arg = np.angle(gain) + np.sum(np.angle(p - zeros)) - np.sum(np.angle(p - others))
        angles[i] = np.degrees(np.pi + res_arg)
    return poles, 180.0 - np.mod(180.0 - angles, 360.0)


@dataclass(frozen=True)
class RootLocus:
    """Branches of 1 + k G = 0: ``roots[i, j]`` is branch j at ``gains[i]`` [rad/s]."""

    gains: np.ndarray
    roots: np.ndarray

    @property
    def start(self) -> np.ndarray:
        """The open-loop pole each branch starts from (k → 0)."""
        return self.roots[0]


def _roots_rows(polys: np.ndarray) -> list[np.ndarray]:
    """``np.roots`` of every row of ``polys``, the companion eigenvalues in one batch.

    Rows with a zero leading or trailing coefficient (``np.roots`` strips those) go
    through ``np.roots`` itself; the others build the same companion matrix as
    ``np.roots`` and one stacked ``eigvals`` call (LAPACK ``geev`` per matrix, the same
    values as a call per row, without 800 calls' overhead per locus).
    """
    out: list[np.ndarray | None] = [None] * polys.shape[0]
    n = polys.shape[1] - 1
    plain = (polys[:, 0] != 0) & (polys[:, -1] != 0) if n >= 1 else np.zeros(0, bool)
    idx = np.nonzero(plain)[0]
    if idx.size:
        comp = np.zeros((idx.size, n, n), dtype=polys.dtype)
        comp[:, np.arange(1, n), np.arange(n - 1)] = 1.0
        comp[:, 0, :] = -polys[idx, 1:] / polys[idx, :1]
        for i, r in zip(idx, np.linalg.eigvals(comp), strict=True):
            out[i] = r
    return [np.roots(p) if r is None else r for p, r in zip(polys, out, strict=True)]


def _match(prev: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``r`` reordered to follow ``prev``: the minimum-total-distance assignment.

    When every root of ``prev`` has a strict nearest root of ``r`` and these nearest
    roots form a permutation, that permutation is the unique optimal assignment (each
    row at its strict minimum), which is what ``linear_sum_assignment`` returns; only
    the other steps call it.
    """
    if r.size < prev.size:  # leading coefficient cancelled: a root went to infinity
        r = np.concatenate([r, np.full(prev.size - r.size, np.inf + 0j)])
    cost = np.abs(prev[:, None] - r[None, :])
    cost[~np.isfinite(cost)] = 1e300
    col = np.argmin(cost, axis=1)
    if r.size > 1 and np.all(np.sort(col) == np.arange(r.size)):
        two = np.partition(cost, 1, axis=1)
        if np.all(two[:, 1] > two[:, 0]):
            return r[col]
    from scipy.optimize import linear_sum_assignment

    return r[linear_sum_assignment(cost)[1]]


def _match_index(prev: np.ndarray, r: np.ndarray) -> np.ndarray:
    """The indices ``i`` with ``_match(prev, r) == r[i]`` (``r`` and ``prev`` finite, one size)."""
    cost = np.abs(prev[:, None] - r[None, :])
    col = np.argmin(cost, axis=1)
    if r.size > 1 and np.all(np.sort(col) == np.arange(r.size)):
        two = np.partition(cost, 1, axis=1)
        if np.all(two[:, 1] > two[:, 0]):
            return col
    from scipy.optimize import linear_sum_assignment

    return linear_sum_assignment(cost)[1]


def _match_run(prev: np.ndarray, rows: list[np.ndarray]) -> list[np.ndarray]:
    """``[_match(prev, rows[0]), _match(<that>, rows[1]), ...]``: the same arrays, batched.

    A matched row is a permutation of its solved row, so the cost matrix of a step is a
    row permutation of the one between consecutive *solved* rows: the nearest-root
    columns and the strictness test of :func:`_match` can be computed for every step in
    one batch and composed (``perm_t = col_t[perm_{t-1}]``); only the steps whose
    nearest roots are not a strict permutation go through the assignment, with the
    tracked predecessor.  Every entry is an element of its solved row, picked by the
    same comparisons, so the rows are those of the step-by-step loop bit for bit
    (issue 24: 8863 calls of :func:`_match`, 0.2 s of the peak-filter case).  Rows of
    another size or with non-finite roots take the step-by-step loop.
    """
    n = prev.size
    if not rows or n < 2 or any(r.size != n for r in rows):
        return _match_loop(prev, rows)
    R = np.array(rows)
    if not (np.all(np.isfinite(R)) and np.all(np.isfinite(prev))):
        return _match_loop(prev, rows)
    cost = np.abs(np.concatenate([prev[None], R[:-1]])[:, :, None] - R[:, None, :])
    col = np.argmin(cost, axis=2)
    two = np.partition(cost, 1, axis=2)
    fast = np.all(np.sort(col, axis=1) == np.arange(n), axis=1) & np.all(
        two[..., 1] > two[..., 0], axis=1
    )
    out = []
    perm = np.arange(n)  # prev (tracked) = prev[perm]; then each tracked row = R[t][perm]
    for t in range(R.shape[0]):
        base = prev if t == 0 else R[t - 1]
        perm = col[t][perm] if fast[t] else _match_index(base[perm], R[t])
        out.append(R[t][perm])
    return out


def _match_loop(prev: np.ndarray, rows: list[np.ndarray]) -> list[np.ndarray]:
    """:func:`_match` step by step (the reference of :func:`_match_run`)."""
    out = []
    for r in rows:
        prev = _match(prev, r)
        out.append(prev)
    return out


def _gains_polys(
    g: control.TransferFunction, gains: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Sorted gains with k = 0 first, the polynomials ``den + k num`` of their rows, the
    open-loop denominator and ω_ref (all in s/ω_ref)."""
    nn, nd, w_ref = _polys(g)
    k = np.unique(np.concatenate([[0.0], np.asarray(gains, dtype=float)]))
    if k[0] < 0:
        raise ServokitValueError("root-locus gains must be >= 0")
    pad = np.concatenate([np.zeros(nd.size - nn.size), nn])
    return k, nd[None, :] + k[:, None] * pad[None, :], nd, w_ref


def root_locus(g: control.TransferFunction, gains: np.ndarray) -> RootLocus:
    """Closed-loop roots of 1 + k G = 0 for increasing ``gains`` (k ≥ 0), branches tracked.

    Parameters
    ----------
    g : control.TransferFunction
        Continuous, proper open loop G.
    gains : numpy.ndarray
        Gains k >= 0 (k = 0 is prepended if absent).

    Returns
    -------
    RootLocus
        Gains and tracked roots; the first row holds the open-loop poles.
    """
    k, polys, nd, w_ref = _gains_polys(g, gains)
    rows = [np.roots(nd)]
    rows += _match_run(rows[0], _roots_rows(polys[1:]))
    return RootLocus(gains=k, roots=np.array(rows) * w_ref)


def _min_gaps(rows: list[np.ndarray]) -> list[float]:
    """Smallest distance between two roots of each row (inf for fewer than two)."""
    out = []
    for r in rows:
        d = np.abs(r[:, None] - r[None, :])
        np.fill_diagonal(d, np.inf)
        out.append(float(np.min(d)) if r.size > 1 else np.inf)
    return out


def _clear_jump(prev: np.ndarray, r: np.ndarray, gap: float) -> np.ndarray | None:
    """``r`` matched to ``prev`` when the match is unambiguous, else None.

    Unambiguous: the same number of finite roots, the nearest roots form a permutation,
    and every root moved less than a quarter of ``gap`` (the smallest root separation at
    either end), so the nearest root is the only candidate and the steps of a dense
    grid in between match the same way.
    """
    if r.size != prev.size or not (np.all(np.isfinite(r)) and np.all(np.isfinite(prev))):
        return None
    cost = np.abs(prev[:, None] - r[None, :])
    col = np.argmin(cost, axis=1)
    if np.any(np.sort(col) != np.arange(r.size)):
        return None
    if r.size > 1 and np.max(cost[np.arange(r.size), col]) >= 0.25 * gap:
        return None
    return r[col]


def tracked_roots(
    g: control.TransferFunction, gains: np.ndarray, at: np.ndarray, *, stride: int = 16
) -> np.ndarray:
    """Rows of ``root_locus(g, gains).roots`` at the gains ``at``, computed sparsely.

    The locus is solved on every ``stride``-th gain (and at ``at``); a coarse step whose
    match is unambiguous (:func:`_clear_jump`) is taken in one jump, any other coarse
    interval is solved and matched on every gain of the dense grid, as
    :func:`root_locus` does. The branch order is that of the dense tracking.

    Parameters
    ----------
    g : control.TransferFunction
        Continuous, proper open loop G.
    gains : numpy.ndarray
        The dense gain grid of :func:`root_locus` (k >= 0).
    at : numpy.ndarray
        Gains (members of ``gains`` or 0) at which the tracked roots are wanted.
    stride : int
        Dense grid points per coarse step.

    Returns
    -------
    numpy.ndarray
        ``roots[i, j]``: branch j at ``at[i]`` [rad/s]; branch j starts at
        ``root_locus(g, gains).start[j]``.
    """
    k, polys, nd, w_ref = _gains_polys(g, gains)
    want = np.searchsorted(k, np.asarray(at, dtype=float))
    coarse = np.unique(np.concatenate([np.arange(0, k.size, stride), [k.size - 1], want]))
    raw = dict(zip(coarse, [np.roots(nd), *_roots_rows(polys[coarse[1:]])], strict=True))
    gaps = dict(zip(coarse, _min_gaps(list(raw.values())), strict=True))
    rows = {0: raw[0]}
    prev = rows[0]
    for a, b in zip(coarse[:-1], coarse[1:], strict=True):
        # the separation is that of the solved roots, whatever their branch order
        gap = min(gaps[a], gaps[b])
        jump = _clear_jump(prev, raw[b], gap) if b > a + 1 else None
        if jump is None:
            prev = _match_run(prev, _roots_rows(polys[a + 1 : b + 1]))[-1]
        else:
            prev = jump
        rows[b] = prev
    return np.array([rows[i] for i in want]) * w_ref


def branch_gain_margins(
    g: control.TransferFunction, *, n_gain: int = 800, k_max: float = 1e8
) -> tuple[np.ndarray, np.ndarray]:
    """Gain k at which each root-locus branch first reaches the imaginary axis.

    The crossing gains come from the frequency response (k = 1/|G(jω)| where G(jω) < 0),
    the branch from tracking.

    Parameters
    ----------
    g : control.TransferFunction
        Stable continuous G.
    n_gain : int
        Points of the tracking grid.
    k_max : float
        Largest gain considered.

    Returns
    -------
    tuple of (numpy.ndarray, numpy.ndarray)
        Start poles and critical gains; ``inf`` for a branch that stays in the open left
        half-plane for all k <= ``k_max``.
    """
    if np.any(np.real(control.tf(g).poles()) >= 0):
        raise ServokitValueError("G must be stable (all poles in the open left half-plane)")
    m = stability_margins(g)
    k_cross = 10.0 ** (np.asarray(m.gain_margins_db) / 20.0)
    w_cross = 2.0 * np.pi * np.asarray(m.phase_crossovers_hz)
    keep = k_cross <= k_max
    k_cross, w_cross = k_cross[keep], w_cross[keep]
    crit = np.full(len(control.tf(g).poles()), np.inf)
    if k_cross.size == 0:
        return np.asarray(control.tf(g).poles(), dtype=complex), crit
    grid = np.geomspace(1e-8 * k_cross.min(), k_cross.max(), n_gain)
    gains = np.concatenate([grid, k_cross])
    start, *at_cross = tracked_roots(g, gains, np.concatenate([[0.0], k_cross]))
    for kc, wc, row in zip(k_cross, w_cross, at_cross, strict=True):
        j = int(np.argmin(np.abs(row - 1j * wc)))
        if abs(row[j] - 1j * wc) > 1e-3 * max(wc, 1.0):  # conjugate branch crosses at -jω
            j = int(np.argmin(np.abs(row + 1j * wc)))
        crit[j] = min(crit[j], kc)
    # a conjugate branch crosses at the same gain as its partner
    for j, p in enumerate(start):
        mate = int(np.argmin(np.abs(start - np.conj(p))))
        crit[j] = crit[mate] = min(crit[j], crit[mate])
    return start, crit


@dataclass(frozen=True)
class PeakFilterLocus:
    """Root-locus facts of G = Sh F for one peak filter (upper-half-plane poles).

    Gains are critical values of the multiplier k on F (1 + k Sh F = 0); divide by the
    designed filter gain for a margin relative to the design.
    """

    filter_pole: complex
    plant_pole: complex
    filter_departure_deg: float
    plant_departure_deg: float
    filter_k_crit: float
    plant_k_crit: float

    @property
    def k_crit(self) -> float:
        """The smallest critical multiplier of the two branches."""
        return min(self.filter_k_crit, self.plant_k_crit)

    def to_dict(self) -> dict[str, float]:
        """Critical multipliers and departure angles [deg] (JSON-ready)."""
        return {
            "filter_k_crit": self.filter_k_crit,
            "plant_k_crit": self.plant_k_crit,
            "filter_departure_deg": self.filter_departure_deg,
            "plant_departure_deg": self.plant_departure_deg,
        }


def peak_filter_locus(
    sh: control.TransferFunction, flt: control.TransferFunction, plant_hz: float
) -> PeakFilterLocus:
    """Departure angles and branch gain margins of the filter pole and of the pseudo-plant
    pole nearest ``plant_hz`` (Figs. 5.12-5.22).

    Parameters
    ----------
    sh : control.TransferFunction
        Continuous pseudo plant.
    flt : control.TransferFunction
        The peak filter F (its gain is the reference of the critical multipliers).
    plant_hz : float
        Frequency near which the pseudo-plant pole of interest lies [Hz].

    Returns
    -------
    PeakFilterLocus
        Poles, departure angles and critical multipliers.
    """
    g = control.tf(sh) * control.tf(flt)
    poles, angles = departure_angles(g)
    starts, k_crit = branch_gain_margins(g)
    p_f = complex(max(control.tf(flt).poles(), key=lambda p: p.imag))
    sh_poles = np.asarray(control.tf(sh).poles(), dtype=complex)
    p_h = complex(sh_poles[np.argmin(np.abs(sh_poles - 2j * np.pi * plant_hz))])
    if p_h.imag < 0:
        p_h = p_h.conjugate()

    def pick(values: np.ndarray, where: np.ndarray, p: complex) -> float:
        return float(values[int(np.argmin(np.abs(where - p)))])

    return PeakFilterLocus(
        filter_pole=p_f,
        plant_pole=p_h,
        filter_departure_deg=pick(angles, poles, p_f),
        plant_departure_deg=pick(angles, poles, p_h),
        filter_k_crit=pick(k_crit, starts, p_f),
        plant_k_crit=pick(k_crit, starts, p_h),
    )
