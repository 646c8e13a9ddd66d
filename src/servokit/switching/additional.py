"""IVC by an additional input r' (book §3.3.2, (3.38)-(3.64)).

The controller state is cleared (``xc[0] = 0``) and ``r'[z] = n_k[z]/d[z] xp_k[0]`` is added
to the control input (``Bu = [Bp; 0]``, (3.39)). The free output from ``xp_k[0]`` is
(3.43) ``y0k = (Npk d + Nru n_k) / (D d)`` with ``Npk/D = C (zI-A)^{-1} z e_k`` and
``Nru/D = C (zI-A)^{-1} Bu``. For a simple closed-loop root ``lam_i`` with left/right
eigenvectors ``w_i``, ``v_i`` both numerators are the residues times the same non-zero
factor, so the cancellation conditions (3.44) read

    lam_i (w_i^H e_k) d(lam_i) + (w_i^H Bu) n_k(lam_i) = 0,   i = 1..n+m,

linear in the coefficients ``a`` of ``n_k`` (3.45): the Vandermonde system (3.46)-(3.47)
``Sigma a = Gamma`` without adjugates. ``g = n + m - 1`` gives a unique ``a``.

``d[z]``: the assigned pole ``p`` times, as the book's §3.3.2 pole list implies, the
roots of ``Nru`` inside the unit circle (the controller poles and stable plant zeros).
Those roots then cancel in ``y0k`` and the free response is first order,
``y0k = (q1 z + q0)/(z - p)``: ``y[k+1] = p y[k]`` for k >= 1 (Fig. 3.11). Where those
roots are fewer than ``g``, d[z] gets poles at z = 0 so that r' stays proper; the
response is then first order after as many samples as poles were added.

Optimised form ((3.48)-(3.64)): with ``g + 1 > n + m`` coefficients, minimise
``J = q1 |U0k|^2 + q2 |Md U0k|^2`` over the first N samples of the input under
``Sigma a = Gamma``. ``U0k = Mu V0 a + Ui`` is affine in a (3.58), so J is a least-squares
objective; it is solved as an equality-constrained least-squares problem (KKT system)
instead of the printed normal-equation form. Correction: the printed (3.62) writes
``Qy = 2 q1 V_i^T Mu V0 + ...`` with ``V_i`` for the input's initial-value response
``U_i`` and a factor 2 that (3.48) already carries; the linear term is
``Qy = q1 U_i^T Mu V0 + q2 U_i^T Md^T Md Mu V0``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy  # scipy.linalg and scipy.signal load on first use (start-up)

from servokit._lazy import control
from servokit.errors import ServokitValueError, check_count, check_finite
from servokit.switching.loop import SwitchedLoop, free_response, left_eig, siso_zeros

__all__ = ["AdditionalInputIvc", "ivc_additional_input", "additional_input_response"]


@dataclass(frozen=True)
class AdditionalInputIvc:
    """The compensators ``r' = n_k/d xp_k[0]`` of one design.

    Attributes
    ----------
    num : ndarray, shape (n + m, g+1)
        Coefficients of ``n_k`` (highest power first), one row per closed-loop state:
        the plant states of (3.41), then the controller states (whose residual at a
        reference switch, §3.5, is compensated the same way).
    den : ndarray
        Coefficients of ``d`` (monic).
    dt : float
        Sampling period [s].
    """

    num: np.ndarray
    den: np.ndarray
    dt: float

    def impulse(self, state: int, n_samples: int) -> np.ndarray:
        """First ``n_samples`` of the impulse response of ``n_k[z]/d[z]``."""
        return _impulse_tf(self.num[state], self.den, n_samples)

    def tf(self, state: int) -> control.TransferFunction:
        """``n_k[z]/d[z]`` for plant state ``state`` as a python-control transfer function."""
        return control.tf(self.num[state], self.den, self.dt)


def _eig(loop: SwitchedLoop) -> tuple[np.ndarray, np.ndarray]:
    lam, w = left_eig(loop.A)
    if np.min(np.abs(np.subtract.outer(lam, lam)) + np.eye(len(lam))) < 1e-9:
        raise ServokitValueError("the closed loop has repeated poles; (3.46) needs simple roots")
    return lam, w


def _denominator(loop: SwitchedLoop, pole: float, cancel_input_zeros: bool, g: int) -> np.ndarray:
    den = np.array([1.0, -pole])
    if cancel_input_zeros:
        z = siso_zeros(loop.A, loop.Bu, loop.C)
        stable = z[np.abs(z) < 1.0]
        den = np.real(np.polymul(den, np.poly(stable))) if stable.size else den
    if len(den) - 1 < g:  # r' = n_k/d must be proper: extra poles at z = 0 (deadbeat)
        den = np.concatenate([den, np.zeros(g - len(den) + 1)])
    return den


def _check_denominator(den: Sequence[float], g: int) -> np.ndarray:
    d = check_finite("denominator", den).ravel()
    if d.size < g + 1 or d[0] == 0 or np.any(np.abs(np.roots(d)) >= 1):
        raise ServokitValueError(
            f"denominator must have degree >= {g} (n + m - 1 or order) and roots inside the "
            "unit circle"
        )
    return d / d[0]


def _conditions(loop: SwitchedLoop, den: np.ndarray, state: int, g: int):
    """(3.46): rows of Sigma (complex Vandermonde) and Gamma for plant state ``state``."""
    lam, w = _eig(loop)
    wBu = w.T @ loop.Bu[:, 0]
    if np.min(np.abs(wBu)) < 1e-12 * np.max(np.abs(wBu)):
        raise ServokitValueError(
            "a closed-loop mode is not reachable from r'; it cannot be cancelled"
        )
    Sigma = np.vander(lam, g + 1)
    Gamma = -lam * w[state] * np.polyval(den, lam) / wBu
    return _realify(Sigma, Gamma)


def _realify(Sigma: np.ndarray, Gamma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Real equations (real and imaginary parts) of a complex system with real unknowns."""
    return np.vstack([Sigma.real, Sigma.imag]), np.concatenate([Gamma.real, Gamma.imag])


def ivc_additional_input(
    loop: SwitchedLoop,
    pole: float,
    *,
    order: int | None = None,
    cancel_input_zeros: bool = True,
    input_weight: float = 0.0,
    jerk_weight: float = 0.0,
    n_samples: int = 200,
    denominator: Sequence[float] | None = None,
) -> AdditionalInputIvc:
    """Design ``r' = n_k/d xp_k[0]`` for every plant state k ((3.41)-(3.47), (3.48)-(3.64)).

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop (poles must be simple).
    pole : float
        The assigned pole of d[z] (|pole| < 1).
    order : int, optional
        Degree g of ``n_k``; default ``n + m - 1`` (unique). Larger g needs weights.
    cancel_input_zeros : bool
        Put the stable roots of ``Nru`` into d[z] (the book's §3.3.2 choice).
    denominator : sequence of float, optional
        d[z] itself (monic, highest power first, degree >= g, roots inside the unit
        circle), e.g. ``np.poly([0.5] * 12)`` for §3.5; overrides ``pole``.
    input_weight, jerk_weight : float
        q1, q2 of (3.61) for the optimised form (g >= n + m).
    n_samples : int
        Horizon N of the optimised form.

    Returns
    -------
    AdditionalInputIvc
        Numerators n_k (one row per closed-loop state) and the common d[z].
    """
    pole = float(check_finite("pole", pole))
    if not abs(pole) < 1:
        raise ServokitValueError(f"pole must lie inside the unit circle (got {pole})")
    g = (
        loop.n + loop.m - 1
        if order is None
        else check_count("order", order, lo=loop.n + loop.m - 1)
    )
    if g > loop.n + loop.m - 1 and input_weight <= 0 and jerk_weight <= 0:
        raise ServokitValueError("order above n + m - 1 needs input_weight or jerk_weight > 0")
    den = (
        _denominator(loop, pole, cancel_input_zeros, g)
        if denominator is None
        else _check_denominator(denominator, g)
    )
    rows = []
    for k in range(loop.n + loop.m):  # controller states too (reference switching, §3.5)
        Sigma, Gamma = _conditions(loop, den, k, g)
        if g == loop.n + loop.m - 1:
            a = np.linalg.lstsq(Sigma, Gamma, rcond=None)[0]
        else:
            a = _optimised(loop, den, k, g, Sigma, Gamma, input_weight, jerk_weight, n_samples)
        rows.append(a)
    return AdditionalInputIvc(np.array(rows), den, loop.dt)


def _optimised(loop, den, k, g, Sigma, Gamma, q1, q2, N) -> np.ndarray:
    """Equality-constrained least squares of (3.61) under Sigma a = Gamma (KKT)."""
    N = check_count("n_samples", N, lo=g + 2)
    # V0: impulse responses of z^j / d[z] (j = g..0), the columns multiplying a (3.55)
    V0 = np.column_stack([_impulse_tf(np.eye(g + 1)[i], den, N) for i in range(g + 1)])
    # Mu: convolution with the impulse response of u/r' = 1 + Cu (zI-A)^{-1} Bu (3.56)
    huu = np.concatenate([[1.0], free_response(loop.A, loop.Cu, loop.Bu, N - 1)[:, 0]])
    Mu = scipy.linalg.toeplitz(huu, np.zeros(N))
    Ui = free_response(loop.A, loop.Cu, np.eye(loop.n + loop.m)[:, k], N)[:, 0]
    Md = np.eye(N) - np.eye(N, k=-1)
    W = np.vstack([np.sqrt(q1) * np.eye(N), np.sqrt(q2) * Md])
    F, e = W @ Mu @ V0, -W @ Ui
    kkt = np.block([[F.T @ F, Sigma.T], [Sigma, np.zeros((len(Sigma), len(Sigma)))]])
    sol = np.linalg.lstsq(kkt, np.concatenate([F.T @ e, Gamma]), rcond=None)[0]
    return sol[: g + 1]


def _impulse_tf(num: np.ndarray, den: np.ndarray, N: int) -> np.ndarray:
    imp = np.zeros(N)
    imp[0] = 1.0
    b = np.concatenate([np.zeros(len(den) - len(num)), num]) if len(num) < len(den) else num
    if len(b) > len(den):
        raise ServokitValueError("n_k[z]/d[z] must be proper: lower order or cancel fewer zeros")
    return scipy.signal.lfilter(b, den, imp)


def additional_input_response(
    loop: SwitchedLoop, design: AdditionalInputIvc, xp0: np.ndarray, n_samples: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brute-force simulation of the free loop with ``xc[0] = 0`` and ``r'`` applied.

    Returns ``(y, u, r')`` over ``n_samples`` samples.

    Parameters
    ----------
    loop : SwitchedLoop
        The closed loop of (3.17).
    design : AdditionalInputIvc
        The compensators n_k/d.
    xp0 : ndarray, shape (n,)
        Plant state at the switch (the controller state is zero).
    n_samples : int
        Number of samples simulated.

    Returns
    -------
    y, u, r_add : ndarray, shape (n_samples,)
        Output, control input and the additional input r'.
    """
    xp0 = np.asarray(xp0, dtype=float)
    rp = sum(xp0[k] * design.impulse(k, n_samples) for k in range(loop.n))
    x = np.concatenate([xp0, np.zeros(loop.m)])
    y, u = np.empty(n_samples), np.empty(n_samples)
    for j in range(n_samples):
        y[j] = loop.C[0] @ x
        u[j] = loop.Cu[0] @ x + rp[j]
        x = loop.A @ x + loop.Bu[:, 0] * rp[j]
    return y, u, rp
