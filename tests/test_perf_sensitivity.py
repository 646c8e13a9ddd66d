"""Vectorised alias sums of ``sampled_data_sensitivity`` against the path they replace."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.models import HDD_SAMPLED_DATA_TS as TS
from servokit.models import ModalPlant, Mode, hdd_sampled_data
from servokit.sampled import _alias
from servokit.sampled import sensitivity as sens
from servokit.sampled.multirate import Multirate, zoh_response


@settings(max_examples=40, deadline=None)
@given(
    m=st.integers(1, 4),
    delay_frac=st.floats(0.0, 1.7),
    zeta=st.floats(0.0, 0.5),
    seed=st.integers(0, 10_000),
    band=st.booleans(),
)
def test_path_terms_match_reference(m, delay_frac, zeta, seed, band):
    rng = np.random.default_rng(seed)
    plant = ModalPlant(
        1e7,
        (Mode(0.0, 0.0, 1.0), Mode(rng.uniform(500, 9000), zeta, rng.uniform(-1, 1))),
        delay=delay_frac * TS,
    )
    mr = Multirate(m=m)
    f = rng.uniform(1.0, 3 / TS, 40)
    orders = np.r_[np.arange(-40, 0), np.arange(0, 41)]
    limit = 2 / TS if band else None
    got = _alias._path_terms(plant, mr, TS, f, orders, limit)
    ref = _alias._per_cell_path_terms(plant, mr, TS, f, orders, limit)
    # relative to each frequency's largest term: the phase of order l carries l * eps
    scale = np.abs(ref).max(axis=1, keepdims=True)
    assert np.all(np.abs(got - ref) <= 1e-12 * scale)


def test_hold_matches_extended_precision():
    """Near an alias of 0 Hz the per-cell sinc loses digits (sin near a multiple of pi);
    the factored form keeps them.  Just below 1/Ts both inherit the rounding of f*Ts
    itself (~1e-16 absolute on a 1e-8 distance), where the new form is no worse."""
    mpmath = pytest.importorskip("mpmath")
    mpmath.mp.dps = 30
    mr = Multirate(m=1)
    f = np.array([1e-3, 0.5, 1234.5, 1.0 / TS - 1e-3])
    orders = np.array([-2, -1, 0, 1, 3])
    got = _alias._hold_filter(mr, TS, f, orders)
    old = zoh_response(f[:, None] + orders[None, :] / TS, TS)
    T = mpmath.mpf(TS)
    for i, fi in enumerate(f):
        for j, li in enumerate(orders):
            w = 2 * mpmath.pi * (mpmath.mpf(float(fi)) + int(li) / T)
            ref = complex((1 - mpmath.exp(-1j * w * T)) / (1j * w))
            err, err_old = abs(got[i, j] - ref) / abs(ref), abs(old[i, j] - ref) / abs(ref)
            assert err <= (1e-14 if i < 3 else err_old)


def test_sensitivity_equals_reference_path(monkeypatch):
    plant = hdd_sampled_data()
    from servokit.models import controller_eq_4_69

    f = np.geomspace(20.0, 2.9 / TS, 300)
    new = sens.sampled_data_sensitivity(plant, controller_eq_4_69(), TS, f)
    monkeypatch.setattr(sens, "_path_terms", _alias._per_cell_path_terms)
    old = sens.sampled_data_sensitivity(plant, controller_eq_4_69(), TS, f)
    for a, b in ((new.Ssd, old.Ssd), (new.Tsd, old.Tsd), (new.gamma_sum, old.gamma_sum)):
        assert np.max(np.abs(a - b) / np.abs(b)) < 1e-10
    assert new.alias_terms == old.alias_terms
