"""Initial controller of the FRF loop-shaping iteration, in the chosen structure.

The convex-concave iteration starts from a controller that stabilises every FRF. A given
controller ``x_0 / y_0`` is written exactly in the structure when ``y_0`` divides the fixed
denominator (``"pid-notch"``) or has the integrator and at most the structure's order
(``"order"``); otherwise its numerator is fitted by least squares on the relative error
``|K - K_0| / |K_0|`` over the grid. Without one, a PI-lead controller
``(s + ω_c/4)/s · (s/(ω_c/3) + 1)/(s/(3ω_c) + 1)`` (Tustin at ``ω_c``) is projected onto the
structure for 25 crossovers ``ω_c`` from Nyquist/300 to Nyquist/4, scaled to ``|P K| = 1`` at
``ω_c`` on the median plant, and the stabilising one of lowest ``‖S‖∞`` is kept.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from servokit._lazy import control
from servokit.errors import ServokitValueError
from servokit.feedback.loopshape_problem import controller_polys

__all__ = ["initial_parameters", "plant_integrators"]


def plant_integrators(freq_hz: np.ndarray, responses: np.ndarray, dt: float) -> int:
    """Plant poles at ``z = 1`` estimated from the low-frequency slope of the FRFs.

    Parameters
    ----------
    freq_hz : ndarray
        Grid [Hz].
    responses : ndarray
        FRFs, shape ``(M, n)``.
    dt : float
        Sampling period [s].

    Returns
    -------
    int
        ``round(-d log|P| / d log|e^{jωT} - 1|)`` over the lowest 5 % of the grid, in 0..4.
    """
    k = max(5, freq_hz.size // 20)
    x = np.log(np.abs(np.exp(2j * np.pi * freq_hz[:k] * dt) - 1.0))
    y = np.mean(np.log(np.abs(responses[:, :k])), axis=0)
    slope = np.polyfit(x, y, 1)[0]
    return int(np.clip(np.rint(-slope), 0, 4))


def _divide(num: np.ndarray, den: np.ndarray) -> np.ndarray | None:
    """Exact quotient ``num / den`` of polynomials in ``z^{-1}`` (ascending), or None."""
    if len(den) > len(num):
        return None
    q, r = np.polydiv(num[::-1], den[::-1])
    if np.max(np.abs(r), initial=0.0) > 1e-8 * np.max(np.abs(num)):
        return None
    return np.asarray(q[::-1], dtype=float)


def _pad(v: np.ndarray, n: int) -> np.ndarray | None:
    v = np.trim_zeros(np.asarray(v, dtype=float), "b")
    return None if len(v) > n else np.concatenate([v, np.zeros(n - len(v))])


def _exact(pb: Any, x0: np.ndarray, y0: np.ndarray) -> np.ndarray | None:
    st = pb.st
    if st.n_den_free == 0:
        q = _divide(st.den_fixed, y0)
        a = None if q is None else _pad(np.convolve(x0, q), st.n_num + 1)
        return a
    q = _divide(y0, st.den_fixed)
    if q is None or abs(q[0] - 1.0) > 1e-9:
        return None
    a, b = _pad(x0, st.n_num + 1), _pad(q[1:], st.n_den_free)
    return None if a is None or b is None else np.concatenate([a, b])


def _fit(pb: Any, K0: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Numerator minimising the relative error to ``K0`` with the denominator fixed by ``b``."""
    basis = pb.basis
    y = basis.Y0 + basis.Vy @ b
    A = basis.Vx / (y * K0)[:, None]
    rows = np.vstack([A.real, A.imag])
    rhs = np.concatenate([np.ones(A.shape[0]), np.zeros(A.shape[0])])
    a = np.linalg.lstsq(rows, rhs, rcond=None)[0]
    return np.concatenate([a, b])


def _pid(wc: float, dt: float) -> control.TransferFunction:
    pid = control.tf([1.0, wc / 4], [1.0, 0.0]) * control.tf([3 / wc, 1.0], [1 / (3 * wc), 1.0])
    return control.sample_system(pid, dt, method="tustin", prewarp_frequency=wc)


def _scan(pb: Any) -> np.ndarray:
    nyq = 0.5 / pb.dt
    zero_b = np.zeros(pb.st.n_den_free)
    best, best_s = None, np.inf
    for fc in np.geomspace(nyq / 300, nyq / 4, 25):
        k0 = _pid(2 * np.pi * fc, pb.dt)
        x0, y0 = controller_polys(k0)
        theta = _exact(pb, x0, y0)
        K0 = np.asarray(k0(np.exp(2j * np.pi * pb.f * pb.dt))).ravel()
        theta = _fit(pb, K0, zero_b) if theta is None else theta
        j = min(np.searchsorted(pb.f, fc), pb.f.size - 1)
        na = pb.st.n_num + 1
        theta[:na] /= np.median(np.abs(pb.P[:, j] * pb.K(theta)[j]))
        ok, tab = pb.ok(theta, np.inf)
        if ok and tab.worst_s_peak_db < best_s:
            best, best_s = theta, tab.worst_s_peak_db
    if best is None:
        # the scan accepts only starts within the ‖T‖∞ bound too: say which bound it was
        within = "" if pb.t_max is None else f" within t_max_db {pb.t_max:g} dB"
        raise ServokitValueError(
            f"no PI-lead controller in the structure stabilises every FRF{within}; give a "
            "stabilising initial controller" + (" or raise t_max_db" if within else "")
        )
    return best


def initial_parameters(pb: Any, initial: control.TransferFunction | None) -> tuple[np.ndarray, str]:
    """Parameters of the starting controller in the structure of ``pb`` (module doc).

    Parameters
    ----------
    pb : _Problem
        The design problem (grid, FRFs, structure).
    initial : control.TransferFunction or None
        A stabilising discrete controller, or None for the PID gain scan.

    Returns
    -------
    tuple of (ndarray, str)
        Parameters and a note saying how they were obtained.
    """
    if initial is None:
        return _scan(pb), "initial controller: PI-lead gain scan"
    if initial.dt is None or not initial.dt or abs(float(initial.dt) - pb.dt) > 1e-12 * pb.dt:
        raise ServokitValueError(f"initial controller must be discrete with dt = {pb.dt:g} s")
    x0, y0 = controller_polys(initial)
    theta = _exact(pb, x0, y0)
    if theta is not None:
        return theta, ""
    K0 = np.asarray(initial(np.exp(2j * np.pi * pb.f * pb.dt))).ravel()
    return _fit(pb, K0, np.zeros(pb.st.n_den_free)), "initial controller fitted to the structure"
