"""(6.18) on loops with a direct feedthrough: the `.theory` and `.error` values themselves."""

from __future__ import annotations

import control
import numpy as np
import pytest

from servokit.limits.bode import discrete_bode_integral


@pytest.mark.parametrize(("k", "a"), [(0.5, 0.2), (2.0, -0.3), (-0.4, 0.5)])
def test_theory_is_minus_two_pi_ln_one_plus_kz(k: float, a: float) -> None:
    # L(z) = k z / (z - a): Kz = L(inf) = k; S = (z - a) / ((1 + k) z - a) and by Jensen's
    # formula the mean of ln|S| on the unit circle is -ln|1 + k| (both roots inside)
    loop = control.tf([k, 0.0], [1.0, -a], 1.0)
    assert abs(a / (1 + k)) < 1  # closed loop stable
    res = discrete_bode_integral(loop, n_freq=4096)
    want = -2.0 * np.pi * np.log(abs(1.0 + k))
    assert res.theory == pytest.approx(want, rel=1e-12)
    assert res.integral == pytest.approx(want, abs=1e-9)  # independent: the quadrature
    assert res.error == pytest.approx(res.integral - res.theory, abs=1e-15)
    assert abs(res.error) < 1e-9
    # the sign carries the waterbed: a loop with Kz > 0 must have a negative area
    assert np.sign(res.theory) == -np.sign(k)


def test_error_shows_a_wrong_theory() -> None:
    # error is integral - theory, not its absolute value: a sign slip would show here
    loop = control.tf([1.0, 0.0], [1.0, -0.1], 1.0)  # Kz = 1: theory -2 pi ln 2
    res = discrete_bode_integral(loop, n_freq=2048)
    assert res.theory == pytest.approx(-2.0 * np.pi * np.log(2.0), rel=1e-12)
    assert res.error == pytest.approx(0.0, abs=1e-9)
