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
    _roots_rows,
    branch_gain_margins,
    departure_angles,
    root_locus,
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
