"""Held-out plants as modal arrays in one bank: the plant path's numbers (issue 24).

``hdd-loopshape`` checks its controllers on 1000 Monte-Carlo plants; it now draws them as
modal arrays (:func:`~servokit.models.variation_arrays.modal_arrays_from_draws`) and
builds one :class:`~servokit.simulate._bank.PlantBank` for the FRFs and the
certifications instead of 1000 ``ModalPlant`` objects and a bank per call.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from servokit.feedback.loopshape_iterate import certify_banks, certify_models
from servokit.feedback.loopshape_problem import bank_frfs, model_frfs
from servokit.models import HDD_BENCHMARK_TS, benchmark_controller, hdd_benchmark_variation_set
from servokit.models.variation_arrays import modal_arrays_from_draws
from servokit.simulate._bank import PlantBank


def _banks(vs, n, seed):
    modal = modal_arrays_from_draws(vs, *vs.draw(n, seed=seed))
    return [(np.arange(n), PlantBank.from_arrays(*modal, vs.nominal.delay, HDD_BENCHMARK_TS))]


@pytest.mark.parametrize(
    "n, seed, gain", [(1, 0, (-0.05, 0.05)), (64, 3, (-0.05, 0.05)), (200, 2026, (0.0, 0.0))]
)
def test_bank_frfs_and_certification_equal_the_plant_path(n, seed, gain):
    vs = dataclasses.replace(hdd_benchmark_variation_set(), gain=gain)
    plants = vs.monte_carlo(n, seed=seed)
    banks = _banks(vs, n, seed)
    f = np.geomspace(10.0, 0.49 / HDD_BENCHMARK_TS, 257)
    z = np.exp(2j * np.pi * f * HDD_BENCHMARK_TS)
    assert np.array_equal(
        bank_frfs(banks, n, z), model_frfs(plants, HDD_BENCHMARK_TS, f, method="blocks")
    )
    c = benchmark_controller()
    for gains in ((1.0,), (0.5, 1.0, 1.05)):
        assert np.array_equal(certify_banks(c, banks, n, gains), certify_models(c, plants, gains))


def test_bank_frfs_several_delay_groups():
    """Banks that cover the rows in pieces (two delays) fill every row of the output."""
    vs = hdd_benchmark_variation_set()
    plants = vs.monte_carlo(10, seed=1)
    plants = [p if i % 2 else p.replace(delay=2.5 * HDD_BENCHMARK_TS) for i, p in enumerate(plants)]
    from servokit.feedback.loopshape_problem import modal_banks

    f = np.linspace(100.0, 5000.0, 33)
    z = np.exp(2j * np.pi * f * HDD_BENCHMARK_TS)
    banks = list(modal_banks(plants, HDD_BENCHMARK_TS))
    assert len(banks) == 2
    got = bank_frfs(banks, len(plants), z)
    assert np.array_equal(got, model_frfs(plants, HDD_BENCHMARK_TS, f, method="blocks"))
    ref = model_frfs(plants, HDD_BENCHMARK_TS, f)
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-9
