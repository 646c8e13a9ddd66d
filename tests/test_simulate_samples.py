"""``simulate(samples_only=True)``: the same samples as the full fine-grid result, exactly."""

from __future__ import annotations

import control
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.models import HDD_SAMPLED_DATA_TS, ModalPlant, Mode
from servokit.simulate import simulate


def _both(plants, **kwargs):
    full = simulate(plants, **kwargs)
    return full, simulate(plants, samples_only=True, **kwargs)


def _assert_same_samples(full, fast, S):
    # the samples come from the same arithmetic (the modal sum of the sample states)
    assert np.array_equal(fast.yd, full.yd)
    assert np.array_equal(fast.yc, fast.yd)
    assert np.array_equal(fast.u, full.u[:, ::S])
    assert np.array_equal(fast.t, full.td) and np.array_equal(fast.td, full.td)
    assert fast.substeps == 1


@settings(max_examples=30, deadline=None)
@given(
    f=st.floats(50.0, 4000.0),
    z=st.sampled_from([1e-6, 1e-3, 0.05, 0.7]),
    gain_exp=st.integers(-3, 9),
    delay_frac=st.floats(0.0, 2.5),
    S=st.integers(1, 12),
    loop_gain=st.sampled_from([0.0, 1e-3, 1.0, 30.0]),
    seed=st.integers(0, 1000),
)
def test_samples_only_equals_the_samples_of_the_full_result(
    f, z, gain_exp, delay_frac, S, loop_gain, seed
):
    """Rigid body + one mode (damping to 1e-6), gains 1e-3..1e9, stable and unstable loops."""
    dt = 1e-4
    gain = 10.0**gain_exp
    plant = ModalPlant(gain, (Mode(0, 0, 1), Mode(f, z, 0.5)), delay=delay_frac * dt)
    rng = np.random.default_rng(seed)
    K = 30
    kwargs = dict(
        dt=dt,
        n_samples=K,
        substeps=S,
        feedforward=rng.standard_normal(8),
        input_disturbance=rng.standard_normal(K * S) * 0.1,
        output_disturbance=rng.standard_normal((2, K * S)) * 1e-3,
        x0=rng.standard_normal(4) * 1e-3,
    )
    if loop_gain:
        # a lead controller scaled to the plant: unstable at the largest loop gains
        C = control.tf([1.0, -0.9], [1.0, -0.5], dt) * (loop_gain / (gain * dt**2))
        kwargs.update(controller=C, reference=np.ones(K), check_stability=False)
    full, fast = _both([plant, plant.replace(gain=2 * gain)], **kwargs)
    _assert_same_samples(full, fast, S)


def test_samples_only_multirate_and_chunks():
    """A multirate loop, and variants split into several chunks by the memory budget."""
    plant = sk.models.hdd_sampled_data()
    dt, m, S = HDD_SAMPLED_DATA_TS, 4, 8
    C = sk.models.controller_eq_4_69()
    F = control.tf([1, 1, 1, 1], [1, 0, 0, 0], dt / m) * control.tf([0.5, 0.2], [1, -0.3], dt / m)
    plants = [plant.replace(gain=plant.gain * g) for g in np.linspace(0.9, 1.1, 40)]
    kwargs = dict(
        dt=dt, n_samples=200, substeps=S, controller=C, multirate=(m, F), reference=np.ones(200)
    )
    full, fast = _both(plants, max_memory_mb=3.0, **kwargs)
    _assert_same_samples(full, fast, S)
    whole = simulate(plants, samples_only=True, **kwargs)  # one chunk: other GEMM sizes
    assert np.allclose(whole.yd, fast.yd, rtol=1e-12, atol=1e-14)
    # open loop, shared input, several chunks: u is the shared row at the samples
    ff = np.ones(50)
    full, fast = _both(plants, dt=dt, n_samples=200, substeps=S, feedforward=ff, max_memory_mb=3.0)
    _assert_same_samples(full, fast, S)


def test_open_loop_samples_agree_with_the_fine_output_to_rounding():
    """``yd`` (the modal sum) and ``yc[:, ::S]`` (the between-sample GEMM at i = 0) are
    the same samples formed in a different order: equal to rounding, not always bitwise
    (the identification of the PZT outside the loop reads the former since issue 24)."""
    plant = sk.models.pzt_active_suspension()
    S, K = 12, 400
    d = np.cos(2 * np.pi * 37e3 * np.arange(K * S) * (1 / 30e3 / S))
    full = simulate(plant, dt=1 / 30e3, n_samples=K, substeps=S, input_disturbance=d)
    scale = np.max(np.abs(full.yd))
    assert np.max(np.abs(full.yc[:, ::S] - full.yd)) <= 1e-14 * scale
