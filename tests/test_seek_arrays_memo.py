"""seek_time_of_arrays keeps the bank of the last small set of modal arrays (issue 24)."""

from __future__ import annotations

import numpy as np

import servokit.simulate.metrics as metrics
from servokit.cases.robust_seek import held_out_arrays
from servokit.models import hdd_benchmark_variants, without_delay
from servokit.seek.hdd import BAND, DESIGNS
from servokit.simulate.metrics import seek_time_of_arrays


def _fresh(modal, ff, tracks):
    metrics._bank_memo.clear()
    return seek_time_of_arrays(modal, 0.0, ff, tracks, band=BAND)


def test_kept_bank_gives_the_fresh_numbers_and_follows_changed_arrays():
    nominal = without_delay(hdd_benchmark_variants())[0]
    ffs = [(d.design(nominal), d.tracks) for d in (DESIGNS[0], DESIGNS[3])]
    modal = tuple(a.copy() for a in held_out_arrays(50, seed=3))
    for ff, tracks in ffs + ffs:  # repeats: the kept bank, with its rows and maps
        kept = seek_time_of_arrays(modal, 0.0, ff, tracks, band=BAND)
        assert len(metrics._bank_memo) == 1
        assert kept.tobytes() == _fresh(modal, ff, tracks).tobytes()
    # the caller changes its arrays in place: another key, another bank
    seek_time_of_arrays(modal, 0.0, *ffs[0], band=BAND)
    modal[0][:, 2] *= 1.01
    changed = seek_time_of_arrays(modal, 0.0, *ffs[0], band=BAND)
    assert changed.tobytes() == _fresh(modal, *ffs[0]).tobytes()
    # the kept bank is read-only and independent of the caller's arrays
    bank = next(iter(metrics._bank_memo.values()))
    assert not bank.Phi.flags.writeable and bank.w is not modal[0]


def test_large_sets_are_not_kept(monkeypatch):
    monkeypatch.setattr(metrics, "_BANK_MEMO_MODES", 10)
    metrics._bank_memo.clear()
    nominal = without_delay(hdd_benchmark_variants())[0]
    ff = DESIGNS[0].design(nominal)
    modal = held_out_arrays(5, seed=1)
    seek_time_of_arrays(modal, 0.0, ff, DESIGNS[0].tracks, band=BAND)
    assert not metrics._bank_memo
    assert np.all(np.isfinite(seek_time_of_arrays(modal, 0.0, ff, 1.0, band=BAND)))


def test_a_bank_replaced_by_another_thread_right_after_the_store(monkeypatch):
    # the sweeps call from several threads; emulate the interleaving where another
    # thread replaces the kept bank between this call's store and its return
    class Replaced(dict):
        def __setitem__(self, key, value) -> None:  # noqa: ANN001
            super().__setitem__(key, value)
            super().clear()  # the other thread's bank landed just after ours

    monkeypatch.setattr(metrics, "_bank_memo", Replaced())
    nominal = without_delay(hdd_benchmark_variants())[0]
    ff = DESIGNS[0].design(nominal)
    modal = held_out_arrays(4, seed=2)
    got = seek_time_of_arrays(modal, 0.0, ff, DESIGNS[0].tracks, band=BAND)
    monkeypatch.setattr(metrics, "_bank_memo", {})
    assert got.tobytes() == _fresh(modal, ff, DESIGNS[0].tracks).tobytes()
