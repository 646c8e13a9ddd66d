"""Case `sampled-oscillations` (§4.3, §4.4, §4.5.3): every book number within tolerance."""

from __future__ import annotations

import pytest

from servokit.cases import registry
from servokit.cases.oscillations import oscillations_case


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return oscillations_case(tmp_path_factory.mktemp("oscillations"))


def test_all_book_numbers_within_tolerance(case):
    assert "sampled-oscillations" in registry()
    bad = [(c.quantity, c.book, c.servokit) for c in case.comparisons if not c.ok]
    assert not bad
    quantities = " ".join(c.quantity for c in case.comparisons)
    for key in ("unacceptable fs", "SRS", "tau"):
        assert key in quantities
    assert len(case.comparisons) >= 25


def test_figures_written(case):
    assert len(case.figures) >= 6
    for path in case.figures:
        assert path.stat().st_size > 10_000
