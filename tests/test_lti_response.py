"""lti_response: python-control's own values of sys(x), vectorised (issue 24, reproduce).

The batched solve must give python-control's point-by-point values bit for bit (the
reproduce rows depend on them), at poles too, for SISO and MIMO, continuous and discrete,
and across chunk boundaries; the flutter PSD's stacked Horner equals the per-filter
``np.polyval`` quotient it replaced.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.models import BenchmarkDisturbances, controller_eq_4_69, hdd_sampled_data
from servokit.models import lti_response as lr
from servokit.models.lti_response import lti_response


def _hdd_loop() -> control.StateSpace:
    from servokit.models import HDD_SAMPLED_DATA_TS

    plant = hdd_sampled_data().discretize(HDD_SAMPLED_DATA_TS)
    return control.ss(controller_eq_4_69()) * plant


def test_hdd_loop_on_the_unit_circle_bit_for_bit(monkeypatch: pytest.MonkeyPatch) -> None:
    # the limits case's Bode integral loop (18 states, a triple pole at z = 1): small
    # chunks so that several batched solves and a ragged last one are compared
    monkeypatch.setattr(lr, "_CHUNK_BYTES", 16 * 18 * 19 * 37)
    loop = _hdd_loop()
    n = 1000
    z = np.exp(1j * (-np.pi + 2.0 * np.pi * (np.arange(n) + 0.5) / n))
    ref = np.asarray(loop(z))
    got = lti_response(loop, z)
    assert got.shape == ref.shape == (n,)
    assert np.array_equal(got, ref)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(2, 12),
    m=st.integers(1, 3),
    p=st.integers(1, 3),
    seed=st.integers(0, 2**31 - 1),
    scale=st.sampled_from([1e-6, 1.0, 1e6]),
    discrete=st.booleans(),
)
def test_random_systems_equal_python_control(n, m, p, seed, scale, discrete) -> None:
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * scale
    sys = control.ss(
        A,
        rng.standard_normal((n, m)),
        rng.standard_normal((p, n)),
        rng.standard_normal((p, m)),
        0.001 if discrete else 0,
    )
    w = np.logspace(-3, 3, 57) * scale
    x = np.exp(1j * w * 0.001) if discrete else 1j * w
    x = x.reshape(3, 19)  # any shape of points
    ref = np.asarray(sys(x.ravel(), squeeze=False)).reshape(p, m, 3, 19)
    got = lti_response(sys, x)
    expect = ref[0, 0] if (p, m) == (1, 1) else ref
    assert got.shape == expect.shape
    assert np.array_equal(got, expect)


def test_rigid_body_jordan_block_and_a_pole_in_the_grid() -> None:
    # 1/s^2 (a Jordan block): at s = 0 the chunk is singular and python-control's own
    # answer (inf) is returned there, the other points still bit for bit
    sys = control.ss([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    s = 1j * np.array([0.0, 1e-3, 1.0, 10.0])
    with np.errstate(all="ignore"), pytest.warns(RuntimeWarning):
        ref = np.asarray(sys(s))
    with np.errstate(all="ignore"), pytest.warns(RuntimeWarning):
        got = lti_response(sys, s)
    assert np.isinf(got[0]) and np.array_equal(got[1:], ref[1:])


def test_transfer_functions_and_one_state_systems_pass_through() -> None:
    g = control.tf([1.0, 2.0], [1.0, 3.0, 5.0])
    s = 1j * np.linspace(0.1, 10, 11)
    assert np.array_equal(lti_response(g, s), g(s))
    one = control.ss([[-2.0]], [[1.0]], [[3.0]], [[0.5]])
    assert np.array_equal(lti_response(one, s), one(s))


def test_flutter_psd_stacked_horner_equals_per_filter_polyval() -> None:
    bd = BenchmarkDisturbances()
    rng = np.random.default_rng(3)

    def per_filter(freq_hz):
        z = np.exp(2j * np.pi * np.asarray(freq_hz, dtype=float) * bd.dt)
        total = np.zeros(z.shape)
        for g in bd._discrete_flutter():
            num, den = g.num_array[0, 0], g.den_array[0, 0]
            total += np.abs(np.polyval(num, z) / np.polyval(den, z)) ** 2
        return 2.0 * bd.dt * total

    for f in (1234.5, np.array([700.0]), rng.uniform(0, 0.5 / bd.dt, 1001)):
        got, ref = bd.flutter_psd(f), per_filter(f)
        assert np.shape(got) == np.shape(ref)
        assert np.array_equal(got, ref)
