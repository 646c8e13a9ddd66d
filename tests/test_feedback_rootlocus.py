"""Root-locus departure angles and branch gain margins against closed forms."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback import peak_filter, peak_filter_phase
from servokit.feedback.rootlocus import (
    _match,
    _roots_rows,
    branch_gain_margins,
    departure_angles,
    root_locus,
    tracked_roots,
)


@settings(max_examples=30, deadline=None)
@given(a=st.floats(0.5, 50), b=st.floats(0.5, 50), c=st.floats(0.5, 50))
@example(a=12.0, b=12.5, c=12.546875)  # nearly a triple pole: was 1.5e-6 off
@example(a=12.0, b=12.0 * (1 + 1e-6), c=12.0 * (1 + 2e-6))
def test_third_order_critical_gain_is_the_routh_hurwitz_value(a, b, c):
    g = control.tf([1.0], np.poly([-a, -b, -c]))
    _, k = branch_gain_margins(g)
    routh = (a + b + c) * (a * b + b * c + c * a) - a * b * c
    # crossings are refined to 1e-12 of phase on the accurate response (a cluster's
    # cancelling partial fractions made this 1.5e-6; tests/test_margins_accuracy.py)
    assert np.min(k) == pytest.approx(routh, rel=1e-9)


def test_textbook_departure_angle():
    # 1/((s^2+2s+5)(s+1)): from -1+2j, 180 - 90 - 90 = 0 deg
    poles, ang = departure_angles(control.tf([1], [1, 2, 5]) * control.tf([1], [1, 1]))
    assert ang[np.argmin(np.abs(poles - (-1 + 2j)))] == pytest.approx(0.0, abs=1e-9)
    # with a zero at -3: + angle(-1+2j+3) = +45 deg
    g = control.tf([1, 3], np.polymul([1, 2, 5], [1, 1]))
    poles, ang = departure_angles(g)
    assert ang[np.argmin(np.abs(poles - (-1 + 2j)))] == pytest.approx(45.0, abs=1e-9)


def test_departure_angle_matches_the_numerical_locus():
    sh = control.tf([1.0], [1 / 2000.0, 1])  # a smooth pseudo plant, phase -atan(f/318)
    f1 = 1000.0
    phi = peak_filter_phase(complex(sh(2j * np.pi * f1)))
    g = sh * peak_filter(f1, 0.001, 1.0, phi)
    poles, ang = departure_angles(g)
    p = poles[np.argmax(poles.imag)]
    a = ang[np.argmax(poles.imag)]
    # (5.18) evaluates Sh at jω1 instead of at the pole: 180 deg up to O(ζ1)
    assert abs(a) == pytest.approx(180.0, abs=0.2)
    locus = root_locus(g, np.array([1e-7]))
    step = locus.roots[1][np.argmin(np.abs(locus.roots[1] - p))] - p
    assert np.degrees(np.angle(step)) % 360 == pytest.approx(a % 360, abs=0.01)


def test_branch_margin_is_where_the_roots_cross():
    g = control.tf([1.0, 0.0], [1, 0.2, 1]) * control.tf([1.0], [1, 1, 1])
    starts, k = branch_gain_margins(g)
    kc = np.min(k)
    assert np.isfinite(kc)
    num, den = g.num[0][0], g.den[0][0]
    pad = np.concatenate([np.zeros(den.size - num.size), num])
    below = np.roots(den + kc * (1 - 1e-6) * pad)
    above = np.roots(den + kc * (1 + 1e-6) * pad)
    assert np.max(below.real) < 0 < np.max(above.real)


def test_unstable_or_discrete_g_is_refused():
    with pytest.raises(ServokitValueError):
        branch_gain_margins(control.tf([1], [1, -1]))
    with pytest.raises(ServokitValueError):
        root_locus(control.tf([1], [1, 0.5], 0.1), np.array([1.0]))


def test_locus_roots_solve_the_characteristic_equation():
    g = control.tf([2e4, 3e8], [1, 300, 4e8]) * control.tf([1], [1, 5e3])
    locus = root_locus(g, np.array([0.5, 3.0]))
    for k, row in zip(locus.gains[1:], locus.roots[1:], strict=True):
        vals = [1 + k * complex(g(r)) for r in row]
        assert np.max(np.abs(vals)) < 1e-6


@pytest.mark.parametrize(
    "method, expected", [("stable", 180.0), ("phase-shift", -90.0), ("transient", 0.0)]
)
def test_zero_placements_give_their_departure_angles_without_nearby_plant_poles(method, expected):
    """(5.18) -> 180°, (5.38) -> -90° (upper pole), corrected (5.51) -> 0°, up to O(ζ1)."""
    sh = control.tf([1.0], [1 / 3000.0, 1]) * control.tf([1.0], [1 / 9000.0, 1])
    g = sh * peak_filter(
        1000.0, 0.001, 1.0, peak_filter_phase(complex(sh(2j * np.pi * 1e3)), method)
    )
    poles, ang = departure_angles(g)
    a = ang[np.argmax(poles.imag)]
    assert (a - expected + 180) % 360 - 180 == pytest.approx(0.0, abs=0.2)


@settings(max_examples=25, deadline=None)
@given(st.integers(2, 12), st.integers(0, 2**32 - 1))
def test_batched_roots_equal_np_roots(n, seed):
    # one stacked eigvals call gives np.roots' values bit for bit, rows with a zero
    # leading or trailing coefficient (stripped by np.roots) included
    rng = np.random.default_rng(seed)
    polys = rng.standard_normal((40, n))
    polys[3, 0] = 0.0
    polys[5, -1] = 0.0
    polys[7, :2] = 0.0
    for got, row in zip(_roots_rows(polys), polys, strict=True):
        np.testing.assert_array_equal(got, np.roots(row))


def _pair(w: float, zeta: float) -> np.ndarray:
    return np.array([1.0, 2.0 * zeta * w, w * w])


@st.composite
def _stable_g(draw):
    """Random stable rational G: lightly damped pairs (ζ down to 1e-6), near-double
    pairs and real poles; zeros anywhere (minimum or non-minimum phase)."""
    den = np.array([1.0])
    for _ in range(draw(st.integers(1, 3))):
        w = draw(st.floats(0.1, 100.0))
        zeta = 10.0 ** draw(st.floats(-6.0, 0.0))
        den = np.polymul(den, _pair(w, zeta))
        if draw(st.booleans()):  # a near-double pair
            eps = 10.0 ** draw(st.floats(-9.0, -2.0))
            den = np.polymul(den, _pair(w * (1.0 + eps), zeta))
    for _ in range(draw(st.integers(0, 2))):
        den = np.polymul(den, [1.0, draw(st.floats(0.05, 200.0))])
    num = np.array([draw(st.floats(0.1, 10.0))])
    for _ in range(draw(st.integers(0, min(2, den.size - 2)))):
        num = np.polymul(num, [1.0, draw(st.floats(-50.0, 50.0))])
    return control.tf(num, den)


@settings(max_examples=60, deadline=None)
@given(
    g=_stable_g(),
    lo=st.floats(-8.0, 0.0),
    decades=st.floats(1.0, 10.0),
    n=st.integers(50, 600),
    stride=st.sampled_from([2, 5, 16, 40]),
    picks=st.lists(st.floats(0.0, 1.0), min_size=1, max_size=5),
)
def test_sparse_tracking_equals_the_dense_tracking(g, lo, decades, n, stride, picks):
    gains = np.geomspace(10.0**lo, 10.0 ** (lo + decades), n)
    dense = root_locus(g, gains)
    at = np.concatenate([[0.0], gains[(np.asarray(picks) * (n - 1)).astype(int)]])
    rows = dense.roots[np.searchsorted(dense.gains, at)]
    # the same roots in the same branch order, bit for bit
    np.testing.assert_array_equal(tracked_roots(g, gains, at, stride=stride), rows)


def test_sparse_tracking_through_a_breakaway_and_a_near_double_pole():
    # two real poles meet and break away at k = 1/4; a pair 1e-7 apart in frequency
    g = control.tf([1.0], np.polymul([1.0, 1.0, 0.0 + 0.25], [1.0, 2e-6, 1.0]))
    g = g * control.tf([1.0], _pair(1.0 + 1e-7, 1e-6))
    gains = np.geomspace(1e-9, 1e3, 800)
    dense = root_locus(g, gains)
    at = dense.gains[::37]
    np.testing.assert_array_equal(tracked_roots(g, gains, at), dense.roots[::37])


@settings(max_examples=100, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 6), ties=st.booleans())
def test_match_is_the_optimal_assignment(seed, n, ties):
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(seed)
    prev = rng.normal(size=n) + 1j * rng.normal(size=n)
    r = prev + 0.5 * (rng.normal(size=n) + 1j * rng.normal(size=n))
    if ties:  # exact ties: the shortcut must leave them to linear_sum_assignment
        r = np.round(r)
        prev = np.round(prev)
    cost = np.abs(prev[:, None] - r[None, :])
    np.testing.assert_array_equal(_match(prev, r), r[linear_sum_assignment(cost)[1]])
