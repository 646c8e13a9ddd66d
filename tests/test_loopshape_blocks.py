"""Modal-block FRFs (``model_frfs(method="blocks")``): the mode-major form of issue 24 gives
the plant-major form's numbers bit for bit, and ``_mode_sum`` is numpy's own complex sum."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.feedback.loopshape_problem import _block_frfs, _mode_sum, modal_banks, model_frfs
from servokit.models import ModalPlant, Mode


def _plant_major_frfs(plants: list, dt: float, z: np.ndarray) -> np.ndarray:
    """The form before issue 24: (plants, frequencies, modes) arrays, numpy's sum."""
    out = np.empty((len(plants), z.size), dtype=complex)
    zc = z[None, :, None]
    for idx, bank in modal_banks(plants, dt):
        delay_factor = z ** (-bank.dd)
        Phi = bank.Phi[:, None]
        gn, go = bank.Gnew[:, None], bank.Gold[:, None]
        a, b, c, e = Phi[..., 0, 0], Phi[..., 0, 1], Phi[..., 1, 0], Phi[..., 1, 1]
        ze = zc - e
        det = (zc - a) * ze - b * c
        num = ze * (gn[..., 0] + go[..., 0] / zc) + b * (gn[..., 1] + go[..., 1] / zc)
        out[idx] = (num / det).sum(axis=-1) * delay_factor
    return out


@settings(max_examples=40, deadline=None)
@given(
    m=st.integers(1, 200),
    exp=st.integers(-150, 150),
    seed=st.integers(0, 10_000),
)
def test_mode_sum_is_numpy_sum_bitwise(m, exp, seed):
    rng = np.random.default_rng(seed)
    shape = (3, 17, m)
    q = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * 10.0 ** rng.uniform(
        exp - 5, exp + 5, shape
    )
    assert np.array_equal(_mode_sum([q[..., i] for i in range(m)]), q.sum(axis=-1))


@settings(max_examples=25, deadline=None)
@given(
    n_modes=st.integers(1, 9),
    damping=st.sampled_from([1e-6, 1e-4, 0.02, 0.3]),
    gain_exp=st.integers(-6, 9),
    delay_frac=st.floats(0.0, 2.5),
    n_plants=st.integers(1, 9),
    seed=st.integers(0, 10_000),
)
def test_mode_major_blocks_equal_plant_major_bitwise(
    n_modes, damping, gain_exp, delay_frac, n_plants, seed
):
    """A rigid body plus lightly to well damped modes, gains 1e-6..1e9, delays to 2.5 T."""
    rng = np.random.default_rng(seed)
    dt = 1e-4
    plants = []
    for _ in range(n_plants):
        freqs, residues = rng.uniform(200, 4900, n_modes - 1), rng.uniform(-1, 1, n_modes - 1)
        modes = [Mode(0.0, 0.0, 1.0)] + [
            Mode(float(f), damping, float(r)) for f, r in zip(freqs, residues, strict=True)
        ]
        plants.append(ModalPlant(10.0**gain_exp, tuple(modes), delay=delay_frac * dt))
    f = np.sort(rng.uniform(10.0, 0.5 / dt, 700))
    z = np.exp(2j * np.pi * f * dt)
    assert np.array_equal(_block_frfs(plants, dt, z), _plant_major_frfs(plants, dt, z))
    # and both are the dense solve's FRFs (the reference of model_frfs)
    ref = model_frfs(plants, dt, f)
    assert np.max(np.abs(model_frfs(plants, dt, f, method="blocks") - ref) / np.abs(ref)) < 1e-6
