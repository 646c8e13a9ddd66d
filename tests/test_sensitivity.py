"""Sampled-data sensitivity (book §4.2, eqs. 4.4-4.38) and the multirate path."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.models import (
    HDD_SAMPLED_DATA_TS,
    ModalPlant,
    Mode,
    controller_eq_4_69,
    hdd_sampled_data,
)
from servokit.sampled import (
    Multirate,
    discrete_plant,
    gamma_terms,
    sampled_data_sensitivity,
    sensitivity_plot,
    zoh_response,
)
from servokit.sampled.sensitivity import _alias_sums

TS = HDD_SAMPLED_DATA_TS
FS = 1.0 / TS


def _multirate_4_68(m: int = 4) -> Multirate:
    h = TS / m
    wf = 2 * np.pi * 3600.0
    fmc = 1 - control.tf([0.1, 0, 0], [1, 2 * 0.003 * wf, wf**2])
    fm = control.sample_system(fmc, h, method="tustin", prewarp_frequency=wf)
    ip = control.tf([1, 1, 1, 1], [1, 0, 0, 0], h)
    return Multirate(m, interpolator=ip, filter=fm)


@pytest.fixture(scope="module")
def hdd():
    return hdd_sampled_data(), controller_eq_4_69()


def _pc_freqresp(sys: control.LTI, f: np.ndarray) -> np.ndarray:
    """python-control's own evaluation of a discrete LTI at z = e^{j 2 pi f dt}."""
    return np.asarray(sys(np.exp(2j * np.pi * np.asarray(f) * sys.dt))).reshape(-1)


# ------------------------------------------------------------------ holds
def test_zoh_response_closed_form():
    f = np.array([0.0, 1.0, 1234.5, 2 * FS, -700.0])
    h = zoh_response(f, TS)
    w = 2 * np.pi * f[1:]
    np.testing.assert_allclose(h[1:], (1 - np.exp(-1j * w * TS)) / (1j * w), rtol=1e-12)
    assert h[0] == pytest.approx(TS)
    assert abs(h[3]) < 1e-18  # a zero of the hold at every multiple of 1/Ts


def test_default_multirate_is_a_zero_order_hold():
    # Ip = 1 + ... + z^-(m-1) after zero insertion, held for Ts/m, equals a ZOH at Ts
    f = np.linspace(5.0, 3 * FS, 97)
    np.testing.assert_allclose(
        Multirate(4).response(f, TS), zoh_response(f, TS), rtol=1e-10, atol=1e-18
    )
    plant = hdd_sampled_data()
    lifted = Multirate(4).discretize(plant, TS)
    direct = plant.discretize(TS)
    g = np.linspace(20.0, 0.49 * FS, 41)
    np.testing.assert_allclose(_pc_freqresp(lifted, g), _pc_freqresp(direct, g), rtol=1e-8)


def test_lifted_model_obeys_decimation_identity():
    # Pdm(e^{jwTs}) = 1/m sum_r G_h(e^{j(wTs - 2 pi r)/m}) for zero insertion + decimation
    mr = _multirate_4_68()
    plant = hdd_sampled_data()
    h = TS / 4
    g_fast = control.series(mr.chain(TS), plant.discretize(h))
    f = np.linspace(30.0, 0.45 * FS, 23)
    expect = sum(_pc_freqresp(g_fast, f - r / TS) for r in range(4)) / 4
    np.testing.assert_allclose(_pc_freqresp(mr.discretize(plant, TS), f), expect, rtol=1e-7)


def test_filter_4_68_resonates_at_3600_hz():
    mr = _multirate_4_68()
    mag = np.abs(_pc_freqresp(mr.filter, np.array([3600.0, 100.0])))
    # Fmc(j wf) = 1 - 0.1 wf^2/(j 2 zeta wf^2) = 1 + j 0.1/(2 zeta); prewarping keeps it exact
    assert mag[0] == pytest.approx(abs(1 + 0.1j / (2 * 0.003)), rel=1e-6)
    assert mag[1] == pytest.approx(1.0, abs=0.01)


# --------------------------------------------------------- alias sum of Pd
def test_alias_sum_matches_python_control_discretisation(hdd):
    plant, _ = hdd
    f = np.array([13.0, 250.0, 1999.0, 3100.0, 3257.0])
    g0, gsum, gabs, used, tail = _alias_sums(plant, Multirate(1), TS, f, 1e-7, 1 << 15, None)
    exact = _pc_freqresp(plant.discretize(TS), f)
    np.testing.assert_allclose(gsum, exact, rtol=1e-6)
    assert tail <= 1e-7 and used >= 8
    assert np.all(gabs >= np.abs(gsum) - 1e-12 * gabs)


def test_alias_sum_multirate_matches_lifted_model(hdd):
    plant, _ = hdd
    mr = _multirate_4_68()
    f = np.array([40.0, 1500.0, 3000.0])
    _, gsum, _, _, _ = _alias_sums(plant, mr, TS, f, 1e-7, 1 << 15, None)
    np.testing.assert_allclose(gsum, _pc_freqresp(mr.discretize(plant, TS), f), rtol=1e-6)


def test_rigid_body_pd_closed_form():
    # ZOH of K/s^2: Pd(z) = K Ts^2 (z + 1) / (2 (z - 1)^2)
    k = 2.5e6
    plant = ModalPlant(k, (Mode(0.0, 0.0, 1.0),))
    f = np.array([7.0, 330.0, 1800.0, 3000.0])
    _, gsum, _, _, _ = _alias_sums(plant, Multirate(1), TS, f, 1e-8, 1 << 15, None)
    z = np.exp(2j * np.pi * f * TS)
    np.testing.assert_allclose(gsum, k * TS**2 * (z + 1) / (2 * (z - 1) ** 2), rtol=1e-7)


def test_alias_terms_decay_like_inverse_cube(hdd):
    plant, ctrl = hdd
    gam = gamma_terms(plant, ctrl, TS, [700.0], [200, 400, -200, -400])[0]
    # |W Pc| ~ 1/w * 1/w^2 far above the modes
    assert abs(gam[1] / gam[0]) == pytest.approx(1 / 8, rel=0.02)
    assert abs(gam[3] / gam[2]) == pytest.approx(1 / 8, rel=0.02)


# --------------------------------------------------------------- identities
@settings(max_examples=30, deadline=None)
@given(st.floats(min_value=5.0, max_value=20000.0))
def test_identities_hold_at_any_frequency(f):
    plant, ctrl = hdd_sampled_data(), controller_eq_4_69()
    if min(abs(f * TS - k) for k in range(4)) < 1e-4:
        return  # a rigid-body alias at a multiple of 1/Ts is a pole
    r = sampled_data_sensitivity(plant, ctrl, TS, [f], multirate=_multirate_4_68())
    np.testing.assert_allclose(r.Sd + r.Td, 1.0, atol=1e-12)  # (4.15) + (4.22)
    # (4.38): |Ssd| = |Tsd| - |Gamma0| + |1 + Gamma0|
    rhs = r.Tsd - np.abs(r.gamma0) + np.abs(1 + r.gamma0)
    np.testing.assert_allclose(r.Ssd, rhs, rtol=1e-9, atol=1e-12)
    # triangle inequality: sampled-data gains bound the discrete ones
    assert np.all(r.T_delta >= -1e-6 * r.Tsd) and np.all(r.S_delta >= -1e-6 * r.Ssd)
    # (4.14) |Tsd| periodic with 1/Ts, |Sd| too
    r2 = sampled_data_sensitivity(plant, ctrl, TS, [f + FS], multirate=_multirate_4_68())
    np.testing.assert_allclose(r2.Tsd, r.Tsd, rtol=1e-5)
    np.testing.assert_allclose(np.abs(r2.Sd), np.abs(r.Sd), rtol=1e-9)


def test_sum_of_gammas_is_minus_td(hdd):
    plant, ctrl = hdd
    f = np.array([120.0, 2500.0])
    orders = np.arange(-3000, 3001)
    gam = gamma_terms(plant, ctrl, TS, f, orders)
    r = sampled_data_sensitivity(plant, ctrl, TS, f)
    np.testing.assert_allclose(gam.sum(axis=1), -r.Td, rtol=1e-6)  # (4.15)
    np.testing.assert_allclose(np.abs(gam).sum(axis=1), r.Tsd, rtol=1e-6)  # (4.13)
    np.testing.assert_allclose(r.gamma0, gam[:, 3000], rtol=1e-12)


def test_ssd_below_one_implies_above_one_at_aliases(hdd):
    # (4.20): |Ssd(w0)| < 1 => |Ssd(w0 + l ws)| > 1 for l != 0
    plant, ctrl = hdd
    f0 = np.array([50.0, 200.0, 400.0])
    r = sampled_data_sensitivity(plant, ctrl, TS, f0)
    assert np.all(r.Ssd < 1)
    for l in (1, 2, 3):
        assert np.all(sampled_data_sensitivity(plant, ctrl, TS, f0 + l * FS).Ssd > 1)
    # (4.21): |Ssd| ~ 0 at w0 gives |Ssd| ~ 2 at its aliases
    assert sampled_data_sensitivity(plant, ctrl, TS, [50.0 + FS]).Ssd[0] == pytest.approx(
        2.0, abs=0.1
    )


def test_slow_loop_is_nearly_discrete():
    # a loop far below Nyquist: aliases are negligible and Ssd ~ |Sd|, Tsd ~ |Td|
    dt = 1e-4
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),))
    wc = 2 * np.pi * 20.0
    # lead with crossover wc, 1/500 of the sampling rate
    ctrl = control.sample_system(control.tf([3 * wc**2, wc**3], [1, 3 * wc]), dt, "tustin")
    f = np.array([1.0, 5.0, 20.0])
    r = sampled_data_sensitivity(plant, ctrl, dt, f)
    np.testing.assert_allclose(r.Ssd, np.abs(r.Sd), rtol=1e-5)
    np.testing.assert_allclose(r.Tsd, np.abs(r.Td), rtol=1e-5)
    assert np.all(r.gamma_sum < 1e-6 * r.Tsd + 1e-9)


def test_band_limit_of_4_62_is_close_to_full_sum(hdd):
    plant, ctrl = hdd
    mr = _multirate_4_68()
    f = np.array([500.0, 3600.0])
    full = sampled_data_sensitivity(plant, ctrl, TS, f, multirate=mr)
    cut = sampled_data_sensitivity(plant, ctrl, TS, f, multirate=mr, band_limit_hz=2 * FS)
    assert cut.alias_terms == 3
    np.testing.assert_allclose(cut.Ssd, full.Ssd, rtol=0.02)
    np.testing.assert_allclose(cut.Tsd, full.Tsd, rtol=0.02)
    assert np.all(cut.Tsd <= full.Tsd)


# ------------------------------------------------------------------ errors
def test_unstable_closed_loop_raises(hdd):
    plant, ctrl = hdd
    with pytest.raises(ServokitValueError, match="unstable"):
        sampled_data_sensitivity(plant, 30 * ctrl, TS, [100.0])


def test_bad_arguments_raise(hdd):
    plant, ctrl = hdd
    with pytest.raises(ServokitValueError, match="controller_d must be discrete"):
        sampled_data_sensitivity(plant, control.tf([1], [1, 1]), TS, [100.0])
    with pytest.raises(ServokitValueError, match="controller_d has dt"):
        sampled_data_sensitivity(plant, control.tf([0.5], [1, -0.5], 1e-4), TS, [100.0])
    with pytest.raises(ServokitValueError, match="freq_hz"):
        sampled_data_sensitivity(plant, ctrl, TS, [0.0, 100.0])
    with pytest.raises(ServokitValueError, match="freq_hz"):
        sampled_data_sensitivity(plant, ctrl, TS, [np.nan])
    with pytest.raises(ServokitTypeError, match="plant"):  # python-control LTIs are accepted
        sampled_data_sensitivity("hdd-sampled-data", ctrl, TS, [100.0])
    with pytest.raises(ServokitValueError, match="not converged"):
        sampled_data_sensitivity(plant, ctrl, TS, [100.0, 3000.0], tol=1e-12, max_terms=16)
    with pytest.raises(ServokitValueError, match="interpolator has dt"):
        sampled_data_sensitivity(
            plant, ctrl, TS, [100.0], multirate=Multirate(2, control.tf([1, 1], [1, 0], TS / 4))
        )
    with pytest.raises(ServokitValueError, match="m must be >= 1"):
        Multirate(0)
    with pytest.raises(ServokitTypeError, match="filter"):
        Multirate(2, filter=np.array([1.0, 2.0]))
    with pytest.raises(ServokitValueError, match="hold"):
        Multirate(2, hold="foh")


def test_discrete_plant_dispatch(hdd):
    plant, _ = hdd
    assert discrete_plant(plant, TS).nstates == plant.discretize(TS).nstates
    assert discrete_plant(plant, TS, _multirate_4_68()).nstates > plant.discretize(TS).nstates


def test_sensitivity_plot_writes_png(tmp_path, hdd):
    plant, ctrl = hdd
    r = sampled_data_sensitivity(plant, ctrl, TS, np.linspace(10, 6000, 200))
    out = tmp_path / "s.png"
    sensitivity_plot(r, quantities=("Ssd", "Tsd", "S_delta"), filename=str(out))
    assert out.stat().st_size > 10_000
    with pytest.raises(ServokitValueError, match="quantities"):
        sensitivity_plot(r, quantities=("nope",))
    d = r.to_dict()
    assert set(d) >= {"Ssd", "Tsd", "Sd_mag", "Td_mag", "gamma_sum"}


# ------------------------------------------------- brute-force simulation
@settings(max_examples=5, deadline=None)
@given(st.floats(min_value=100.0, max_value=12000.0), st.booleans())
def test_steady_state_matches_hybrid_simulation(f, use_multirate):
    """The alias-sum response (4.27)-(4.31) against the lead's hybrid simulator."""
    from servokit.sampled import sinusoid_response
    from servokit.simulate import simulate

    if min(abs(f * TS - k) for k in range(3)) < 1e-3:
        return
    plant, ctrl = hdd_sampled_data(), controller_eq_4_69()
    mr = _multirate_4_68() if use_multirate else None
    kw = {"multirate": (4, mr.chain(TS))} if use_multirate else {}
    n = 800
    res = simulate(
        plant,
        dt=TS,
        n_samples=n,
        substeps=8,
        controller=ctrl,
        output_disturbance=lambda t: np.sin(2 * np.pi * f * t),
        **kw,
    )
    keep = res.t >= 0.5 * n * TS
    ss = sinusoid_response(plant, ctrl, TS, f, res.t[keep], multirate=mr)
    np.testing.assert_allclose(res.yc[0, keep], ss.yc, atol=2e-5)
    ks = res.td >= 0.5 * n * TS
    np.testing.assert_allclose(res.yd[0, ks], ss.yd, atol=2e-5)
    np.testing.assert_allclose(ss.td, res.td[ks], rtol=1e-12)
    r = sampled_data_sensitivity(plant, ctrl, TS, [f], multirate=mr)
    # the infinity-norm ratios are bounded by the alias sums (4.13), (4.17)
    assert np.max(np.abs(ss.yc)) <= r.Ssd[0] * (1 + 1e-6)
    assert np.max(np.abs(ss.yc0)) <= r.Tsd[0] * (1 + 1e-6)
    assert np.max(np.abs(ss.yd)) <= abs(r.Sd[0]) * (1 + 1e-6)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 9), st.integers(1, 60), st.integers(0, 2**32 - 1))
def test_eval_discrete_shifted_matrices_as_before(n, n_points, seed):
    """``z I - A`` built by a diagonal update (demo speed-up): the same response as the
    ``z[:, None, None] * eye - A`` construction it replaced, bit for bit."""
    from servokit.sampled.multirate import eval_discrete

    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * rng.choice([1e-3, 1.0, 1e3])
    A[rng.uniform(size=(n, n)) < 0.3] = 0.0
    B, C, D = rng.standard_normal((n, 1)), rng.standard_normal((1, n)), rng.standard_normal()
    z = np.exp(2j * np.pi * rng.uniform(0, 0.5, n_points)) * rng.choice([0.5, 1.0, 3.0])
    sys = control.ss(A, B, C, D, 1e-3)
    x = np.linalg.solve(z[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (z.size, n, 1)))
    np.testing.assert_array_equal(eval_discrete(sys, z), (C @ x)[:, 0, 0] + D)
