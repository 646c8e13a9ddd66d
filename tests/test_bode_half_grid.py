"""The discrete Bode integral on the upper half of the circle equals the full-circle mean."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.limits.bode import discrete_bode_integral


def _full_circle(loop: control.StateSpace, n: int) -> float:
    """The trapezoid of ln|S| on the whole midpoint grid, unit-circle poles removed."""
    z = np.exp(1j * (-np.pi + 2.0 * np.pi * (np.arange(n) + 0.5) / n))
    ln_s = np.log(np.abs(1.0 / (1.0 + loop(z))))
    for p in [p for p in np.asarray(loop.poles()) if abs(abs(p) - 1.0) < 1e-4]:
        angle = 0.0 if abs(np.angle(p)) < 1e-4 else np.angle(p)
        ln_s -= np.log(np.abs(z - np.exp(1j * angle)))
    return float(2.0 * np.pi * np.mean(ln_s))


@settings(max_examples=25, deadline=None)
@given(
    k=st.floats(0.02, 0.4),
    zeta=st.sampled_from([1e-6, 1e-3, 0.05, 0.5]),
    theta=st.floats(0.3, 2.8),
    integrators=st.integers(0, 2),
    n=st.sampled_from([256, 1024, 4096]),
)
def test_half_grid_equals_full_circle(k, zeta, theta, integrators, n):  # noqa: ANN001
    """Lightly damped resonances (damping to 1e-6), integrators (poles on the circle)."""
    r = np.exp(-zeta * theta)
    pair = control.tf([1.0, 0.0], [1.0, -2 * r * np.cos(theta), r * r], 1.0)
    lag = control.tf([1.0], [1.0, -0.5], 1.0)
    loop = k * pair * lag
    for _ in range(integrators):
        loop = loop * control.tf([1.0, -0.9], [1.0, -1.0], 1.0) * 0.5
    loop = control.ss(loop)
    cl = np.asarray(control.feedback(loop, 1).poles())
    if np.any(np.abs(cl) >= 1.0):
        return  # the theorem needs a stable closed loop (the function refuses)
    got = discrete_bode_integral(loop, n_freq=n).integral
    assert got == pytest.approx(_full_circle(loop, n), abs=1e-9 * max(1.0, n * 1e-3))


def test_odd_grid_keeps_the_full_circle():
    loop = control.tf([0.3], [1.0, -0.5], 1.0)
    assert discrete_bode_integral(loop, n_freq=1025).integral == pytest.approx(
        _full_circle(control.ss(loop), 1025), abs=1e-12
    )
