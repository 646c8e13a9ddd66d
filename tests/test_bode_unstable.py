"""Bode sensitivity integrals with unstable open-loop poles (the general form), by hand."""

from __future__ import annotations

import control
import numpy as np
import pytest

from servokit.errors import ServokitValueError
from servokit.limits.bode import continuous_bode_integral, discrete_bode_integral


@pytest.mark.parametrize("a, k", [(2.0, 5.0), (0.5, 3.0), (10.0, 40.0)])
def test_continuous_first_order_unstable_pole(a, k):
    # L = k/(s - a), k > a > 0: int ln|S| = pi a - pi k / 2 (by hand, module docstring)
    r = continuous_bode_integral(control.tf([k], [1, -a]))
    assert r.theory == pytest.approx(np.pi * a - np.pi * k / 2)
    assert r.integral == pytest.approx(r.theory, abs=1e-6 * max(1.0, abs(r.theory)))
    assert abs(r.error) < 1e-6 * max(1.0, abs(r.theory))
    assert "unstable" in r.corollary


def test_continuous_relative_degree_two_with_an_unstable_pole():
    # L = k (s + 1) / ((s - a)(s + b))... relative degree 1; use degree 2: Ks = 0
    a = 1.5
    loop = control.tf([60.0, 60.0], [1, 10 - a, -10 * a]) * control.tf([1], [0.01, 1])
    poles = np.asarray(control.feedback(loop, 1).poles())
    assert np.all(poles.real < 0)
    r = continuous_bode_integral(loop)
    assert r.theory == pytest.approx(np.pi * a)  # Ks = 0: only the unstable pole
    assert r.integral == pytest.approx(np.pi * a, rel=1e-5)


@pytest.mark.parametrize("a, k", [(1.5, 1.0), (-2.0, -1.5), (1.2, 0.9)])
def test_discrete_first_order_unstable_pole_has_a_positive_theory(a, k):
    # L = k/(z - a), |a| > 1 > |a - k|: int_{-pi}^{pi} ln|S| = 2 pi ln|a| > 0
    r = discrete_bode_integral(control.tf([k], [1, -a], 0.1))
    assert r.theory == pytest.approx(2 * np.pi * np.log(abs(a)))
    assert r.theory > 0  # the sign: unstable poles raise the integral
    assert r.integral == pytest.approx(r.theory, rel=1e-9)
    assert abs(r.error) < 1e-9


def test_discrete_unstable_pole_and_feedthrough():
    # L = (c z + d)/(z - a): Kz = c; theory 2 pi (ln|a| - ln|1 + c|)
    a, c, d = 1.4, 0.3, 0.2
    loop = control.tf([c, d], [1, -a], 1.0)
    assert np.all(np.abs(control.feedback(loop, 1).poles()) < 1)
    r = discrete_bode_integral(loop)
    assert r.theory == pytest.approx(2 * np.pi * (np.log(a) - np.log(1 + c)))
    assert r.integral == pytest.approx(r.theory, rel=1e-9)


def test_an_unstable_closed_loop_is_still_refused():
    with pytest.raises(ServokitValueError, match="closed loop"):
        discrete_bode_integral(control.tf([0.2], [1, -1.5], 0.1))
