"""§4.5.3-§4.5.4 HDD case: Mf, loop normalisation, seeks and the full comparison table."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sl

from servokit.cases import registry
from servokit.cases.hdd_residual import (
    MF_DELAY,
    crossover_gain,
    hdd_residual_case,
    reference_model,
    residual_amplitude,
    tdof_setup,
)
from servokit.models import HDD_SAMPLED_DATA_TS, controller_fig_4_57, hdd_sampled_data


def mf_by_hand(gain: float, T: float, delay: float) -> np.ndarray:
    """Frequency response of ZOH-discretised Pf with 0 < delay < T (augmented expm)."""
    w, z = 2 * np.pi * 3950.0, 0.3
    A = np.zeros((4, 4))
    A[0, 1] = A[2, 3] = 1.0
    A[3, 2], A[3, 3] = -(w**2), -2 * z * w
    B = np.array([0.0, gain, 0.0, -1.3 * gain])
    C = np.array([1.0, 0.0, 1.0, 0.0])

    def zoh(t):
        M = np.zeros((5, 5))
        M[:4, :4], M[:4, 4] = A * t, B * t
        E = sl.expm(M)
        return E[:4, :4], E[:4, 4]

    Phi, _ = zoh(T)
    Pa, Ga = zoh(T - delay)
    _, Gb = zoh(delay)
    zz = np.exp(2j * np.pi * np.array([100.0, 1000.0, 5000.0]) * T)
    # x[k+1] = Phi x[k] + Ga u[k] + Pa Gb u[k-1]
    return np.array([C @ np.linalg.solve(zk * np.eye(4) - Phi, Ga + Pa @ Gb / zk) for zk in zz])


def test_reference_model_matches_hand_discretisation():
    T = HDD_SAMPLED_DATA_TS / 4
    mf = reference_model(1.1e5, T, MF_DELAY)
    zz = np.exp(2j * np.pi * np.array([100.0, 1000.0, 5000.0]) * T)
    got = np.array([complex(mf(z)) for z in zz])
    np.testing.assert_allclose(got, mf_by_hand(1.1e5, T, MF_DELAY), rtol=1e-8)


def test_crossover_normalisation_and_margins():
    setup = tdof_setup()
    T = setup.tau_fb
    z = np.exp(2j * np.pi * 1000.0 * T)
    loop = complex(setup.plant.discretize(T)(z) * setup.controller(z))
    assert abs(loop) == pytest.approx(1.0, rel=1e-9)
    # §4.5.4.1: more than 40 deg phase margin at 1 kHz.
    assert 180 + np.degrees(np.angle(loop)) > 40
    # gain scaling is linear in the plant gain
    base = hdd_sampled_data()
    ctrl = controller_fig_4_57(T)
    assert crossover_gain(base.replace(gain=2 * base.gain), ctrl, 1000.0) == pytest.approx(
        crossover_gain(base, ctrl, 1000.0), rel=1e-9
    )


def test_residual_amplitude_recovers_synthetic_vibration():
    t = np.linspace(0, 6e-3, 6001)
    w = 2 * np.pi * 4100
    s = np.clip(t - 2e-3, 0, None)
    y = 0.3 * np.exp(-0.01 * w * s) * np.sin(w * s + 0.4) + 0.05 * (s / 1e-3) ** 2 - 0.1
    assert residual_amplitude(t, y, 2e-3, 4100.0, 0.01, 2e-3) == pytest.approx(0.3, rel=1e-6)


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    return hdd_residual_case(tmp_path_factory.mktemp("hdd_residual"))


def test_case_registered_and_all_book_numbers(case):
    assert "hdd-residual" in registry()
    bad = [(c.quantity, c.book, c.servokit) for c in case.comparisons if not c.ok]
    # rows resting on a fitted parameter are judged at the printed precision and may
    # miss by it; they stay within 1 % (the fit is not exact)
    assert all(c.kind == "fitted" for c in case.comparisons if not c.ok), bad
    assert all(abs(c.ratio - 1) < 0.01 for c in case.comparisons if c.kind == "fitted")
    assert len(case.comparisons) >= 10  # Mf of (4.75), margins, SRS/simulation ordering
    for path in case.figures:
        assert path.stat().st_size > 10_000


def test_case_seek_ordering_and_settling(case):
    seeks = case.extra["seeks"]
    srs = [s["srs_at_4100Hz"] for s in seeks]
    resid = [s["residual_4100Hz_tracks"] for s in seeks]
    peak = [s["peak_error_after_seek_tracks"] for s in seeks]
    settle = [s["settling_time_s"] for s in seeks]
    # §4.5.4.3-4: 115 us smallest, 230 us largest, 307 us between - SRS and simulation.
    for values in (srs, resid, peak, settle):
        assert values[0] < values[2] < values[1]
    assert case.extra["tau_fb_s"] == pytest.approx(HDD_SAMPLED_DATA_TS / 4)
    assert case.extra["gain_margin_db"] > 5.0  # "a gain margin of more than 5 dB"
    # every seek ends within the band: the loop settles on the 500-track target
    assert all(np.isfinite(settle)) and max(settle) < 12e-3


@pytest.mark.slow
def test_cached_mf_search_is_what_the_search_finds():
    # the reproduce rows cite MF_SEARCH; re-run the (tau_fb, delay) grid search behind it
    from servokit.cases.hdd_residual import MF_SEARCH, mf_search

    assert mf_search() == MF_SEARCH
    assert MF_SEARCH["worst_units"] > 0.5  # no grid point reproduces every printed digit
