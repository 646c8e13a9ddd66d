"""servokit.seek: one checked request, one design_seek, and the deprecated old paths."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import servokit as sk
from servokit.errors import ServokitValueError
from servokit.feedforward import fsc_input
from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark_variants, without_delay
from servokit.seek import (
    SeekRequest,
    choose_N,
    design_seek,
    robust_minimum_time,
    table_2_4_weights,
)

PLANTS = hdd_benchmark_variants()[:3]


def test_fixed_n_is_the_fsc_design() -> None:
    req = SeekRequest(
        PLANTS, HDD_BENCHMARK_TS, 1.0, method="ffsc", N=10, band_weights=table_2_4_weights(1.0)
    )
    res = design_seek(req)
    ref = fsc_input(
        PLANTS[0],
        HDD_BENCHMARK_TS,
        10,
        1.0,
        band_weights=table_2_4_weights(1.0),
        model="rigid-body",
    )
    np.testing.assert_array_equal(res.ff.u, ref.u)
    assert res.search is None


def test_auto_n_is_choose_n_on_the_simulated_plants_with_progress() -> None:
    calls: list[int] = []
    req = SeekRequest(
        PLANTS, HDD_BENCHMARK_TS, 1.0, N="auto", N_range=range(8, 14), simulate_delay=False
    )
    res = design_seek(req, progress=lambda: calls.append(1))
    ref = choose_N(
        without_delay(PLANTS),
        HDD_BENCHMARK_TS,
        1.0,
        range(8, 14),
        design_plant=PLANTS[0],
        model="rigid-body",
    )
    assert res.search is not None and res.search.N == ref.N
    np.testing.assert_array_equal(res.search.worst_seek_times, ref.worst_seek_times)
    assert len(calls) == 6  # one call per candidate N


def test_robust_is_the_lp() -> None:
    req = SeekRequest(PLANTS, HDD_BENCHMARK_TS, 1.0, method="robust", N=12, u_max=0.5)
    ref = robust_minimum_time(PLANTS, HDD_BENCHMARK_TS, 1.0, band=0.1, u_max=0.5, N=12)
    np.testing.assert_allclose(design_seek(req).ff.u, ref.u, rtol=0, atol=0)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"method": "lp"}, "method must be"),
        ({"plants": []}, "plants is empty"),
        ({"dt": -1.0}, "dt"),
        ({"target": 0.0}, "target must be non-zero"),
        ({"band": 0.0}, "band"),
        ({"N": 0}, "N"),
        ({"method": "ffsc", "N": 10}, "band_weights"),
        ({"N": 10, "band_weights": [(1.0, 2.0, 1.0, 3)]}, "only applies to method 'ffsc'"),
        ({"N": "auto"}, "N_range or N_max"),
        ({"method": "robust"}, "needs u_max"),
        ({"method": "robust", "u_max": 1.0, "margin": 1.0}, "margin"),
        ({"method": "robust", "u_max": 1.0, "objective": "x"}, "objective"),
        ({"model": "x", "N": 5}, "model"),
    ],
)
def test_request_errors_name_the_parameter(kw: dict, match: str) -> None:
    args = {"plants": PLANTS, "dt": HDD_BENCHMARK_TS, "target": 1.0} | kw
    with pytest.raises(ServokitValueError, match=match):
        SeekRequest(**args)


def test_old_paths_still_resolve_with_a_deprecation_warning() -> None:
    from servokit.robust.sweep import sweep_seek_times  # old submodule path: an alias

    import servokit.robust

    assert sweep_seek_times is sk.seek.sweep_seek_times
    with pytest.warns(DeprecationWarning, match="servokit.seek.robust_minimum_time"):
        assert servokit.robust.robust_minimum_time is robust_minimum_time
    with pytest.warns(DeprecationWarning, match="servokit.seek.choose_N"):
        assert sk.simulate.choose_N is choose_N
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the API contract name: no warning
        assert sk.feedforward.robust_minimum_time is robust_minimum_time
    with pytest.raises(AttributeError):
        _ = servokit.robust.nothing_here


def test_limits_reach_the_constrained_design() -> None:
    from servokit.feedforward import InputLimit

    free = fsc_input(PLANTS[0], HDD_BENCHMARK_TS, 14, 1.0, model="rigid-body")
    cap = 0.8 * float(np.abs(free.u).max())
    req = SeekRequest(PLANTS, HDD_BENCHMARK_TS, 1.0, N=14, limits=[InputLimit(cap)])
    ref = fsc_input(
        PLANTS[0], HDD_BENCHMARK_TS, 14, 1.0, model="rigid-body", constraints=[InputLimit(cap)]
    )
    u = design_seek(req).ff.u
    np.testing.assert_array_equal(u, ref.u)
    assert np.abs(u).max() <= cap * (1 + 1e-6)
