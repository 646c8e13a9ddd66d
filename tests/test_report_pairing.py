"""pair_rows: every book value and every computed item gets a row; no silent 'nearest'."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.report.pairing import pair_rows


def test_exact_pairs_any_order() -> None:
    rows = pair_rows("peak", ["4100", "5000", "7000"], [7000.2, 4100.1, 5000.3], unit="Hz")
    assert [r.servokit for r in rows] == [4100.1, 5000.3, 7000.2]
    assert all(r.ok for r in rows) and rows[0].unit == "Hz"


def test_extra_computed_item_is_reported_not_dropped() -> None:
    rows = pair_rows("peak", ["4100", "7000"], [4100.0, 5500.0, 7000.0])
    assert len(rows) == 3
    extra = rows[-1]
    assert math.isnan(extra.book) and extra.servokit == 5500.0
    assert "no book counterpart" in extra.note


def test_book_value_without_partner_misses() -> None:
    rows = pair_rows("root", ["0.5", "0.9"], [0.5], note="read from Fig. 1")
    assert rows[0].ok
    assert not rows[1].ok and math.isnan(rows[1].servokit)
    assert rows[1].note.startswith("read from Fig. 1;") and "no computed item" in rows[1].note


def test_far_partner_is_a_miss_with_note() -> None:
    # nearest-matching would silently pair 0.9 with 0.8; here it is a labelled miss
    rows = pair_rows("root", ["0.9"], [0.8])
    assert not rows[0].ok and "outside the printed precision" in rows[0].note


@settings(max_examples=80, deadline=None)
@given(
    book=st.lists(st.integers(1, 10_000), min_size=0, max_size=6),
    found=st.lists(st.floats(1, 10_000), min_size=0, max_size=6),
)
def test_row_count_covers_both_lists(book: list[int], found: list[float]) -> None:
    rows = pair_rows("x", [str(b) for b in book], found)
    assert len(rows) == max(len(book), len(found))
    used = sorted(r.servokit for r in rows if not math.isnan(r.servokit))
    assert used == sorted(found)  # every computed item appears exactly once
    assert [r.book for r in rows[: len(book)]] == [float(b) for b in book]
    assert np.all([r.kind == "reproduced" for r in rows])
