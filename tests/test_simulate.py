"""Hybrid simulator: exactness against python-control and brute force, metrics, errors."""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.models import HDD_BENCHMARK_TS, HDD_SAMPLED_DATA_TS, ModalPlant, Mode
from servokit.simulate import seek_time, settling_time, simulate, step_metrics


def test_open_loop_matches_python_control_on_fine_grid():
    plants = sk.models.hdd_benchmark_variants()[:5]
    S = 10
    h = HDD_BENCHMARK_TS / S
    u = np.random.default_rng(1).standard_normal(25) * 1e-3
    res = simulate(plants, dt=HDD_BENCHMARK_TS, n_samples=50, substeps=S, feedforward=u)
    ufine = np.zeros(50 * S)
    ufine[: 25 * S] = np.repeat(u, S)
    for p, y in zip(plants, res.yc, strict=True):
        ref = control.forced_response(p.discretize(h), U=ufine).outputs
        assert np.max(np.abs(y - ref)) / np.max(np.abs(ref)) < 1e-12
    assert np.array_equal(res.yd, res.yc[:, ::S])


def test_rigid_body_intersample_is_exact_parabola():
    plant = ModalPlant(1.0, (Mode(0, 0, 1),), delay=0.3e-3)
    res = simulate(plant, dt=1e-3, n_samples=4, substeps=20, feedforward=[1.0])
    tau = np.clip(res.t - 0.3e-3, 0, None)
    expected = np.where(tau < 1e-3, tau**2 / 2, 1e-3**2 / 2 + 1e-3 * (tau - 1e-3))
    assert np.allclose(res.yc[0], expected, rtol=1e-12, atol=1e-18)


def test_closed_loop_samples_match_python_control_feedback():
    plant = sk.models.hdd_sampled_data()
    C = sk.models.controller_eq_4_69()
    K = 300
    res = simulate(
        plant, dt=HDD_SAMPLED_DATA_TS, n_samples=K, substeps=4, controller=C, reference=np.ones(K)
    )
    cl = control.feedback(plant.discretize(HDD_SAMPLED_DATA_TS) * C, 1)
    ref = control.forced_response(cl, U=np.ones(K)).outputs
    assert np.max(np.abs(res.yd[0] - ref)) < 1e-10


def _brute_force_multirate(plant, C, F, m, S, K, dt, ff, ff_q):
    """Step-by-step reference: fine-step python-control model, controller every S steps,
    multirate filter every S/m steps with zero insertion, feedforward held ff_q steps."""
    h = dt / S
    Pd = control.ss(plant.discretize(h))
    Cs, Fs = control.ss(C), control.ss(F)
    xp = np.zeros(Pd.nstates)
    xc = np.zeros(Cs.nstates)
    xf = np.zeros(Fs.nstates)
    y = np.zeros(K * S)
    fb = 0.0
    for j in range(K * S):
        y[j] = (Pd.C @ xp)[0]
        if j % S == 0:
            e = -y[j]
            ufb = (Cs.C @ xc)[0] + Cs.D[0, 0] * e
            xc = Cs.A @ xc + Cs.B[:, 0] * e
        if j % (S // m) == 0:
            inp = ufb if j % S == 0 else 0.0
            fb = (Fs.C @ xf)[0] + Fs.D[0, 0] * inp
            xf = Fs.A @ xf + Fs.B[:, 0] * inp
        uff = ff[j // ff_q] if j // ff_q < len(ff) else 0.0
        xp = Pd.A @ xp + Pd.B[:, 0] * (fb + uff)
    return y


def test_multirate_loop_matches_brute_force():
    plant = sk.models.hdd_sampled_data()
    dt, m, S = HDD_SAMPLED_DATA_TS, 4, 8
    C = sk.models.controller_eq_4_69()
    Ip = control.tf([1, 1, 1, 1], [1, 0, 0, 0], dt / m)
    F = Ip * control.tf([0.5, 0.2], [1, -0.3], dt / m)
    ff = np.array([1e-3, -2e-3, 0.5e-3, 1e-3])
    res = simulate(
        plant,
        dt=dt,
        n_samples=40,
        substeps=S,
        controller=C,
        multirate=(m, F),
        feedforward=ff,
        ff_dt=3 * dt / S,
    )
    ref = _brute_force_multirate(plant, C, F, m, S, 40, dt, ff, 3)
    assert np.max(np.abs(res.yc[0] - ref)) / np.max(np.abs(ref)) < 1e-9


def test_output_and_input_disturbance():
    plant = ModalPlant(1.0, (Mode(0, 0, 1),))
    dc = lambda t: np.sin(2 * np.pi * 100 * t)  # noqa: E731
    res = simulate(
        plant,
        dt=1e-3,
        n_samples=5,
        substeps=10,
        output_disturbance=dc,
        input_disturbance=lambda t: np.ones_like(t),
    )
    assert np.allclose(res.yc[0], res.t**2 / 2 + dc(res.t), atol=1e-15)


@settings(max_examples=20, deadline=None)
@given(
    f=st.floats(200.0, 8000.0),
    z=st.floats(0.005, 0.3),
    r=st.floats(-1.5, 1.5),
    delay_frac=st.floats(0.0, 2.5),
    S=st.integers(1, 12),
    seed=st.integers(0, 1000),
)
def test_random_plants_match_python_control(f, z, r, delay_frac, S, seed):
    dt = 1e-4
    plant = ModalPlant(1e6, (Mode(0, 0, 1), Mode(f, z, r)), delay=delay_frac * dt)
    u = np.random.default_rng(seed).standard_normal(10)
    res = simulate([plant, plant.replace(gain=2e6)], dt=dt, n_samples=20, substeps=S, feedforward=u)
    ufine = np.zeros(20 * S)
    ufine[: 10 * S] = np.repeat(u, S)
    ref = control.forced_response(plant.discretize(dt / S), U=ufine).outputs
    scale = np.max(np.abs(ref))
    assert np.max(np.abs(res.yc[0] - ref)) / scale < 1e-10
    assert np.max(np.abs(res.yc[1] - 2 * ref)) / scale < 2e-10


def test_settling_time_definition():
    t = np.arange(10.0)
    y = np.array([0, 0.5, 1.2, 0.95, 1.05, 1.2, 1.0, 1.0, 1.05, 0.92])
    assert settling_time(t, y, 1.0, 0.1)[0] == 6.0
    assert settling_time(t, np.ones(10), 1.0, 0.1)[0] == 0.0
    assert np.isinf(settling_time(t, np.zeros(10), 1.0, 0.1)[0])
    m = step_metrics(t, y, 1.0, 0.1)
    assert m.peak[0] == 1.2 and m.overshoot[0] == pytest.approx(0.2)


@dataclass
class _Held:
    u: np.ndarray
    dt: float


def test_seek_time_of_a_bang_bang_on_rigid_body():
    # rigid body K/s^2: +a for T, -a for T moves exactly a K T^2 and stops
    dt = 1e-4
    plant = ModalPlant(1e4, (Mode(0, 0, 1),))
    a, n = 1.0, 5
    ff = _Held(np.r_[np.full(n, a), np.full(n, -a)], dt)
    target = a * 1e4 * (n * dt) ** 2
    st_ = seek_time(plant, ff, target, band=0.01 * target, grid=dt / 50)
    assert 0.8 * 2 * n * dt < st_[0] <= 2 * n * dt


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"dt": 0.0}, "dt"),
        ({"n_samples": 0}, "n_samples"),
        ({"substeps": 0}, "substeps"),
        ({"feedforward": [1.0], "ff_dt": 1.5e-4 / 7}, "ff_dt"),
        ({"feedforward": [np.nan]}, "feedforward"),
        ({"controller": control.tf([1], [1, 1])}, "discrete"),
        ({"reference": [1.0]}, "controller"),
    ],
)
def test_simulate_errors(kwargs, match):
    base = dict(dt=1e-4, n_samples=5, substeps=4)
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate(sk.models.hdd_benchmark(), **base)


def test_plants_with_different_delays_are_refused():
    p = sk.models.hdd_benchmark()
    with pytest.raises(ValueError, match="delay"):
        simulate([p, p.replace(delay=0.0)], dt=1e-4, n_samples=3)


def test_tdof_nominal_plant_has_zero_feedback_and_open_loop_response():
    from servokit.simulate import tdof_response

    plant = sk.models.hdd_sampled_data()
    dt = HDD_SAMPLED_DATA_TS
    C = sk.models.controller_eq_4_69()
    u = 1e-4 * np.sin(2 * np.pi * np.arange(20) / 20)
    res = tdof_response(
        plant, plant, controller=C, dt=dt, n_samples=80, substeps=6, feedforward=u, ff_dt=dt / 2
    )
    open_loop = simulate(plant, dt=dt, n_samples=80, substeps=6, feedforward=u, ff_dt=dt / 2)
    assert np.max(np.abs(res.sim.yc - open_loop.yc)) < 1e-12 * np.max(np.abs(open_loop.yc))


def test_tdof_reference_is_the_discretised_model_output():
    from servokit.simulate import tdof_response

    nominal = sk.models.hdd_sampled_data()
    plants = [nominal.replace(gain=0.9 * nominal.gain), nominal.replace(gain=1.1 * nominal.gain)]
    dt = HDD_SAMPLED_DATA_TS
    C = sk.models.controller_eq_4_69()
    u = 1e-4 * np.sin(2 * np.pi * np.arange(12) / 12)
    res = tdof_response(
        plants, nominal, controller=C, dt=dt, n_samples=200, substeps=4, feedforward=u, ff_dt=2 * dt
    )
    # M(z): exact ZOH discretisation of the nominal model with its delay (cf. eq. 4.75)
    held = np.zeros(200)
    held[:24] = np.repeat(u, 2)
    ym = control.forced_response(nominal.discretize(dt), U=held).outputs
    assert np.max(np.abs(res.reference - ym)) < 1e-12 * np.max(np.abs(ym))
    # feedback pulls the perturbed plants towards the model: smaller error than open loop
    ol = simulate(plants, dt=dt, n_samples=200, substeps=4, feedforward=u, ff_dt=2 * dt)
    err_fb = np.abs(res.sim.yd - ym).max()
    err_ol = np.abs(ol.yd - ym).max()
    assert err_fb < 0.5 * err_ol


def test_unstable_loop_is_refused():
    plant = sk.models.hdd_sampled_data()
    dt = HDD_SAMPLED_DATA_TS / 4
    C = sk.models.controller_fig_4_57(dt)  # sized for a different plant gain (§4.5.4)
    with pytest.raises(ValueError, match="unstable"):
        simulate(plant, dt=dt, n_samples=10, controller=C)
    with pytest.raises(ValueError, match="overflowed"):
        simulate(
            plant,
            dt=dt,
            n_samples=4000,
            controller=C,
            check_stability=False,
            reference=np.ones(4000),
        )


def test_multirate_stability_check_matches_simulated_growth():
    plant = sk.models.hdd_sampled_data()
    dt, m = HDD_SAMPLED_DATA_TS, 4
    C = sk.models.controller_eq_4_69()
    Ip = control.tf([1, 1, 1, 1], [1, 0, 0, 0], dt / m)
    res = simulate(
        plant,
        dt=dt,
        n_samples=400,
        substeps=4,
        controller=C,
        multirate=(m, Ip),
        reference=np.ones(400),
    )
    assert abs(res.yd[0, -1] - 1.0) < 1e-3  # stable, integral action
    with pytest.raises(ValueError, match="unstable"):
        simulate(plant, dt=dt, n_samples=10, substeps=4, controller=C, multirate=(m, 8 * Ip))


def test_metrics_and_simulate_reject_bad_arguments():
    with pytest.raises(ValueError, match="target"):
        settling_time(np.arange(3.0), np.zeros(3), np.nan, 0.1)
    with pytest.raises(TypeError, match="n_samples"):
        simulate(sk.models.hdd_benchmark(), dt=1e-4, n_samples="a")
    improper = control.tf([1.0, 2.0, 3.0], [1.0, 0.5], 1e-4)
    with pytest.raises(ValueError, match="not proper"):
        simulate(sk.models.hdd_benchmark(), dt=1e-4, n_samples=3, controller=improper)
