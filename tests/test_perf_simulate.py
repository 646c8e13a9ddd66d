"""Fast simulator paths against the paths they replace (issue 8).

Closed-form modal ZOH vs the matrix exponential, batched stability vs python-control's
per-variant poles, chunked vs one-shot simulation, stacked discrete models vs
``ModalPlant.discretize``.  No timings here: speed is measured by ``make bench``.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
import scipy.linalg
from hypothesis import example, given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.models import HDD_SAMPLED_DATA_TS, ModalPlant, Mode
from servokit.models._zoh import delayed_zoh, modal_delayed_zoh, modal_zoh
from servokit.simulate import iter_simulate, seek_time, settling_time, simulate, simulate_metrics
from servokit.simulate._bank import PlantBank
from servokit.simulate.stability import spectral_radii


def _balanced_error(w, z, r, t):
    """Max error of the closed form vs scipy expm, scaled by D = diag(1, max(w, 1/t))."""
    A = np.array([[0.0, 1.0, 0.0], [-w * w, -2 * z * w, r], [0.0, 0.0, 0.0]]) * t
    E = scipy.linalg.expm(A)
    Phi, G = modal_zoh(w, z, r, t)
    s = max(w, 1.0 / t)
    D = np.array([1.0, s])
    eP = np.abs((Phi - E[:2, :2]) * D[None, :] / D[:, None]).max()
    eG = np.abs((G - E[:2, 2]) / D).max() * s * s / abs(r)
    return max(eP, eG)


@settings(max_examples=80, deadline=None)
@given(
    w=st.one_of(st.just(0.0), st.floats(1.0, 1e6)),
    z=st.one_of(st.just(0.0), st.just(1.0), st.floats(0.0, 3.0)),
    r=st.floats(0.1, 10.0) | st.floats(-10.0, -0.1),
    log_t=st.floats(-8.0, -2.0),
)
def test_modal_zoh_matches_expm(w, z, r, log_t):
    t = 10.0**log_t
    # the phase w t itself carries a rounding of eps * w t, in both computations
    assert _balanced_error(w, z, r, t) < 1e-13 * (1.0 + w * t)


def test_modal_zoh_hand_cases():
    # rigid body: Phi = [[1, t], [0, 1]], Gamma = r [t^2/2, t]
    Phi, G = modal_zoh(0.0, 0.0, 3.0, 0.5)
    assert np.array_equal(Phi, [[1.0, 0.5], [0.0, 1.0]])
    assert np.allclose(G, [3 * 0.125, 1.5], rtol=1e-15)
    # undamped oscillator, quarter period: Phi = [[0, 1/w], [-w, 0]], Gamma = r [1/w^2, 1/w]
    w = 2.0
    Phi, G = modal_zoh(w, 0.0, 1.0, np.pi / 2 / w)
    assert np.allclose(Phi, [[0, 1 / w], [-w, 0]], atol=1e-15)
    assert np.allclose(G, [1 / w**2, 1 / w], atol=1e-15)


@settings(max_examples=12, deadline=None)
@given(delay_frac=st.floats(0.0, 3.0), seed=st.integers(0, 10_000))
@example(delay_frac=0.08999495348426681, seed=600)  # a small-Gamma mode: 1.4e-12 of its row
def test_modal_delayed_zoh_matches_expm_path(delay_frac, seed):
    rng = np.random.default_rng(seed)
    w = np.r_[0.0, 2 * np.pi * rng.uniform(100, 3e4, 5)]
    z = np.r_[0.0, rng.uniform(0, 0.3, 5)]
    r = rng.uniform(-2, 2, 6) * 1e6
    h = 1e-5
    A = np.zeros((6, 2, 2))
    A[:, 0, 1], A[:, 1, 0], A[:, 1, 1] = 1.0, -(w**2), -2 * z * w
    B = np.zeros((6, 2, 1))
    B[:, 1, 0] = r
    ref = delayed_zoh(A, B, h, delay_frac * h)
    new = modal_delayed_zoh(w, z, r, h, delay_frac * h)
    assert new[3] == ref[3]
    # as in test_modal_zoh_matches_expm: the phase w h carries a rounding of eps * w h in
    # both computations, so the per-mode tolerance grows with (1 + w h)
    phase = 1.0 + w * h
    for a, b in ((new[0], ref[0]), (new[1], ref[1][..., 0]), (new[2], ref[2][..., 0])):
        scale = np.abs(b).max(axis=-1, keepdims=True) + 1e-300
        per_mode = phase.reshape((-1,) + (1,) * (scale.ndim - 1))
        assert np.all(np.abs(a - b) <= 1e-12 * scale * per_mode)


def test_bank_discrete_matches_modal_plant_discretize():
    plants = sk.models.hdd_benchmark_variants()[:3] + [sk.models.hdd_benchmark().rigid_body()]
    plants = [p.replace(delay=plants[0].delay) for p in plants]
    dt = 3e-5
    A, B, C = PlantBank.build(plants, dt / 4).discrete(dt)
    for v, p in enumerate(plants):
        ref = p.discretize(dt)
        n = ref.nstates - (ref.nstates - 2 * len(p.modes))  # modal part of the reference
        n_del = ref.nstates - n
        keep = np.r_[np.arange(n), A.shape[1] - n_del + np.arange(n_del)]
        assert np.allclose(
            A[v][np.ix_(keep, keep)], ref.A, rtol=1e-12, atol=1e-12 * np.abs(ref.A).max()
        )
        assert np.allclose(B[v][keep], ref.B[:, 0], rtol=1e-12, atol=1e-14)
        assert np.array_equal(C[keep], ref.C[0])


def _pc_spectral_radius(p, C, dt, multirate=None):
    """The replaced path: python-control discretise / series / feedback / poles."""
    if multirate is None:
        g = control.ss(p.discretize(dt))
    else:
        m, F = multirate
        fast = control.ss(p.discretize(dt / m)) * control.ss(F)
        Am1 = np.linalg.matrix_power(fast.A, m - 1)
        g = control.ss(Am1 @ fast.A, Am1 @ fast.B, fast.C, fast.D, dt)
    return np.abs(control.poles(control.feedback(g * control.ss(C), 1))).max()


@pytest.mark.parametrize("multirate", [None, 2, 4])
def test_batched_stability_matches_python_control(multirate):
    nominal = sk.models.hdd_sampled_data()
    plants = [nominal.replace(gain=g * nominal.gain) for g in (0.3, 1.0, 2.5, 6.0)]
    dt = HDD_SAMPLED_DATA_TS
    C = sk.models.controller_eq_4_69()
    Cs = control.ss(C)
    ctrl = (Cs.A, Cs.B[:, 0], Cs.C[0], float(Cs.D[0, 0]))
    mr = None
    if multirate is not None:
        F = control.tf([1, 1, 1], [1, 0, 0], dt / multirate) * control.tf(
            [0.4], [1, -0.6], dt / multirate
        )
        Fs = control.ss(F)
        mr = (multirate, (Fs.A, Fs.B[:, 0], Fs.C[0], float(Fs.D[0, 0])))
    bank = PlantBank.build(plants, dt / 4)
    rho = spectral_radii(bank, ctrl, dt, mr)
    ref = [_pc_spectral_radius(p, C, dt, None if mr is None else (multirate, F)) for p in plants]
    assert np.allclose(rho, ref, rtol=1e-9)
    assert np.any(np.array(ref) < 1) and np.any(np.array(ref) > 1)  # both sides covered


def test_unstable_variant_is_named():
    nominal = sk.models.hdd_sampled_data()
    plants = [nominal, nominal.replace(gain=6 * nominal.gain, name="hot")]
    with pytest.raises(ValueError, match=r"plants\[1\] \(hot\) is unstable"):
        simulate(
            plants, dt=HDD_SAMPLED_DATA_TS, n_samples=5, controller=sk.models.controller_eq_4_69()
        )


def _close(a, b):
    """Equal up to BLAS blocking order (chunks change matrix sizes)."""
    return np.max(np.abs(a - b)) <= 1e-13 * np.max(np.abs(b))


def _set(n):
    return sk.models.hdd_benchmark_variation_set().monte_carlo(n, seed=7)


def test_chunked_equals_one_shot_open_and_closed_loop():
    plants = _set(40)
    dt = sk.models.HDD_BENCHMARK_TS
    u = 1e-6 * np.sin(np.linspace(0, 2 * np.pi, 12))
    kw = dict(
        dt=dt,
        n_samples=30,
        substeps=8,
        feedforward=u,
        input_disturbance=np.random.default_rng(0).standard_normal((40, 240)) * 1e-9,
    )
    one = simulate(plants, **kw)
    many = simulate(plants, max_memory_mb=1.0 + 40 * 240 * 8 * 2 / 1e6, **kw)
    assert _close(many.yc, one.yc) and np.array_equal(one.u, many.u)
    # closed loop: chunks of the sampled-data plant set with the eq. (4.69) controller
    nominal = sk.models.hdd_sampled_data()
    cl_plants = [nominal.replace(gain=g * nominal.gain) for g in np.linspace(0.8, 1.2, 9)]
    ckw = dict(
        dt=HDD_SAMPLED_DATA_TS,
        n_samples=60,
        substeps=4,
        controller=sk.models.controller_eq_4_69(),
        reference=np.ones(60),
    )
    one = simulate(cl_plants, **ckw)
    chunks = list(iter_simulate(cl_plants, max_memory_mb=0.02, **ckw))
    assert len(chunks) > 1
    for sl, res in chunks:
        assert _close(res.yc, one.yc[sl]) and _close(res.yd, one.yd[sl])


def test_simulate_metrics_equals_metric_of_full_result():
    plants = _set(30)
    dt = sk.models.HDD_BENCHMARK_TS
    u = 1e-6 * np.sin(np.linspace(0, 2 * np.pi, 12))
    kw = dict(dt=dt, n_samples=40, substeps=5, feedforward=u)
    full = simulate(plants, **kw)

    def metric(res):
        return np.c_[np.abs(res.yc).max(axis=1), settling_time(res.t, res.yc, 0.0, 1e-3)]

    got = simulate_metrics(plants, metric, max_memory_mb=0.05, **kw)
    assert _close(got, metric(full))
    with pytest.raises(ValueError, match="one value per variant"):
        simulate_metrics(plants, lambda res: np.zeros(len(res.yc) + 1), **kw)


def test_output_larger_than_budget_is_refused():
    with pytest.raises(ValueError, match="max_memory_mb"):
        simulate(_set(3), dt=1e-4, n_samples=1000, substeps=100, max_memory_mb=1.0)


@settings(max_examples=15, deadline=None)
@given(
    n_modes=st.integers(1, 4),
    delay_frac=st.floats(0.0, 2.5),
    S=st.integers(1, 9),
    seed=st.integers(0, 10_000),
)
def test_random_plant_sets_match_python_control(n_modes, delay_frac, S, seed):
    rng = np.random.default_rng(seed)
    dt = 1e-4
    plants = [
        ModalPlant(
            1e6,
            tuple(
                Mode(f, z, a)
                for f, z, a in zip(
                    rng.uniform(0, 5000, n_modes),
                    rng.uniform(0, 1.5, n_modes),
                    rng.uniform(-1, 1, n_modes),
                    strict=True,
                )
            ),
            delay=delay_frac * dt,
        )
        for _ in range(3)
    ]
    u = rng.standard_normal(8)
    res = simulate(plants, dt=dt, n_samples=16, substeps=S, feedforward=u)
    ufine = np.zeros(16 * S)
    ufine[: 8 * S] = np.repeat(u, S)
    for p, y in zip(plants, res.yc, strict=True):
        ref = control.forced_response(p.discretize(dt / S), U=ufine).outputs
        assert np.max(np.abs(y - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_iter_simulate_argument_errors():
    plant = sk.models.hdd_benchmark()
    with pytest.raises(TypeError, match="unexpected argument"):
        list(iter_simulate(plant, dt=1e-4, n_samples=3, feedfoward=[1.0]))
    with pytest.raises(TypeError, match="n_samples"):
        list(iter_simulate(plant, dt=1e-4))


def test_seek_time_in_chunks_equals_one_shot():
    from dataclasses import dataclass

    from servokit.simulate import seek_response

    @dataclass
    class Held:
        u: np.ndarray
        dt: float

    ff = Held(1e-6 * np.sin(np.linspace(0, 2 * np.pi, 26)), sk.models.HDD_BENCHMARK_TS)
    plants = _set(25)
    res = seek_response(plants, ff)
    target = float(np.median(res.yc[:, -1]))
    ref = settling_time(res.t, res.yc, target, 0.05 * abs(target))
    got = seek_time(plants, ff, target, band=0.05 * abs(target), max_memory_mb=0.2)
    assert np.array_equal(got, ref)


@settings(max_examples=40, deadline=None)
@given(S=st.integers(1, 6), K=st.integers(1, 12), dd=st.integers(0, 7), seed=st.integers(0, 999))
def test_active_periods_match_their_windows(S, K, dd, seed):
    from servokit.simulate._core import _active, _windows

    rng = np.random.default_rng(seed)
    ubuf = np.zeros((2, K * S + dd + 1))
    for _ in range(rng.integers(0, 3)):
        ubuf[rng.integers(0, 2), rng.integers(0, ubuf.shape[1])] = 1.0
    W = _windows(ubuf, S, 0, K)
    nz = np.flatnonzero(np.any(W != 0, axis=(0, 2)))
    expected = slice(0, 0) if nz.size == 0 else slice(int(nz[0]), int(nz[-1]) + 1)
    assert _active(ubuf, S, K) == expected


@settings(max_examples=15, deadline=None)
@given(V=st.integers(1, 5), N=st.integers(1, 6), K=st.integers(1, 70), seed=st.integers(0, 999))
def test_matrix_scan_doubling_equals_serial(V, N, K, seed):
    from servokit.simulate._scan import matrix_scan

    rng = np.random.default_rng(seed)
    A = rng.standard_normal((V, N, N))
    A *= 0.95 / np.abs(np.linalg.eigvals(A)).max(axis=-1)[:, None, None]  # stable
    d = rng.standard_normal((K, V, N))
    serial = matrix_scan(A, d, "serial")
    ref = np.zeros((V, N))
    for k in range(K):  # the recursion written out
        assert np.allclose(serial[:, k], ref, rtol=1e-12, atol=1e-12)
        ref = np.einsum("vij,vj->vi", A, ref) + d[k]
    doubling = matrix_scan(A, d, "doubling")
    assert np.max(np.abs(doubling - serial)) <= 1e-12 * max(np.max(np.abs(serial)), 1.0)


def test_sample_rate_closed_loop_matches_python_control():
    nominal = sk.models.hdd_sampled_data()
    plants = [nominal.replace(gain=g * nominal.gain) for g in (0.9, 1.0, 1.15)] * 4  # > 8
    C = sk.models.controller_eq_4_69()
    K = 200
    for subset in (plants[:1], plants):  # doubling scan, serial scan
        res = simulate(subset, dt=HDD_SAMPLED_DATA_TS, n_samples=K, substeps=1, controller=C,
                       reference=np.ones(K), output_disturbance=np.full(K, 0.01))  # fmt: skip
        assert np.array_equal(res.yc - 0.01, res.yd - 0.01)
        for p, yd in zip(subset, res.yd, strict=True):
            cl = control.feedback(p.discretize(HDD_SAMPLED_DATA_TS) * C, 1)
            ref = control.forced_response(cl, U=np.full(K, 0.99)).outputs + 0.01
            assert np.max(np.abs(yd - ref)) < 1e-12


def _markov(A, B, C, n=25):
    """First ``n`` Markov parameters ``C A^k B`` of one discrete model."""
    out, x = [], B.copy()
    for _ in range(n):
        out.append(C @ x)
        x = A @ x
    return np.array(out)


@settings(max_examples=25, deadline=None)
@given(
    S=st.integers(1, 12),
    f=st.lists(st.floats(0.0, 4e3), min_size=1, max_size=3),
    zeta=st.floats(1e-6, 1.5),
    delay_steps=st.sampled_from([0.0, 0.3, 1.0, 2.75, 4.0, 7.5]),
)
def test_sample_rate_model_from_the_fine_maps_equals_direct_discretisation(
    S, f, zeta, delay_steps
):
    """The Ts model derived from Phi^S and the fine block maps (issue 24) has the impulse
    response of the model discretised at Ts directly (lightly damped, overdamped, rigid
    body; delays fractional, whole fine steps and whole periods)."""
    dt = 1e-4
    modes = tuple(Mode(fi, 0.0 if fi == 0.0 else zeta, 1.0 + i) for i, fi in enumerate(f))
    h = dt / S
    plant = ModalPlant(3.0, modes, delay=delay_steps * h)
    A, B, C = PlantBank.build([plant], h).discrete(dt)
    Ad, Bd, Cd = PlantBank.build([plant], dt).discrete(dt)
    got, ref = _markov(A[0], B[0], C), _markov(Ad[0], Bd[0], Cd)
    assert np.allclose(got, ref, rtol=1e-10, atol=1e-11 * np.abs(ref).max())
