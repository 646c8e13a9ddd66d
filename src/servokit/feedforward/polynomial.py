"""Acceleration sampled-data polynomials (book §2.2.4, eqs. (2.16)-(2.25), Table 2.1).

The rigid body ``P(s) = 1/s^2`` driven through a zero-order hold by ``u[n]`` obeys
(2.17); with ``p[0] = v[0] = 0`` its velocity and position after ``N`` steps are the
sums (2.18)-(2.19)::

    v[N] = tau * sum_{i=0}^{N-1} u[i]
    p[N] = tau^2 / 2 * sum_{i=0}^{N-1} (2 (N - i) - 1) u[i]

A sampled-data polynomial of order ``K`` is ``u[n] = sum_j c_j n^j`` (2.20) whose
``K + 1`` coefficients are fixed by ``v[N] = 0``, ``p[N] = r`` and ``K - 1`` conditions
on ``u`` and its derivatives with respect to ``n`` at ``n = 0`` and ``n = N``, split as
in Table 2.1: ``floor((K - 1) / 2)`` at the start and the rest at the end.

The coefficients are *derived* here, symbolically in ``N``, by solving those
boundary conditions exactly with sympy (Faulhaber sums, rational arithmetic); the
derivation is cached per order.  Order 3 gives (2.24), orders 4-8 give Table 2.1.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

from servokit.errors import ServokitTypeError, ServokitValueError, check_finite

if TYPE_CHECKING:
    import sympy as sp

__all__ = [
    "POLYNOMIAL_ORDERS",
    "boundary_condition_split",
    "polynomial_formula",
    "sampled_polynomial",
    "rigid_body_zoh_states",
]

#: Orders of Table 2.1 (3 is eq. (2.24)).
POLYNOMIAL_ORDERS = (3, 4, 5, 6, 7, 8)



@functools.cache
def _symbols() -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """The symbols ``n, N, i``; sympy is imported here, on first use (it costs about half
    a second: ``rigid_body_zoh_states`` and the minimum-jerk module never need it)."""
    import sympy as sp

    return sp.symbols("n N i", integer=True, positive=True)


def _check_order(order: object) -> int:
    if isinstance(order, bool) or not isinstance(order, int | np.integer):
        raise ServokitTypeError(f"order must be an integer in 3..8, got {order!r}")
    if int(order) not in POLYNOMIAL_ORDERS:
        raise ServokitValueError(
            f"order must be one of {POLYNOMIAL_ORDERS} (Table 2.1), got {order}"
        )
    return int(order)


def boundary_condition_split(order: int) -> tuple[int, int]:
    """Number of vanishing derivatives of ``u`` (orders 0, 1, ...) at ``n = 0`` and at ``n = N``.

    Table 2.1 imposes ``K - 1`` such conditions for an order-``K`` polynomial, the
    extra one (for even ``K``) at the final step.

    Parameters
    ----------
    order : int
        Polynomial order ``K`` (3..8).

    Returns
    -------
    (n_start, n_end) : tuple of int
    """
    k = _check_order(order)
    n_start = (k - 1) // 2
    return n_start, k - 1 - n_start


@functools.cache
def polynomial_formula(order: int) -> sp.Expr:
    """Sampled-data polynomial ``u[n]`` for ``r = tau = 1``, derived symbolically in n and N.

    Solves the boundary conditions of Table 2.1 (``p[0] = v[0] = 0`` hold by (2.18)-(2.19))
    for the coefficients of ``u[n] = sum_{j<=K} c_j n^j``; the physical input is
    ``target / dt**2`` times this expression.

    Parameters
    ----------
    order : int
        Polynomial order ``K`` (3..8); 3 is eq. (2.24).

    Returns
    -------
    sympy.Expr
        Factored rational function of the sympy symbols ``n`` and ``N`` (positive integers).
    """
    import sympy as sp

    k = _check_order(order)
    _n, _N, _i = _symbols()
    coeffs = sp.symbols(f"c0:{k + 1}")
    u = sum(c * _n**j for j, c in enumerate(coeffs))
    n_start, n_end = boundary_condition_split(k)
    eqs = [sp.diff(u, _n, d).subs(_n, 0) for d in range(n_start)]
    eqs += [sp.diff(u, _n, d).subs(_n, _N) for d in range(n_end)]
    # Faulhaber sums S_j = sum_{i=0}^{N-1} i^j turn (2.18)-(2.19) into polynomials in N.
    power_sums = [sp.expand(sp.summation(_i**j, (_i, 0, _N - 1))) for j in range(k + 2)]
    v_end = sum(c * power_sums[j] for j, c in enumerate(coeffs))
    # (2.19) with tau = 1: p[N] = 1/2 sum (2N - 1 - 2i) u[i] = 1
    p_end = sum(
        c * ((2 * _N - 1) * power_sums[j] - 2 * power_sums[j + 1]) for j, c in enumerate(coeffs)
    )
    eqs += [v_end, p_end - 2]
    solutions = sp.solve(eqs, coeffs, dict=True)
    if len(solutions) != 1:  # pragma: no cover - the linear system is regular for every order
        raise RuntimeError(f"boundary conditions of order {k} have no unique solution")
    return sp.factor(u.subs(solutions[0]))


def _polynomial_samples(order: int, N: int) -> np.ndarray:
    """``u[0..N]`` for ``r = tau = 1`` from the boundary conditions, numerically.

    The ``n_start`` conditions at ``n = 0`` and the ``n_end`` at ``n = N`` (Table 2.1) say
    that ``u`` has the factors ``x^n_start (1 - x)^n_end`` (``x = n / N``); with
    ``n_start + n_end = K - 1`` the rest is linear, ``c0 + c1 x``, and (2.18)-(2.19) fix
    ``c0, c1``: ``sum_i u[i] = 0`` (``v[N] = 0``) and ``sum_i (2N - 1 - 2i) u[i] = 2``
    (``p[N] = 1``).  The boundary zeros are exact and the 2 x 2 system well conditioned;
    numpy only, where sympy's exact derivation costs about a second of start-up.
    """
    n_start, n_end = boundary_condition_split(order)
    x = np.arange(N + 1) / N
    g0 = x**n_start * (1.0 - x) ** n_end
    basis = np.array([g0, g0 * x])  # u = c0 g0 + c1 g0 x
    i = np.arange(N, dtype=float)  # the sums run over u[0..N-1]
    rows = np.array([basis[:, :-1].sum(axis=1) / N, basis[:, :-1] @ ((2 * N - 1 - 2 * i) / N) / N])
    c = np.linalg.solve(rows, [0.0, 2.0 / N**2])
    return c @ basis


def rigid_body_zoh_states(u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of ``1/s^2`` at the sampling instants under a ZOH, eq. (2.17).

    Parameters
    ----------
    u : ndarray (M,)
        Held input samples ``u[0..M-1]`` [m/s^2 or track/s^2].
    dt : float
        Hold period ``tau`` [s].

    Returns
    -------
    p, v : ndarray (M + 1,)
        ``p[n] = p(n tau)`` and ``v[n] = v(n tau)`` for ``n = 0..M`` from rest.
    """
    u = np.asarray(u, dtype=float)
    v = np.concatenate(([0.0], dt * np.cumsum(u)))
    p = np.concatenate(([0.0], np.cumsum(dt * v[:-1] + 0.5 * dt * dt * u)))
    return p, v


def sampled_polynomial(order: int, N: int, dt: float, target: float) -> np.ndarray:
    """Acceleration sampled-data polynomial input ``u[0..N]`` (eq. (2.24), Table 2.1).

    Held by a ZOH with period ``dt``, ``u`` moves the rigid body ``1/s^2`` from rest at
    0 to rest at ``target`` in exactly ``N`` steps.

    Parameters
    ----------
    order : int
        Polynomial order 3..8 (3 is (2.24); 4-8 are the rows of Table 2.1).
    N : int
        Number of steps (final step); at least 3.
    dt : float
        Sampling (hold) period ``tau`` [s].
    target : float
        Target position ``r`` (units of the plant output).

    Returns
    -------
    ndarray (N + 1,)
        ``u[0], ..., u[N]`` with ``u[0] = u[N] = 0`` [target units / s^2].

    Raises
    ------
    ServokitValueError
        Bad arguments, or if the boundary conditions are not met to 1e-9 (never expected).
    """
    k = _check_order(order)
    if isinstance(N, bool) or not isinstance(N, int | np.integer):
        raise ServokitTypeError(f"N must be an integer number of steps, got {N!r}")
    N = int(N)
    dt = float(check_finite("dt", dt))
    target = float(check_finite("target", target))
    if dt <= 0:
        raise ServokitValueError(f"dt must be > 0 seconds (got {dt})")
    if N < 3:
        raise ServokitValueError(
            f"N = {N} makes the order-{k} boundary conditions singular; use N >= 3"
        )
    u = _polynomial_samples(k, N) * (target / dt**2)
    p, v = rigid_body_zoh_states(u[:-1], dt)
    scale = max(abs(target), np.finfo(float).tiny)
    if not (
        np.all(np.isfinite(u))
        and abs(p[-1] - target) <= 1e-9 * scale
        and abs(v[-1]) * dt * N <= 1e-9 * scale
        and abs(u[0]) + abs(u[-1]) <= 1e-9 * np.max(np.abs(u), initial=scale)
    ):
        raise ServokitValueError(
            f"sampled polynomial (order {k}, N = {N}) misses its boundary conditions "
            f"(p[N] - r = {p[-1] - target:.3g}); choose a smaller N"
        )
    return u
