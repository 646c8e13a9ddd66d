"""``disturbance_magnitude`` remembers one-point values: the same numbers as evaluating."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit.models.disturbances as dist
from servokit.models import HDD_BENCHMARK_TS, BenchmarkDisturbances, hdd_benchmark


@settings(max_examples=30, deadline=None)
@given(f=st.lists(st.floats(0.0, 0.5 / HDD_BENCHMARK_TS), min_size=1, max_size=12))
def test_one_point_values_equal_the_array_evaluation(f):  # noqa: ANN001
    bd = BenchmarkDisturbances()
    mag = dist.disturbance_magnitude(bd, hdd_benchmark().discretize(HDD_BENCHMARK_TS))
    whole = mag(np.array(f))  # arrays are evaluated, never remembered
    for _ in range(2):  # the first call computes, the second finds the value
        one = np.array([mag(np.array([x]))[0] for x in f])
        np.testing.assert_array_equal(one, whole)
        assert np.shape(mag(f[0])) == ()  # a pole (f = 0: inf/nan) included
        np.testing.assert_array_equal(mag(f[0]), whole[0])


def test_memory_is_bounded_and_nan_is_not_found(monkeypatch):
    monkeypatch.setattr(dist, "_SEEN_MAX", 3)
    bd = BenchmarkDisturbances()
    mag = dist.disturbance_magnitude(bd, hdd_benchmark().discretize(HDD_BENCHMARK_TS))
    values = [float(mag(np.array([x]))[0]) for x in (100.0, 200.0, 300.0, 400.0, 100.0)]
    assert values[0] == values[-1]
    assert np.isnan(mag(np.array([np.nan]))[0])


@settings(max_examples=30, deadline=None)
@given(f=st.lists(st.floats(0.0, 0.5 / HDD_BENCHMARK_TS), min_size=2, max_size=12))
def test_flutter_psd_of_one_point_equals_the_array(f):  # noqa: ANN001
    bd = BenchmarkDisturbances()
    whole = bd.flutter_psd(np.array(f))
    one = np.array([bd.flutter_psd(np.array([x]))[0] for x in f])
    np.testing.assert_array_equal(one, whole)
    assert np.shape(bd.flutter_psd(f[0])) == () and bd.flutter_psd(f[0]) == whole[0]
