"""``rolloff_bandwidth`` on grid suffixes equals the whole-grid minimum, bit for bit."""

from __future__ import annotations

import control
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.limits.accuracy import _response, rolloff_bandwidth


def _whole_grid(loop, delta: float, k: int, n: int) -> float:  # noqa: ANN001
    """(6.14)'s Omega from ``|L|`` on every grid point at once (the form before)."""
    dt = float(loop.dt) if loop.isdtime() else None
    resp = _response(loop, dt)
    top = np.pi / dt if dt else 1e3 * max(1.0, float(np.max(np.abs(loop.poles()))))
    w = np.geomspace(top * 1e-8, top * (1 - 1e-9), n)
    g = w * (np.abs(resp(w)) / delta) ** (1.0 / (k + 1))
    tail = np.maximum.accumulate(g[::-1])[::-1]
    return float(np.min(np.maximum(w, tail)) / (2 * np.pi))


@settings(max_examples=40, deadline=None)
@given(
    gain=st.floats(1e-6, 1e6),
    zeta=st.sampled_from([1e-6, 1e-3, 0.05, 0.7]),
    frac=st.floats(1e-4, 0.9),
    integrators=st.integers(0, 2),
    discrete=st.booleans(),
    delta=st.floats(0.05, 0.9),
    k=st.integers(1, 3),
    n=st.sampled_from([100, 1000, 5000]),
)
def test_suffix_minimum_is_the_whole_grid_minimum(  # noqa: PLR0913
    gain, zeta, frac, integrators, discrete, delta, k, n
):  # noqa: ANN001
    """Resonances (damping to 1e-6) anywhere from the bottom decades to near Nyquist,
    rigid bodies, gains that put Omega early or late in the grid."""
    wn = frac * (np.pi / 1e-4 if discrete else 1e4)
    loop = gain * control.tf([wn * wn], [1.0, 2 * zeta * wn, wn * wn])
    for _ in range(integrators):
        loop = loop * control.tf([1.0], [1.0, 0.0])
    if discrete:
        loop = control.c2d(control.ss(loop), 1e-4, "zoh")
    else:
        loop = control.ss(loop)
    got = rolloff_bandwidth(loop, delta=delta, k=k, n_freq=n)
    want = _whole_grid(loop, delta, k, n)
    assert got == want or (np.isnan(got) and np.isnan(want))
