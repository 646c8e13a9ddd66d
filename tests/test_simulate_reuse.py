"""Re-running a loop reuses a few plants' discretisation and loop eigenvalues (issue 24):
the reused results equal fresh ones, and a changed plant or controller is not served
from the kept values."""

from __future__ import annotations

import numpy as np
import pytest

import servokit as sk
from servokit.errors import ServokitValueError
from servokit.models import HDD_SAMPLED_DATA_TS as TS
from servokit.simulate import _bank, simulate, stability


def _forget():
    _bank._reused_bank.cache_clear()
    stability.clear_radii_cache()


def _run(plant, C):
    return simulate(plant, dt=TS, n_samples=120, substeps=3, controller=C, reference=np.ones(120))


def test_rerun_equals_fresh_and_changes_are_seen():
    C = sk.models.controller_eq_4_69()
    p = sk.models.hdd_sampled_data()
    _forget()
    fresh = _run(p, C)
    again = _run(p, C)
    assert _bank._reused_bank.cache_info().hits >= 1
    np.testing.assert_array_equal(again.yc, fresh.yc)
    # a plant differing in one gain is a new discretisation, not the kept one
    q = p.replace(gain=1.1 * p.gain)
    _forget()
    ref_q = _run(q, C)
    _run(p, C)
    np.testing.assert_array_equal(_run(q, C).yc, ref_q.yc)
    assert not np.array_equal(ref_q.yc, fresh.yc)


def test_kept_bank_is_read_only_and_large_sets_are_not_kept():
    p = sk.models.hdd_sampled_data()
    _forget()
    bank = _bank.bank_for([p], TS)
    with pytest.raises(ValueError):
        bank.Phi[0, 0, 0, 0] = 1.0
    assert _bank.bank_for([p], TS) is bank
    many = [p] * (_bank._REUSE_MAX_PLANTS + 1)
    assert _bank.bank_for(many, TS) is not _bank.bank_for(many, TS)


def test_unstable_loop_still_refused_on_a_rerun():
    p = sk.models.hdd_sampled_data()
    C = 1e4 * sk.models.controller_eq_4_69()  # far too much gain
    for _ in range(2):  # the second verdict comes from the kept eigenvalues
        with pytest.raises(ServokitValueError, match="unstable"):
            _run(p, C)


def test_kept_transition_rows_and_block_maps_are_read_only():
    p = sk.models.hdd_sampled_data()
    _forget()
    simulate(p, dt=TS, n_samples=20, substeps=4, feedforward=np.ones(3))
    bank = _bank.bank_for([p], TS / 4)
    for arr in (bank.transition_rows(4), bank.block_maps(4)):
        with pytest.raises(ValueError):
            arr[...] *= 2  # one write would change every later simulation of this plant


def test_kept_spectral_radii_are_few_and_keyed_by_a_digest():
    rng = np.random.default_rng(3)
    _forget()
    for _ in range(3 * stability._RADII_CACHE_SIZE):
        A = 0.3 * rng.standard_normal((2, 6, 6))
        np.testing.assert_array_equal(stability._radii_few(A), stability._radii(A))
    assert len(stability._RADII_CACHE) == stability._RADII_CACHE_SIZE
    assert all(len(key[0]) == 32 for key in stability._RADII_CACHE)
