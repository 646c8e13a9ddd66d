"""Additional-input IVC (book §3.3.2) and the loop-design helpers."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.switching import (
    additional_input_response,
    fit_delay_ratio,
    ivc_additional_input,
    pade_double_integrator,
    place_controller,
    switched_loop,
)
from tests.test_switching_ivc import random_loop


def first_order_miss(y: np.ndarray, pole: float, start: int = 1) -> float:
    """Largest |y[k+1] - pole y[k]| for k >= start, relative to max |y|."""
    return float(np.max(np.abs(y[start + 1 :] - pole * y[start:-1])) / np.max(np.abs(y)))


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**31), st.integers(1, 3), st.integers(1, 2), st.floats(-0.8, 0.9))
def test_free_response_is_first_order(seed, n, m, pole):
    loop = random_loop(seed, n, m)
    for cancel in (True, False):
        design = ivc_additional_input(loop, pole, cancel_input_zeros=cancel)
        # poles at 0 padded into d[z] delay the first-order phase by that many samples
        start = 1 + int(np.sum(np.roots(design.den) == 0))
        for k in range(n):
            y, _, _ = additional_input_response(loop, design, np.eye(n)[k], 80)
            assert first_order_miss(y, pole, start) < 1e-9


def test_pade_plant_zeros_and_delay_fit():
    ratio = 0.6
    P = pade_double_integrator(2e-4, ratio * 2e-4, gain=3.0)
    z = np.sort(np.real(control.zeros(P)))
    assert fit_delay_ratio(z) == pytest.approx(ratio, rel=1e-6)
    # DC behaviour: a double integrator (two poles at 1) and a Padé pole exp(-2 dt/Td)
    p = np.sort(np.real(control.poles(P)))
    np.testing.assert_allclose(p, [np.exp(-2 / ratio), 1, 1], atol=1e-6)


def test_place_controller_gives_the_poles():
    P = pade_double_integrator(1.0, 0.75)
    target = [-0.3, 0.5 + 0.4j, 0.5 - 0.4j, 0.9, 0.95]
    C = place_controller(P, target)
    got = np.sort_complex(switched_loop(P, C).poles())
    np.testing.assert_allclose(got, np.sort_complex(np.array(target)), atol=1e-9)
    with pytest.raises(ServokitValueError, match="give 5"):
        place_controller(P, target[:4])


def test_optimised_form_not_worse_and_still_cancels():
    P = pade_double_integrator(1.0, 0.75)
    loop = switched_loop(P, place_controller(P, [-0.3, 0.5 + 0.4j, 0.5 - 0.4j, 0.9, 0.95]))
    base = ivc_additional_input(loop, 0.6)
    opt = ivc_additional_input(loop, 0.6, order=7, input_weight=1.0, jerk_weight=1.0, n_samples=120)
    for k in range(3):
        x0 = np.eye(3)[k]
        y0, u0, _ = additional_input_response(loop, base, x0, 120)
        y1, u1, _ = additional_input_response(loop, opt, x0, 120)
        start = 1 + int(np.sum(np.roots(opt.den) == 0))
        assert first_order_miss(y1, 0.6, start) < 1e-8
        J = [np.sum(u**2) + np.sum(np.diff(np.concatenate([[0], u])) ** 2) for u in (u0, u1)]
        assert J[1] <= J[0] * (1 + 1e-9)


def test_additional_input_bad_input():
    loop = random_loop(1, 2, 1)
    with pytest.raises(ServokitValueError, match="unit circle"):
        ivc_additional_input(loop, 1.2)
    with pytest.raises(ServokitValueError, match="needs input_weight"):
        ivc_additional_input(loop, 0.5, order=6)
