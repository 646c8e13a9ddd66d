"""Sampled-data polynomials: (2.24) and Table 2.1 reproduced exactly, boundary conditions."""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.feedforward.polynomial import (
    POLYNOMIAL_ORDERS,
    boundary_condition_split,
    polynomial_formula,
    rigid_body_zoh_states,
    sampled_polynomial,
)

n, N = sp.symbols("n N", integer=True, positive=True)

# Book formulas for r = tau = 1, typed from eq. (2.24) and Table 2.1 (book values live in tests).
BOOK = {
    3: 60 * n * (n - N) * (2 * n - N) / (N * (N**2 - 1) * (N**2 - 4)),
    4: -60
    * n
    * (n - N) ** 2
    * (5 * n * N - 2 * (1 + N**2))
    / ((N - 2) * (N - 1) * N * (N + 1) * (N + 2) * (1 + N**2)),
    5: -420
    * n**2
    * (n - N) ** 2
    * (2 * n - N)
    / ((N - 2) * (N - 1) * N * (N + 1) * (N + 2) * (5 + N**2)),
    6: 840
    * n**2
    * (n - N) ** 3
    * (-10 + (7 * n - 3 * N) * N * (1 + N**2))
    / (N * (N**2 - 4) * (N**2 - 1) * (N**2 + 5) * (10 + 3 * (N**2 + N**4))),
    7: 2520
    * n**3
    * (n - N) ** 3
    * (2 * n - N)
    / ((N - 2) * (N - 1) * N * (N + 1) * (N + 2) * (42 + 5 * N**2 + N**4)),
    8: -1260
    * n**3
    * (n - N) ** 4
    * (-84 + 30 * n * N - 4 * N**2 + 9 * n * N**3 - 4 * N**4 + 9 * n * N**5 - 4 * N**6)
    / (
        (N - 2)
        * (N - 1)
        * N
        * (N + 1)
        * (N + 2)
        * (3 + N**2)
        * (7 - 2 * N**2 + N**4)
        * (42 + 5 * N**2 + N**4)
    ),
}


@pytest.mark.parametrize("order", sorted(BOOK))
def test_derived_formula_equals_table_2_1_symbolically(order: int) -> None:
    assert sp.simplify(polynomial_formula(order) - BOOK[order]) == 0


def _exact(expr: sp.Expr):  # noqa: ANN202
    """Evaluate a rational function with integer coefficients in exact Fraction arithmetic."""
    assert all(a.is_Integer for a in expr.atoms(sp.Rational))
    fn = sp.lambdify((n, N), expr, modules="math")
    return lambda k, m: Fraction(fn(Fraction(k), Fraction(m)))


@pytest.mark.parametrize("order", sorted(BOOK))
def test_table_2_1_rational_equality_for_N_5_to_60(order: int) -> None:
    ours, book = _exact(polynomial_formula(order)), _exact(BOOK[order])
    for NN in range(5, 61):
        exact = [book(k, NN) for k in range(NN + 1)]
        assert [ours(k, NN) for k in range(NN + 1)] == exact
        # sampled_polynomial's numeric solve (no sympy) agrees with the exact value to
        # round-off: a few ulps of the peak (zero crossings come out as ~1e-15 of it)
        u = sampled_polynomial(order, NN, 1.0, 1.0)
        ref = np.array([float(x) for x in exact])
        np.testing.assert_allclose(u, ref, rtol=1e-12, atol=1e-14 * np.abs(ref).max())


def test_order_3_coefficients_of_2_24() -> None:
    # A, B, C of §2.2.4 from the expanded derived polynomial
    poly = sp.Poly(sp.together(polynomial_formula(3) * N * (N**2 - 1) * (N**2 - 4)), n)
    assert poly.coeff_monomial(n**3) == 120
    assert sp.expand(poly.coeff_monomial(n**2)) == -180 * N
    assert sp.expand(poly.coeff_monomial(n)) == 60 * N**2


def test_approaches_minimum_jerk_with_gain_g_of_2_25() -> None:
    # (2.25): u[n] = 60 r/T^2 nn (2nn-1)(nn-1) g, g = 1/((1-1/N^2)(1-4/N^2))
    NN, dt, r = 40, 1e-3, 2.0
    T = NN * dt
    u = sampled_polynomial(3, NN, dt, r)
    nn = np.arange(NN + 1) / NN
    g = 1.0 / ((1 - 1 / NN**2) * (1 - 4 / NN**2))
    np.testing.assert_allclose(u, 60 * r / T**2 * nn * (2 * nn - 1) * (nn - 1) * g, rtol=1e-12)


def test_boundary_split_matches_table() -> None:
    assert [boundary_condition_split(k) for k in range(3, 9)] == [
        (1, 1),
        (1, 2),
        (2, 2),
        (2, 3),
        (3, 3),
        (3, 4),
    ]


@settings(max_examples=40, deadline=None)
@given(
    order=st.integers(3, 8),
    NN=st.integers(3, 400),
    dt=st.floats(1e-6, 1e-2),
    target=st.floats(-1e3, 1e3).filter(lambda x: abs(x) > 1e-6),
)
def test_boundary_conditions_property(order: int, NN: int, dt: float, target: float) -> None:
    u = sampled_polynomial(order, NN, dt, target)
    assert u.shape == (NN + 1,)
    # independent check: exact ZOH of 1/s^2 by the matrix recursion (2.17)
    A = np.array([[1.0, dt], [0.0, 1.0]])
    B = np.array([0.5 * dt**2, dt])
    x = np.zeros(2)
    for uk in u[:-1]:
        x = A @ x + B * uk
    assert abs(x[0] - target) <= 1e-9 * abs(target)
    assert abs(x[1]) * NN * dt <= 1e-9 * abs(target)
    peak = np.abs(u).max()
    assert abs(u[0]) <= 1e-12 * peak and abs(u[-1]) <= 1e-9 * peak
    p, v = rigid_body_zoh_states(u[:-1], dt)
    np.testing.assert_allclose(p[-1], target, rtol=1e-9)


@pytest.mark.parametrize("order", sorted(BOOK))
def test_vanishing_derivatives_for_every_N(order: int) -> None:
    # derivative conditions of Table 2.1 hold identically in N, and no more than those
    n_start, n_end = boundary_condition_split(order)
    expr = sp.factor(polynomial_formula(order))
    num = sp.numer(expr)
    for d in range(n_start):
        assert sp.expand(sp.diff(num, n, d).subs(n, 0)) == 0
    for d in range(n_end):
        assert sp.expand(sp.diff(num, n, d).subs(n, N)) == 0
    assert sp.expand(sp.diff(num, n, n_end).subs(n, N)) != 0


def test_errors() -> None:
    with pytest.raises(ServokitValueError, match="order"):
        sampled_polynomial(9, 10, 1e-3, 1.0)
    with pytest.raises(ServokitTypeError, match="order"):
        sampled_polynomial(3.0, 10, 1e-3, 1.0)  # type: ignore[arg-type]
    with pytest.raises(ServokitValueError, match="N = 2"):
        sampled_polynomial(3, 2, 1e-3, 1.0)
    with pytest.raises(ServokitTypeError, match="N must be an integer"):
        sampled_polynomial(3, 10.5, 1e-3, 1.0)  # type: ignore[arg-type]
    with pytest.raises(ServokitValueError, match="dt"):
        sampled_polynomial(3, 10, -1e-3, 1.0)
    with pytest.raises(ServokitValueError, match="target"):
        sampled_polynomial(3, 10, 1e-3, float("nan"))


@settings(max_examples=40, deadline=None)
@given(st.sampled_from(POLYNOMIAL_ORDERS), st.integers(3, 20000))
def test_numeric_samples_equal_the_sympy_formula(order, n_steps):
    """sampled_polynomial solves the conditions numerically (no sympy at start-up); the
    exact derivation's formula, evaluated, gives the same samples."""
    expr = polynomial_formula(order)
    n, big_n = sorted(expr.free_symbols, key=lambda x: x.name != "n")
    u = sampled_polynomial(order, n_steps, 1.0, 1.0)
    exact = sp.lambdify((n, big_n), expr, modules="numpy")(np.arange(n_steps + 1.0), n_steps)
    np.testing.assert_allclose(u, exact, rtol=0, atol=1e-11 * np.max(np.abs(exact)))
