"""The margins of the hdd-sensitivity case read on a grid prefix equal the whole grid's."""

from __future__ import annotations

import numpy as np
import pytest

import servokit.cases.hdd_sensitivity as hs
from servokit.models import controller_eq_4_69, hdd_sampled_data, without_delay
from servokit.sampled.multirate import eval_discrete


def _whole_grid(mr, n: int, delay: bool) -> dict[str, float]:  # noqa: ANN001
    """The margins as read before: the loop on all ``n`` points at once."""
    dt = hs.HDD_SAMPLED_DATA_TS
    f = np.linspace(1.0, 0.5 / dt, n)
    z = np.exp(2j * np.pi * f * dt)
    plant = hdd_sampled_data() if delay else without_delay(hdd_sampled_data())[0]
    loop = eval_discrete(mr.discretize(plant, dt), z) * eval_discrete(controller_eq_4_69(), z)
    mag = np.abs(loop)
    ic = int(np.flatnonzero((mag[:-1] >= 1) & (mag[1:] < 1))[0])
    neg = (np.diff(np.sign(loop.imag)) != 0) & (loop.real[:-1] < 0) & (np.arange(n - 1) > ic)
    ip = int(np.flatnonzero(neg)[0])
    return {
        "gain_crossover_hz": float(f[ic]),
        "phase_margin_deg": float(180.0 + np.degrees(np.angle(loop[ic]))),
        "phase_crossover_hz": float(f[ip]),
        "gain_margin_db": float(-20 * np.log10(mag[ip])),
    }


@pytest.mark.parametrize(
    ("n", "delay"), [(20_000, True), (20_000, False), (997, True), (64, False)]
)
def test_prefix_margins_equal_the_whole_grid(n: int, delay: bool) -> None:
    mr = hs.hdd_multirate(hs.HDD_SAMPLED_DATA_TS)
    assert hs._margins(mr, n, delay=delay) == _whole_grid(mr, n, delay)  # bit for bit


def test_first_crossings_need_both_inside() -> None:
    loop = np.array([2.0 + 1j, 0.5 + 0.1j, -0.5 + 0.1j, -0.5 - 0.1j])
    assert hs._first_crossings(loop) == (0, 2)
    assert hs._first_crossings(loop[:3]) is None  # the phase crossover is not inside yet
    assert hs._first_crossings(np.array([0.5 + 0j, 0.2 + 0j])) is None
