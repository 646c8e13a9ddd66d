"""Fast evaluation of ``yu[ds]`` on sampling-phase grids for :mod:`servokit.sampled.unobservable`.

Holds the machinery behind :func:`~servokit.sampled.unobservable.unobservable_magnitude`:

* undamped rows (4.41): :func:`_undamped_yu` (sorted sample phases, row-wise binary
  search) and :class:`_UndampedGrid`, which sorts the phases once for the grid and the
  zooms of :func:`_refine`;
* damped rows (4.48): :func:`_damped_yu`, bit for bit :func:`_damped_yu_direct` (its
  reference) through :func:`_damped_sample_extrema`;
* :func:`_yu_of` (the ``ds -> yu[ds]`` evaluator of a set of rows) and :func:`_refine`
  (polishing the grid extremum off the grid).

The module constants (:data:`_CHUNK`, :data:`_DIRECT_PHASES`, :data:`_CACHE_ELEMENTS`,
...) size the work arrays and choose between the fast and the direct paths.
"""

from __future__ import annotations

import numpy as np

from servokit.sampled.damped_sine import damped_sine_extrema

#: Number of samples standing for "infinitely many" in the steady state of (4.41).
STEADY_STATE_SAMPLES = 4096

_TWO_PI = 2.0 * np.pi
# Elements of the (frequency, phase, sample) work array handled at once.
_CHUNK = 2_000_000


def _undamped_yu(b: np.ndarray, n: np.ndarray, ds: np.ndarray) -> np.ndarray:
    """``yu`` of (4.41)/(4.48) for ``sin(b s)`` sampled at ``s = n + ds`` (rows: frequencies).

    ``yu = 1 - cos(d)`` with ``d`` the largest circular distance of ``+-pi/2 - b ds`` to the
    sample phases ``b n``, found by a row-wise binary search in the sorted phases.
    """
    rows = max(1, _CHUNK // (n.size + ds.shape[1]))
    if b.size > rows:
        return np.concatenate(
            [_undamped_yu(b[i : i + rows], n, ds[i : i + rows]) for i in range(0, b.size, rows)]
        )
    theta = np.sort(np.mod(b[:, None] * n[None, :], _TWO_PI), axis=1)
    return _undamped_yu_search(b, _search_array(theta), ds)


def _damped_yu(b: np.ndarray, a: np.ndarray, n_samples: int, ds: np.ndarray) -> np.ndarray:
    """``yu`` of (4.48) for ``exp(-a s) sin(b s)``, samples ``n = 1..Ns``, window ``s >= Ns``.

    The same numbers as :func:`_damped_yu_direct` (bit for bit), with six transcendental
    calls per (row, phase) instead of two per (row, phase, sample): see
    :func:`_damped_sample_extrema` (used from :data:`_DIRECT_PHASES` (row, phase) pairs).
    """
    start = float(n_samples)
    scale = np.exp(-a * start)
    cmax, cmin = damped_sine_extrema(a, b, b * start, np.inf)
    cmax, cmin = cmax * scale, cmin * scale
    if ds.size < _DIRECT_PHASES:
        return _damped_yu_direct(b, a, n_samples, ds)  # small: numpy call overhead wins
    ymax, ymin = _damped_sample_extrema(b, a, n_samples, ds)
    return np.maximum(0.0, np.maximum(cmax[:, None] - ymax, -(cmin[:, None] - ymin)))


def _damped_yu_direct(b: np.ndarray, a: np.ndarray, n_samples: int, ds: np.ndarray) -> np.ndarray:
    """Reference of :func:`_damped_yu`: ``exp(-a s) sin(b s)`` on the whole (row, phase,
    sample) grid (the implementation before the demo speed-up; tests compare to it)."""
    start = float(n_samples)
    scale = np.exp(-a * start)
    cmax, cmin = damped_sine_extrema(a, b, b * start, np.inf)
    cmax, cmin = cmax * scale, cmin * scale
    n = np.arange(1, n_samples + 1, dtype=float)
    out = np.empty(ds.shape)
    rows = max(1, _CHUNK // max(1, ds.shape[1] * n_samples))
    for lo in range(0, b.size, rows):
        sl = slice(lo, lo + rows)
        s = n[None, None, :] + ds[sl, :, None]
        yd = np.exp(-a[sl, None, None] * s) * np.sin(b[sl, None, None] * s)
        yup = cmax[sl, None] - yd.max(axis=2)
        yum = cmin[sl, None] - yd.min(axis=2)
        out[sl] = np.maximum(0.0, np.maximum(yup, -yum))
    return out


def _damped_samples(b: np.ndarray, a: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``exp(-a s) sin(b s)`` for rows ``b``, ``a`` (k,) and ``s`` (k, m), evaluated exactly
    as :func:`_damped_yu_direct` does (same operations, so the same rounding)."""
    return np.exp(-a[:, None] * s) * np.sin(b[:, None] * s)


#: Below this many (row, phase) elements :func:`_damped_yu` evaluates the grid directly
#: (fewer numpy calls; the same values).
_DIRECT_PHASES = 1024
#: (row, phase) elements of one block of :func:`_damped_sample_extrema` (cache-sized: a
#: dozen simple passes per sample run over each block).
_BLOCK = 1 << 14
#: ``a (Ns + 1)`` above which a row is evaluated directly (far below exp's underflow, so
#: the relative error bounds of :func:`_damped_sample_extrema` hold wherever it is used).
_DIRECT_DECAY = 600.0


def _direct_extrema(
    b: np.ndarray, a: np.ndarray, n: np.ndarray, ds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Max and min over ``n`` of :func:`_damped_samples` at ``s = n + ds`` (rows of ``ds``
    (k,) belong to ``b``, ``a`` (k,)): the direct evaluation, for the few hard entries."""
    yd = _damped_samples(b, a, n[None, :] + ds[:, None])
    return yd.max(axis=1), yd.min(axis=1)


def _damped_sample_extrema(
    b: np.ndarray, a: np.ndarray, n_samples: int, ds: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``max_n`` and ``min_n`` of ``yd = exp(-a s) sin(b s)``, ``s = n + ds``, ``n = 1..Ns``.

    Angle addition gives ``yd = exp(-a ds) (cos(b ds) S[n] + sin(b ds) K[n])`` with
    ``S, K = exp(-a n) (sin, cos)(b n)``; the positive factor ``exp(-a ds)`` does not move
    the extremum, so two multiply-adds per (row, phase, sample) locate the extremal
    sample, and the value there is evaluated directly (exactly as
    :func:`_damped_yu_direct` evaluates every sample).  The product differs from the
    direct value over ``exp(-a ds)`` by a few ulp of ``1 + (|b| + a) (Ns + 1)``;
    wherever another sample comes within ``margin`` (~500 times that bound) of the
    extremum, and for rows decaying towards underflow, every sample is evaluated
    directly.  The result is the direct grid's max and min, bit for bit.
    """
    n = np.arange(1, n_samples + 1, dtype=float)
    rows_all, n_ph = ds.shape
    ymax = np.empty(ds.shape)
    ymin = np.empty(ds.shape)
    margin_all = 2.0**-40 * (1.0 + (np.abs(b) + a) * (n_samples + 1.0))
    rows = max(1, _BLOCK // max(1, n_ph))
    for lo in range(0, rows_all, rows):
        sl = slice(lo, lo + rows)
        bb, aa, dd = b[sl], a[sl], ds[sl]
        en = np.exp(-aa[:, None] * n)
        bn = bb[:, None] * n
        S = np.ascontiguousarray((en * np.sin(bn)).T)[:, :, None]  # (Ns, rows, 1)
        K = np.ascontiguousarray((en * np.cos(bn)).T)[:, :, None]
        bd = bb[:, None] * dd
        C, D = np.cos(bd), np.sin(bd)
        shape = C.shape
        mx, mx2 = np.full(shape, -np.inf), np.full(shape, -np.inf)
        mn, mn2 = np.full(shape, np.inf), np.full(shape, np.inf)
        kx, kn = np.zeros(shape, np.intp), np.zeros(shape, np.intp)
        v, w = np.empty(shape), np.empty(shape)
        m = np.empty(shape, dtype=bool)
        for j in range(n_samples):
            np.multiply(C, S[j], out=v)
            np.multiply(D, K[j], out=w)
            v += w
            # running max, its index, and the runner-up (likewise for the min)
            np.minimum(mx, v, out=w)
            np.maximum(mx2, w, out=mx2)
            np.greater(v, mx, out=m)
            np.copyto(kx, j, where=m)
            np.maximum(mx, v, out=mx)
            np.maximum(mn, v, out=w)
            np.minimum(mn2, w, out=mn2)
            np.less(v, mn, out=m)
            np.copyto(kn, j, where=m)
            np.minimum(mn, v, out=mn)
        ymax[sl] = _damped_samples(bb, aa, n[kx] + dd)
        ymin[sl] = _damped_samples(bb, aa, n[kn] + dd)
        margin = margin_all[sl, None]
        hard = (mx2 >= mx - margin) | (mn2 <= mn + margin)
        hard |= (aa * (n_samples + 1.0) > _DIRECT_DECAY)[:, None]
        if hard.any():
            r, p = np.nonzero(hard)
            hi, low = _direct_extrema(bb[r], aa[r], n, dd[r, p])
            ymax[lo + r, p], ymin[lo + r, p] = hi, low
    return ymax, ymin


class _UndampedGrid:
    """``yu[ds]`` of :func:`_undamped_yu` for fixed rows ``b`` and samples ``n``, the sorted
    sample phases computed once for all the phase grids asked for (the grid and the
    zooms of :func:`_refine`).

    Every call splits the rows into the same chunks as :func:`_undamped_yu` (they depend
    on the number of phases) and searches each chunk's array built from the cached phases
    exactly as it builds it, so the values are the same bit for bit; the arrays of the
    last chunking are kept too (the four zooms share one).  Without room for the cache
    (more than :data:`_CACHE_ELEMENTS` phases) it calls :func:`_undamped_yu`.
    """

    def __init__(self, b: np.ndarray, n: np.ndarray) -> None:
        self.b, self.n = b, n
        self.theta: np.ndarray | None = None
        self.chunking: tuple[int, list[np.ndarray]] = (0, [])
        if b.size * n.size <= _CACHE_ELEMENTS:
            self.theta = np.empty((b.size, n.size))
            rows = max(1, _CHUNK // (n.size + 1))
            for lo in range(0, b.size, rows):
                sl = slice(lo, lo + rows)
                self.theta[sl] = np.sort(np.mod(b[sl, None] * n[None, :], _TWO_PI), axis=1)

    def __call__(self, ds: np.ndarray) -> np.ndarray:
        if self.theta is None:
            return _undamped_yu(self.b, self.n, ds)
        rows = max(1, _CHUNK // (self.n.size + ds.shape[1]))
        starts = range(0, self.b.size, rows)
        if self.chunking[0] != rows:
            self.chunking = (rows, [_search_array(self.theta[i : i + rows]) for i in starts])
        flats = self.chunking[1]
        return np.concatenate(
            [
                _undamped_yu_search(self.b[i : i + rows], flat, ds[i : i + rows])
                for i, flat in zip(starts, flats, strict=True)
            ]
        )


#: Largest (row x sample) phase array :class:`_UndampedGrid` keeps (32 MB, and as much
#: for the search arrays).
_CACHE_ELEMENTS = 1 << 22


def _search_array(theta: np.ndarray) -> np.ndarray:
    """The rows of sorted phases ``theta`` with wrap-around sentinels, each row shifted by
    ``4 pi`` from the previous one, flattened: one sorted array for the row-wise search."""
    ext = np.concatenate([theta[:, -1:] - _TWO_PI, theta, theta[:, :1] + _TWO_PI], axis=1)
    return (ext + (4.0 * _TWO_PI) * np.arange(theta.shape[0])[:, None]).ravel()


def _undamped_yu_search(b: np.ndarray, flat: np.ndarray, ds: np.ndarray) -> np.ndarray:
    """:func:`_undamped_yu` of one chunk of rows from its :func:`_search_array`."""
    offset = (4.0 * _TWO_PI) * np.arange(b.size)[:, None]
    dist = np.zeros(ds.shape)
    for target in (0.5 * np.pi, -0.5 * np.pi):
        x = np.mod(target - b[:, None] * ds, _TWO_PI) + offset
        idx = np.searchsorted(flat, x.ravel()).reshape(x.shape)
        idx = np.clip(idx, 1, flat.size - 1)
        d = np.minimum(flat[idx] - x, x - flat[idx - 1])
        dist = np.maximum(dist, d)
    return 1.0 - np.cos(np.minimum(dist, np.pi))


def _yu_of(b: np.ndarray, a: np.ndarray, n_samples: int | None):  # noqa: ANN202
    """``ds -> yu[ds]`` for the rows ``b``, ``a`` (rows of ``ds`` belong to them)."""
    if n_samples is None:
        return _UndampedGrid(b, np.arange(STEADY_STATE_SAMPLES, dtype=float))
    if np.all(a == 0.0):
        return _UndampedGrid(b, np.arange(1, n_samples + 1, dtype=float))
    return lambda ds: _damped_yu(b, a, n_samples, ds)


def _refine(
    yu_of,  # noqa: ANN001 - ds -> yu[ds] of the rows (see _yu_of)
    grid: np.ndarray,
    yu: np.ndarray,
    sign: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Polish the grid extremum of ``sign * yu`` by two zooms of 33 phases each."""
    k = np.argmax(sign * yu, axis=1)
    best_ds = grid[k]
    best = yu[np.arange(yu.shape[0]), k]
    half = 1.0 / grid.size
    local = np.linspace(-1.0, 1.0, 33)
    for _ in range(2):
        ds = np.clip(best_ds[:, None] + half * local[None, :], 0.0, np.nextafter(1.0, 0.0))
        vals = yu_of(ds)
        j = np.argmax(sign * vals, axis=1)
        cand = vals[np.arange(vals.shape[0]), j]
        better = sign * cand > sign * best
        best = np.where(better, cand, best)
        best_ds = np.where(better, ds[np.arange(ds.shape[0]), j], best_ds)
        half = half / 16.0
    return best, best_ds
