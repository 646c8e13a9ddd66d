"""Fitting a modal plant with delay to a measured frequency response (FRF).

:func:`fit_modal` returns a :class:`ModalFit` whose ``.plant`` is the book's modal
plant (eq. 2.73), ``P(s) = K sum_i A_i / (s^2 + 2 zeta_i w_i s + w_i^2) exp(-s Td)``,
fitted to ``(freq_hz, response)``.  The steps:

1. **Delay** from the phase slope: the median of ``-d(phase)/d(omega)`` over the upper
   half of the band, taken across a few points at a time (resonances move the phase only
   inside their bandwidths, so the median sees the delay's constant slope).
2. **Poles** by AAA rational approximation (Nakatsukasa, Sete & Trefethen 2018,
   :class:`scipy.interpolate.AAA`) of the delay-compensated response, times ``(jw)^2``
   when a rigid body is fitted (a flat function approximates best).  Lightly damped
   poles inside the band are the candidate modes, ranked by their peak contribution
   relative to the data (linear least squares for the residues).
3. **Nonlinear least squares** (:func:`scipy.optimize.least_squares`, trust-region,
   analytic Jacobian; :mod:`servokit.models._modal_nls`) of the relative error on
   ``log w_i``, ``log zeta_i``, ``K A_i`` and ``Td``, for 0, 1, 2, ... of the ranked
   candidates.
4. **Mode count** by the Bayesian information criterion
   ``BIC = N ln(RSS / N) + k ln N`` (``N`` real residuals, ``k`` parameters).

Parameter uncertainties are the standard deviations of the linearised covariance
``s^2 (J^T J)^-1`` at the optimum (``s^2 = RSS / (N - k)``), mapped to natural units.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Literal

import numpy as np

from servokit.errors import ServokitValueError, check_count
from servokit.models._modal_nls import Layout, _basis, linear_residues, solve
from servokit.models.modal import ModalPlant, Mode

__all__ = ["BandError", "ModalFit", "fit_modal", "delay_from_phase"]

#: Default largest number of resonances "auto" tries (``max_modes``).
MAX_AUTO_MODES = 12


@dataclass(frozen=True)
class BandError:
    """Relative FRF error |G - H| / |H| of a fit in one frequency band.

    Parameters
    ----------
    f_low_hz, f_high_hz : float
        Band edges [Hz].
    n_points : int
        Data points in the band.
    median, rms, max : float
        Median, root-mean-square and largest relative error.
    """

    f_low_hz: float
    f_high_hz: float
    n_points: int
    median: float
    rms: float
    max: float


@dataclass(frozen=True)
class ModalFit:
    """A modal plant fitted to an FRF (:func:`fit_modal`).

    Parameters
    ----------
    plant : ModalPlant
        The fitted plant (rigid body first, then modes by frequency; gain ``K`` is the
        rigid-body residue when there is one, else the largest ``|K A_i|``).
    freq_hz : numpy.ndarray
        Data frequencies used (inside the band) [Hz].
    response : numpy.ndarray
        Data at ``freq_hz``.
    model : numpy.ndarray
        ``plant.freqresp(freq_hz)``.
    freq_std_hz, damping_std, gain_residue_std : numpy.ndarray
        One standard deviation of each mode's frequency [Hz], damping ratio and
        ``K A_i`` (linearised, from the Jacobian), in the order of ``plant.modes``;
        0 for the rigid body's (fixed) frequency and damping.
    delay_std_s : float
        Standard deviation of the delay [s] (0 when the delay was fixed).
    bands : tuple of BandError
        The error per octave band.
    noise_rel : float
        RMS relative residual, corrected for the fitted parameters (an estimate of the
        data's relative noise when the model is right).
    bic : dict
        BIC of every mode count tried (lower is better).
    friction : bool
        Whether the first flexible mode is the low-frequency friction mode.
    """

    plant: ModalPlant
    freq_hz: np.ndarray
    response: np.ndarray
    model: np.ndarray
    freq_std_hz: np.ndarray
    damping_std: np.ndarray
    gain_residue_std: np.ndarray
    delay_std_s: float
    bands: tuple[BandError, ...]
    noise_rel: float
    bic: dict[int, float]
    friction: bool = False

    @property
    def rel_error(self) -> np.ndarray:
        """|model - data| / |data| at each frequency."""
        return np.abs(self.model - self.response) / np.abs(self.response)

    @property
    def median_error(self) -> float:
        """Median relative FRF error over the band."""
        return float(np.median(self.rel_error))

    @property
    def n_modes(self) -> int:
        """Number of fitted resonances (rigid body and friction mode not counted)."""
        return sum(1 for m in self.plant.modes if m.freq_hz > 0) - int(self.friction)


def delay_from_phase(freq_hz: np.ndarray, response: np.ndarray) -> float:
    """Input delay [s] from the phase slope over the upper half of the band (step 1 above).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequencies [Hz], increasing.
    response : numpy.ndarray
        Complex FRF.

    Returns
    -------
    float
        ``max(0, median(-d phase / d omega))`` over the upper half of the points, slopes
        taken across ``n/50`` points (at least 1) to average the noise.
    """
    omega = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    phase = np.unwrap(np.angle(response))
    half = omega.size // 2
    k = max(1, omega.size // 50)
    w, p = omega[half:], phase[half:]
    if w.size <= k:
        return 0.0
    slopes = (p[k:] - p[:-k]) / (w[k:] - w[:-k])
    return max(0.0, float(-np.median(slopes)))


def _has_rigid_body(freq_hz: np.ndarray, response: np.ndarray) -> bool:
    """A rigid body makes the low end fall at about -40 dB/decade (below -30 accepted)."""
    n = max(3, freq_hz.size // 10)
    slope = np.polyfit(np.log10(freq_hz[:n]), 20 * np.log10(np.abs(response[:n])), 1)[0]
    return bool(slope < -30.0)


def _candidates(
    omega: np.ndarray, H: np.ndarray, T0: float, rigid: bool, n_max: int
) -> list[tuple[float, float]]:
    """Candidate modes ``(w [rad/s], zeta)`` from AAA poles, most significant first."""
    from scipy.interpolate import AAA

    s = 1j * omega
    g = H * np.exp(s * T0) * (s**2 if rigid else 1.0)
    w_ref = omega[-1]
    with warnings.catch_warnings():  # noisy data never meets rtol: max_terms stops AAA
        warnings.simplefilter("ignore", RuntimeWarning)
        aaa = AAA(s / w_ref, g / np.median(np.abs(g)), rtol=1e-3, max_terms=4 * n_max + 8)
    poles = aaa.poles() * w_ref
    w = np.abs(poles)
    z = -poles.real / np.where(w > 0, w, 1.0)
    # a pole narrower than the local grid spacing cannot be told from noise (AAA puts
    # such poles between points); the data has a few points per bandwidth
    spacing = np.interp(w, omega[1:], np.diff(omega))
    keep = (poles.imag > 0) & (z < 0.5) & (w > omega[0]) & (w < omega[-1])
    keep &= 2.0 * z * w >= spacing
    if not np.any(keep):
        return []
    cw, cz = w[keep], z[keep]
    layout = Layout(cw.size, rigid, fit_delay=False, delay=T0)
    b = linear_residues(layout, cw, cz, T0, omega, H)[int(rigid) :]
    # energy of each mode's contribution relative to the data, on the data grid
    contrib = b / (cw**2 - omega[:, None] ** 2 + 2j * cz * cw * omega[:, None])
    energy = np.sum(np.abs(contrib / H[:, None]) ** 2, axis=0)
    out: list[tuple[float, float]] = []
    for i in np.argsort(-energy):  # a weaker pole inside a stronger one's bandwidth is noise
        if all(abs(cw[i] - w) > 2.0 * max(cz[i] * cw[i], z * w) for w, z in out):
            out.append((float(cw[i]), float(cz[i])))
    return out


def _delay_scan(
    omega: np.ndarray, H: np.ndarray, modes: list[tuple[float, float]], rigid: bool, t_max: float
) -> float:
    """Delay minimising the relative error of the best residues for fixed candidate poles.

    Variable projection over the one nonlinear parameter the poles do not fix: a grid
    of 200 delays in [0, t_max], then the best grid point.
    """
    layout = Layout(len(modes), rigid, fit_delay=False)
    w = np.array([m[0] for m in modes])
    z = np.array([m[1] for m in modes])
    basis = _basis(layout, omega, w, z) / np.abs(H)[:, None]
    rhs = H / np.abs(H)
    best, best_rss = 0.0, np.inf
    for T in np.linspace(0.0, t_max, 200):
        A = np.exp(-1j * omega * T)[:, None] * basis
        A2 = np.vstack([A.real, A.imag])
        b2 = np.concatenate([rhs.real, rhs.imag])
        sol = np.linalg.lstsq(A2, b2, rcond=None)[0]
        rss = float(np.sum((A2 @ sol - b2) ** 2))
        if rss < best_rss:
            best, best_rss = float(T), rss
    return best


def _bounds(layout: Layout, omega: np.ndarray, friction: bool, t_max: float):
    n, nb = layout.n_modes, layout.n_b
    lo_w = np.full(n, np.log(omega[0] / 2.0))
    hi_w = np.full(n, np.log(omega[-1] * 1.5))
    lo_z, hi_z = np.full(n, np.log(1e-7)), np.full(n, np.log(2.0))
    if friction:  # the first flexible mode is the low-frequency friction mode
        lo_w[0], hi_w[0] = np.log(2 * np.pi * 1e-3), np.log(omega[0] * 4.0)
        hi_z[0] = np.log(100.0)
    lo = np.concatenate([lo_w, lo_z, np.full(nb, -np.inf)] + ([[0.0]] if layout.fit_delay else []))
    hi = np.concatenate([hi_w, hi_z, np.full(nb, np.inf)] + ([[t_max]] if layout.fit_delay else []))
    return lo, hi


@dataclass(frozen=True)
class _Trial:
    layout: Layout
    theta: np.ndarray
    residual: np.ndarray
    jac: np.ndarray
    bic: float


def _trial(
    omega: np.ndarray,
    H: np.ndarray,
    modes: list[tuple[float, float]],
    rigid: bool,
    delay: float | None,
    T0: float,
    t_max: float,
    friction: bool,
) -> _Trial:
    layout = Layout(len(modes), rigid, fit_delay=delay is None, delay=delay or 0.0)
    w = np.array([m[0] for m in modes])
    z = np.array([m[1] for m in modes])
    T = T0 if delay is None else delay
    b = linear_residues(layout, w, z, T, omega, H)
    theta, r, J = solve(
        layout, layout.join(w, z, b, T), omega, H, _bounds(layout, omega, friction, t_max)
    )
    N, k = 2 * omega.size, theta.size
    rss = float(np.sum(np.abs(r) ** 2))
    return _Trial(layout, theta, r, J, N * np.log(rss / N) + k * np.log(N))


def _band_errors(freq_hz: np.ndarray, rel: np.ndarray) -> tuple[BandError, ...]:
    edges = freq_hz[0] * 2.0 ** np.arange(0, np.log2(freq_hz[-1] / freq_hz[0]) + 1)
    edges = np.append(edges[edges < freq_hz[-1]], freq_hz[-1] * (1 + 1e-12))
    out = []
    for lo, hi in zip(edges[:-1], edges[1:], strict=True):
        e = rel[(freq_hz >= lo) & (freq_hz < hi)]
        if e.size:
            out.append(
                BandError(
                    float(lo),
                    float(min(hi, freq_hz[-1])),
                    int(e.size),
                    float(np.median(e)),
                    float(np.sqrt(np.mean(e**2))),
                    float(e.max()),
                )
            )
    return tuple(out)


def _std(t: _Trial) -> np.ndarray:
    """Linearised standard deviations of theta: s^2 (J^T J)^-1 through the SVD of J."""
    N, k = t.jac.shape
    s2 = float(np.sum(np.abs(t.residual) ** 2)) / max(N - k, 1)
    _, sv, vt = np.linalg.svd(t.jac, full_matrices=False)
    sv = np.where(sv > sv[0] * 1e-12, sv, np.inf)  # unidentifiable directions: no info
    return np.sqrt(s2 * np.sum((vt / sv[:, None]) ** 2, axis=0))


def _check(freq_hz: object, response: object, band: tuple[float, float] | None):
    f = np.asarray(freq_hz, dtype=float)
    H = np.asarray(response, dtype=complex)
    if f.ndim != 1 or f.shape != H.shape:
        raise ServokitValueError("freq_hz and response must be vectors of the same length")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(H))):
        raise ServokitValueError("freq_hz and response must be finite")
    if np.any(np.diff(f) <= 0) or f[0] <= 0:
        raise ServokitValueError("freq_hz must be > 0 and strictly increasing")
    if band is not None:
        lo, hi = band
        if not 0 <= lo < hi:
            raise ServokitValueError(
                f"band must be (f_low_hz, f_high_hz) with 0 <= low < high, got {band}"
            )
        sel = (f >= lo) & (f <= hi)
        f, H = f[sel], H[sel]
    if np.any(H == 0):
        raise ServokitValueError("response has exact zeros; the relative error is undefined")
    if f.size < 10:
        raise ServokitValueError(f"{f.size} points in the band; a fit needs at least 10")
    return f, H


def fit_modal(
    freq_hz: np.ndarray,
    response: np.ndarray,
    *,
    n_modes: int | Literal["auto"] = "auto",
    delay: float | Literal["auto"] = "auto",
    rigid_body: bool | Literal["auto"] = "auto",
    friction: bool = False,
    band: tuple[float, float] | None = None,
    max_delay: float | None = None,
    max_modes: int = MAX_AUTO_MODES,
    name: str = "fitted",
    started: Callable[[str], None] | None = None,
) -> ModalFit:
    """Fit a modal plant with delay (eq. 2.73) to an FRF (method in the module docstring).

    Parameters
    ----------
    freq_hz : numpy.ndarray
        Frequencies [Hz], > 0 and increasing (e.g. from :func:`~servokit.models.read_frf`).
    response : numpy.ndarray
        Complex FRF at ``freq_hz`` (no exact zeros).
    n_modes : int or "auto"
        Number of resonances; "auto" chooses 0..``max_modes`` by BIC.
    delay : float or "auto"
        Input delay [s]: fitted ("auto") or fixed.
    rigid_body : bool or "auto"
        Fit a rigid-body mode ``K/s^2``; "auto" when the low end falls at -40 dB/decade.
    friction : bool
        Replace the rigid body by a low-frequency mode with free frequency and damping
        (pivot friction or a spring), fitted below the band's first resonance.
    band : (float, float), optional
        Use only data with ``f_low_hz <= freq_hz <= f_high_hz``.
    max_delay : float, optional
        Upper bound of the fitted delay [s]; default ``5 / f_max``.
    max_modes : int
        Largest number of resonances ``n_modes="auto"`` tries.
    name : str
        Name of the fitted plant.
    started : callable, optional
        Called with a one-line description once the data and arguments are checked,
        before the fit (whose SciPy imports are most of a small fit's time: a command's
        start line, issue 23).

    Returns
    -------
    ModalFit
        The plant, the data and model, per-parameter standard deviations, per-octave
        errors and the BIC of every mode count tried.
    """
    from threadpoolctl import threadpool_limits

    f, H = _check(freq_hz, response, band)
    if n_modes != "auto":
        n_modes = check_count("n_modes", n_modes, lo=0)
    max_modes = check_count("max_modes", max_modes, lo=0)
    if started is not None:
        what = "0.." + str(max_modes) if n_modes == "auto" else str(n_modes)
        started(f"fitting {what} resonance(s) to {f.size} points")
    # small dense problems: BLAS threads only contend (a loaded 2-core box ran 50x slower)
    with threadpool_limits(limits=1):
        return _fit(f, H, n_modes, delay, rigid_body, friction, max_delay, max_modes, name)


def _fit(f, H, n_modes, delay, rigid_body, friction, max_delay, max_modes, name) -> ModalFit:  # noqa: ANN001
    omega = 2.0 * np.pi * f
    rigid = _has_rigid_body(f, H) if rigid_body == "auto" else bool(rigid_body)
    rigid = rigid and not friction
    fixed = None if delay == "auto" else float(delay)
    if fixed is not None and fixed < 0:
        raise ServokitValueError(f"delay must be >= 0 s or 'auto' (got {fixed})")
    t_max = 5.0 / f[-1] if max_delay is None else float(max_delay)
    T0 = min(delay_from_phase(f, H), t_max) if fixed is None else fixed
    n_max = int(max_modes) if n_modes == "auto" else int(n_modes)
    low = [(omega[0], 0.7)] if friction else []  # the friction mode's start
    cands = _candidates(omega, H, T0, rigid or friction, n_max)
    if fixed is None and cands:
        T0 = _delay_scan(omega, H, low + cands[:n_max], rigid, t_max)
    if n_modes != "auto" and len(cands) < n_max:
        raise ServokitValueError(
            f"found {len(cands)} resonance(s) in the data, fewer than n_modes={n_max}; "
            "lower n_modes or use 'auto'"
        )
    fit = partial(_trial, omega, H, rigid=rigid, delay=fixed, T0=T0, t_max=t_max, friction=friction)
    if n_modes != "auto":
        trials = {n_max: fit(low + cands[:n_max])}
    else:
        trials = _auto_count(fit, low, cands[:n_max])
    best = min(trials, key=lambda n: trials[n].bic)
    chosen = _prune(fit, trials[best], len(low)) if n_modes == "auto" else trials[best]
    return _result(f, H, chosen, friction, name, {n: t.bic for n, t in trials.items()})


def _auto_count(fit, low: list, cands: list) -> dict[int, _Trial]:  # noqa: ANN001
    """Trials with 0, 1, 2, ... of the ranked candidates, each started from the candidates
    and the scanned delay (a start from the previous optimum lets modes wander onto
    neighbours and the delay absorb missing modes); stops once the BIC has not improved
    twice."""
    trials = {0: fit(low)}
    best = 0
    for n in range(1, len(cands) + 1):
        trials[n] = fit(low + cands[:n])
        if trials[n].bic < trials[best].bic:
            best = n
        elif n - best >= 2:
            break
    return trials


def _prune(fit, t: _Trial, n_low: int) -> _Trial:  # noqa: ANN001
    """Drop resonances whose removal lowers the BIC (a mode that fitted nothing)."""
    improved = True
    while improved and t.layout.n_modes > n_low:
        improved = False
        w, z, _, T = t.layout.split(t.theta)
        modes = list(zip(w, z, strict=True))
        for i in range(n_low, len(modes)):
            trial = fit(modes[:i] + modes[i + 1 :], T0=T)
            if trial.bic < t.bic:
                t, improved = trial, True
                break
    return t


def _result(f, H, t: _Trial, friction: bool, name: str, bic: dict[int, float]) -> ModalFit:  # noqa: ANN001
    w, z, b, T = t.layout.split(t.theta)
    std = _std(t)
    n, r = t.layout.n_modes, int(t.layout.rigid)
    sw, sz = std[:n] * w, std[n : 2 * n] * z  # d/dlog x = x d/dx
    sb = std[2 * n : 2 * n + t.layout.n_b]
    rows = [(0.0, 0.0, b[0], 0.0, 0.0, sb[0])] if r else []
    rows += sorted(
        (w[i] / (2 * np.pi), z[i], b[r + i], sw[i] / (2 * np.pi), sz[i], sb[r + i])
        for i in range(n)
    )
    gain = b[0] if r else float(max(abs(x) for x in b))
    plant = ModalPlant(
        gain=float(gain),
        modes=tuple(Mode(fr, zz, bb / gain) for fr, zz, bb, *_ in rows),
        delay=float(T),
        name=name,
        source="fit_modal" + (" + friction mode" if friction else ""),
    )
    model = plant.freqresp(f)
    rel = np.abs(model - H) / np.abs(H)
    N, k = 2 * f.size, t.theta.size
    return ModalFit(
        plant=plant,
        freq_hz=f,
        response=H,
        model=model,
        freq_std_hz=np.array([x[3] for x in rows]),
        damping_std=np.array([x[4] for x in rows]),
        gain_residue_std=np.array([x[5] for x in rows]),
        delay_std_s=float(std[-1]) if t.layout.fit_delay else 0.0,
        bands=_band_errors(f, rel),
        noise_rel=float(np.sqrt(np.sum(rel**2) / max(N / 2 - k / 2, 1))),
        bic=bic,
        friction=friction,
    )
