"""The numpy-only cores of the pes, dual-stage, identify and report commands (issue 23)
against python-control and scipy.signal, the libraries they leave unloaded.

Bit-for-bit where the arithmetic is the same (Tustin maps, polynomial products, companion
realisations, the Rosenbrock pencil); to rounding where the sums are grouped differently
(block simulation, FFT convolution, closed-form ZOH, Welch), with hard corners: damping
down to 1e-6, rigid bodies (Jordan blocks at z = 1), unstable systems, huge and tiny
scales.
"""

from __future__ import annotations

import re

import control
import numpy as np
import pytest
import scipy.linalg
import scipy.signal as signal
from hypothesis import example, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.dual_stage_controllers import (
    _addon,
    _pair,
    peak_filter_addon,
    plant_zeros,
    zero_pole_pair,
)
from servokit.feedback.filters import discretize_filter, discretize_filter_data
from servokit.feedback.peak_filtered import (
    PeakFilterSpec,
    peak_filtered_controller,
    peak_filtered_data,
)
from servokit.models import (
    BenchmarkDisturbances,
    ModalPlant,
    Mode,
    benchmark_controller,
    benchmark_controller_data,
    hdd_benchmark,
)
from servokit.models.rational import RationalTF, as_state_space_data
from servokit.sampled.identification import settling_samples
from servokit.simulate import simulate
from servokit.simulate._scan import forced_outputs
from servokit.simulate.pes import (
    pes_closed_loop,
    pes_closed_loop_data,
    track_following_pes,
    welch_psd,
)

DAMPING = st.sampled_from([1e-6, 1e-4, 0.003, 0.05, 0.3, 0.9])
SCALE = st.sampled_from([1e-150, 1e-9, 1.0, 1e9, 1e150])


def _dlsim(A, B, C, D, u):  # noqa: ANN001, ANN202
    """scipy.signal.dlsim's recursion, one step per sample (the reference)."""
    x = np.zeros(A.shape[0])
    y = np.empty((u.shape[0], C.shape[0]))
    for k in range(u.shape[0]):
        y[k] = C @ x + D @ u[k]
        x = A @ x + B @ u[k]
    return y


def _modal_block(radius: float, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return radius * np.array([[c, -s], [s, c]])


@settings(max_examples=60, deadline=None)
@example(  # cond(T) = 4738: 7-sample blocks were 7.7e-10 off the recursion (now halved)
    seed=14746, n_blocks=3, damping=1e-06, corner="stable", n_in=1, K=12, block=7,
    scale=1e-150,
)  # fmt: skip
@given(
    seed=st.integers(0, 2**32 - 1),
    n_blocks=st.integers(1, 4),
    damping=DAMPING,
    corner=st.sampled_from(["stable", "rigid", "unstable"]),
    n_in=st.integers(1, 3),
    K=st.integers(1, 700),
    block=st.sampled_from([1, 7, 64, 1000]),
    scale=SCALE,
)
def test_block_simulation_is_the_step_by_step_recursion(
    seed: int, n_blocks: int, damping: float, corner: str, n_in: int, K: int, block: int,
    scale: float,
) -> None:  # fmt: skip
    rng = np.random.default_rng(seed)
    blocks = []
    for _ in range(n_blocks):  # lightly damped modes: radius exp(-zeta w T)
        angle = rng.uniform(0.01, 3.0)
        blocks.append(_modal_block(np.exp(-damping * angle), angle))
    if corner == "rigid":  # a Jordan block at z = 1: the discrete double integrator
        blocks.append(np.array([[1.0, 1.0], [0.0, 1.0]]))
    elif corner == "unstable":
        blocks.append(np.array([[1.004]]))
    n = sum(b.shape[0] for b in blocks)
    A = np.zeros((n, n))
    i = 0
    for b in blocks:
        A[i : i + b.shape[0], i : i + b.shape[0]] = b
        i += b.shape[0]
    T = rng.standard_normal((n, n)) + 3 * np.eye(n)  # a non-modal basis
    A = T @ A @ np.linalg.inv(T)
    B = scale * rng.standard_normal((n, n_in))
    C = rng.standard_normal((2, n))
    D = scale * rng.standard_normal((2, n_in))
    u = rng.standard_normal((K, n_in))
    got = forced_outputs(A, B, C, D, u, block)
    want = _dlsim(A, B, C, D, u)
    # the same sums grouped differently: rounding relative to the largest output. A^L
    # carries its rounding into every block: harmless for a stable loop (what pes runs,
    # 1e-11), a larger loss for a defective eigenvalue on or outside the unit circle
    # (measured up to 1.1e-8 with blocks of 64 at 252 samples, seed 909780; pes runs the
    # block form only on stable loops). The random basis T amplifies both roundings by up
    # to its condition number (seed 3489186: cond 2738, a stable loop 3.3e-11 apart);
    # a defective eigenvalue by its square (T and T^-1 both enter the rounding of A^L,
    # and a Jordan block turns an eps perturbation into sqrt-eps growth): 300 random
    # rigid loops in this basis measured 1e-11 to 5e-12 x cond^2 (cond 2925: 4.2e-5;
    # hypothesis found cond ~ 300 with 1.08e-152 at a 1.08e-152 tolerance when the
    # factor was linear)
    grow = np.linalg.cond(T) / 100
    rel = 1e-11 * max(1.0, grow) if corner == "stable" else 2e-7 * max(1.0, grow**2)
    tol = rel * np.max(np.abs(want), axis=0) + 1e-300
    assert np.all(np.abs(got - want) <= tol)


def test_block_simulation_matches_python_control_forced_response() -> None:
    sys = control.ss(control.tf([0.2, -0.1, 0.05], [1.0, -1.6, 0.9], 1e-4))
    u = np.random.default_rng(0).standard_normal(3000)
    want = control.forced_response(sys, U=u).outputs
    got = forced_outputs(sys.A, sys.B, sys.C, sys.D, u[:, None])[:, 0]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.max(np.abs(want)))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(16, 5000),
    frac=st.floats(0.01, 1.0),
    scale=SCALE,
    offset=st.floats(-5, 5),
    seed=st.integers(0, 2**32 - 1),
)
def test_welch_psd_is_scipy_welch(
    n: int, frac: float, scale: float, offset: float, seed: int
) -> None:
    x = scale * (offset + np.random.default_rng(seed).standard_normal(n))
    m = max(1, int(frac * n))
    f_ref, p_ref = signal.welch(x, fs=26400.0, nperseg=m)
    f, p = welch_psd(x, 26400.0, m)
    np.testing.assert_array_equal(f, f_ref)
    np.testing.assert_allclose(p, p_ref, rtol=1e-10, atol=1e-12 * np.max(p_ref))


@settings(max_examples=25, deadline=None)
@given(
    freqs=st.lists(st.floats(50.0, 12000.0), min_size=1, max_size=4),
    damping=DAMPING,
    peak=st.sampled_from([1e-8, 0.1, 1e6]),
    n=st.integers(1, 3000),
    seed=st.integers(0, 2**32 - 1),
)
def test_flutter_by_fft_is_the_zoh_filtered_noise(
    freqs: list[float], damping: float, peak: float, n: int, seed: int
) -> None:
    bd = BenchmarkDisturbances(
        flutter_freq_hz=tuple(freqs),
        flutter_damping=(damping,) * len(freqs),
        flutter_peak_track=(peak,) * len(freqs),
    )
    whites = [np.random.default_rng(seed + i).standard_normal(n) for i in range(len(freqs))]
    # reference: each resonator's ZOH by scipy.linalg.expm, stepped sample by sample,
    # output one sample ahead (y[k] = C x[k+1], the generator's convention)
    want = np.zeros(n)
    for f, white in zip(freqs, whites, strict=True):
        w = 2 * np.pi * f
        A = np.array([[0.0, 1.0], [-w * w, -2 * damping * w]])
        B = np.array([[0.0], [peak * 2 * damping * w * w]])
        M = scipy.linalg.expm(np.block([[A, B], [np.zeros((1, 3))]]) * bd.dt)
        phi, gamma = M[:2, :2], M[:2, 2:]
        C = np.array([[1.0, 0.0]])
        want += _dlsim(phi, gamma, C @ phi, C @ gamma, white[:, None])[:, 0]
    got = bd._flutter_sequence(whites)
    assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))


def test_generated_record_keeps_its_streams() -> None:
    # sensor, force and RRO unchanged; flutter to rounding (seeded streams per source)
    bd = BenchmarkDisturbances()
    rec = bd.generate(20, seed=7)
    rng = np.random.default_rng(np.random.SeedSequence(7).spawn(4)[2])
    want = sum(
        signal.lfilter(g.num[0][0], g.den[0][0], rng.standard_normal(rec.n))
        for g in bd._discrete_flutter()
    )
    assert np.max(np.abs(rec.flutter - want)) <= 1e-11 * np.max(np.abs(want))


@settings(max_examples=15, deadline=None)
@given(
    fc=st.floats(200.0, 3000.0),
    notch=st.tuples(st.floats(2000.0, 12000.0), DAMPING, st.floats(0.05, 0.9)),
    dt=st.sampled_from([1e-5, 37.879e-6, 1e-4]),
)
def test_benchmark_controller_data_is_python_controls_bit_for_bit(
    fc: float, notch: tuple[float, float, float], dt: float
) -> None:
    if notch[0] >= 0.45 / dt:
        return
    want = benchmark_controller(fc, dt=dt, notches=(notch,))
    got = benchmark_controller_data(fc, dt=dt, notches=(notch,), zoh="expm")
    np.testing.assert_array_equal(got.numerator, want.num[0][0])
    np.testing.assert_array_equal(got.denominator, want.den[0][0])
    modal = benchmark_controller_data(fc, dt=dt, notches=(notch,))  # numpy-only ZOH
    np.testing.assert_allclose(modal.numerator, want.num[0][0], rtol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    f=st.floats(1.0, 2e4),
    z_num=DAMPING,
    z_den=st.sampled_from([1e-6, 0.01, 0.5, 2.0]),
    gain=SCALE,
    dt=st.sampled_from([1e-6, 2.5e-5, 1e-3]),
)
def test_tustin_twin_is_python_controls_bit_for_bit(
    f: float, z_num: float, z_den: float, gain: float, dt: float
) -> None:
    if f >= 0.49 / dt:
        return
    w = 2 * np.pi * f
    num, den = gain * np.array([1.0, 2 * z_num * w, w * w]), np.array([1.0, 2 * z_den * w, w * w])
    try:
        want = discretize_filter(control.tf(num, den), dt, f)
    except ServokitValueError as exc:  # a degenerate map (num = den): refused by both
        with pytest.raises(ServokitValueError, match=re.escape(str(exc))):
            discretize_filter_data(RationalTF(num, den), dt, f)
        return
    got = discretize_filter_data(RationalTF(num, den), dt, f)
    np.testing.assert_array_equal(got.numerator, want.num[0][0])
    if not np.any(got.numerator):  # gain 1e-150: the bilinear map's numerator cancels to
        return  # 0 in both (python-control then stores den = [1]): the same zero filter
    np.testing.assert_array_equal(got.denominator, want.den[0][0])


@settings(max_examples=12, deadline=None)
@given(
    f1=st.floats(100.0, 5000.0),
    z1=st.sampled_from([1e-6, 0.02, 0.3]),
    depth=st.floats(0.5, 30.0),
    delay=st.sampled_from([0.0, 10e-6, 55e-6]),
)
def test_peak_filtered_data_is_python_controls_bit_for_bit(
    f1: float, z1: float, depth: float, delay: float
) -> None:
    bd = BenchmarkDisturbances()
    plant = hdd_benchmark().replace(delay=delay)
    spec = PeakFilterSpec(f1, z1, depth)
    want = peak_filtered_controller(benchmark_controller(dt=bd.dt), plant.discretize(bd.dt), spec)
    got = peak_filtered_data(
        benchmark_controller_data(dt=bd.dt, zoh="expm"), plant.discretize_data(bd.dt), spec
    )
    np.testing.assert_array_equal(got.numerator, want.num[0][0])
    np.testing.assert_array_equal(got.denominator, want.den[0][0])


@settings(max_examples=40, deadline=None)
@given(
    f=st.floats(100.0, 2e4),
    g=st.floats(100.0, 2e4),
    zz=DAMPING,
    zp=st.sampled_from([1e-6, 0.05, 0.7]),
    k=SCALE,
    phi=st.floats(-4.0, 4.0),
)
def test_dual_stage_factors_are_python_controls_bit_for_bit(
    f: float, g: float, zz: float, zp: float, k: float, phi: float
) -> None:
    for got, want in ((_pair(f, g, zz, zp), zero_pole_pair(f, g, zz, zp)),
                      (_addon(f, zp, k, phi), peak_filter_addon(f, zp, k, phi))):  # fmt: skip
        np.testing.assert_array_equal(got.numerator, want.num[0][0])
        np.testing.assert_array_equal(got.denominator, want.den[0][0])


def _modal_plant(freqs: list[float], damping: float, rigid: bool, scale: float) -> ModalPlant:
    modes = [Mode(freq_hz=f, damping=damping, residue=(-1) ** i * scale) for i, f in
             enumerate(freqs)]  # fmt: skip
    if rigid:
        modes.insert(0, Mode(freq_hz=0.0, damping=0.0, residue=scale))
    return ModalPlant(modes=modes, gain=1.0, name="random")


PLANTS = st.builds(
    _modal_plant,
    st.lists(st.floats(200.0, 3e4), min_size=1, max_size=4, unique=True),
    DAMPING,
    st.booleans(),
    st.sampled_from([1e-3, 1.0, 1e6]),
)


def _distinct(freqs: list[float]) -> bool:
    """Modes at least 1e-9 apart relative: two modes one ulp apart with opposite residues
    (200.0 and 200.00000000000003 Hz, hypothesis) nearly cancel, and the zero between
    them is set by the rounding of their separation in both methods (5.4e-7 here against
    the pencil's 8.8e-8)."""
    return all(abs(a - b) > 1e-9 * max(a, b) for i, a in enumerate(freqs) for b in freqs[i + 1 :])


DISTINCT_PLANTS = st.builds(
    _modal_plant,
    st.lists(st.floats(200.0, 3e4), min_size=1, max_size=4, unique=True).filter(_distinct),
    DAMPING,
    st.booleans(),
    st.sampled_from([1e-3, 1.0, 1e6]),
)


@settings(max_examples=40, deadline=None)
@given(plant=DISTINCT_PLANTS)
def test_plant_zeros_are_the_numerators_roots(plant: ModalPlant) -> None:
    """The zero dynamics (``siso_zeros``) against the numerator's roots in 60 digits: as
    accurate as python-control's pencil up to a small factor on these plants (1.6e-9
    against 9.8e-10 on four modes at damping 1e-6, where the zeros' conditioning sets the
    floor), and far more accurate on the VCM plant (2.2e-14 against 1.8e-6,
    tests/test_models_rational.py)."""
    from _mp_reference import numerator_roots_mp

    from servokit.models.modal import modal_matrices

    A, B, C = modal_matrices(*plant.arrays())
    ref = numerator_roots_mp(A, B.ravel(), C.ravel(), dps=60)
    ref = ref[(np.imag(ref) > 0) & (np.abs(ref) < 2 * np.pi * 1e6)]
    pencil = control.zeros(plant.to_statespace())
    plant_zeros.cache_clear()
    got = plant_zeros(plant)
    assert len(got) == ref.size
    mine = np.array([2 * np.pi * f * (-z + 1j * np.sqrt(1 - z**2)) for f, z in got.items()])
    for r in ref:
        err_mine = np.min(np.abs(mine - r)) / abs(r)
        err_pencil = np.min(np.abs(pencil - r)) / abs(r)
        assert err_mine <= max(1e-8, 4 * err_pencil)


@settings(max_examples=40, deadline=None)
@given(
    num=st.lists(st.floats(-2.0, 2.0), min_size=1, max_size=5),
    den=st.lists(st.floats(-0.9, 0.9), min_size=1, max_size=5),
    scale=SCALE,
)
def test_companion_form_is_python_controls_realisation(
    num: list[float], den: list[float], scale: float
) -> None:
    num, den = scale * np.array(num), [1.0, *den]
    if len(num) > len(den) or not np.any(num):
        return
    tf = RationalTF(num, den, 1e-4)
    got = as_state_space_data(tf)
    if np.abs(tf.numerator[0]) <= 1e-14:
        # scipy's normalize (under control.ss) drops leading numerator coefficients of
        # magnitude <= 1e-14 as "zeros", another system; the companion form keeps them
        z = np.exp(1j * np.linspace(0.1, 3.0, 7))
        resp = np.array([got(v)[0, 0] for v in z])
        # (below ~1e-308 the values are subnormal: relative precision is lost there)
        np.testing.assert_allclose(resp, tf(z), rtol=1e-9, atol=1e-300)
        return
    want = control.ss(control.tf(num, den, 1e-4))
    for a, b in ((got.A, want.A), (got.B, want.B), (got.C, want.C), (got.D, want.D)):
        np.testing.assert_array_equal(a, b)


@settings(max_examples=12, deadline=None)
@given(plant=PLANTS, k=st.sampled_from([1e-6, 1e-3, 1.0]), dt=st.sampled_from([2e-5, 1e-4]))
def test_settling_samples_from_numpy_loop_poles(plant: ModalPlant, k: float, dt: float) -> None:
    c = RationalTF(k * np.array([1.0, -1.7, 0.72]), [1.0, -1.2, 0.2], dt)
    pd = plant.discretize(dt)
    rho = float(np.max(np.abs(control.feedback(pd * c.to_control(), 1).poles())))
    rho_open = float(np.max(np.abs(pd.poles())))
    for in_loop, r in ((True, rho), (False, rho_open)):
        if abs(r - 1.0) < 1e-12:  # on the circle within rounding: either verdict is right
            continue
        if r > 1.0:  # unstable, or a rigid body in open loop: refused
            with pytest.raises(ValueError):
                settling_samples(plant, c, dt, 1e-5, in_loop=in_loop)
            continue
        want = np.log(1e-5) / np.log(r)  # log(r) carries eps / (1 - r) of relative error
        got = settling_samples(plant, c, dt, 1e-5, in_loop=in_loop)
        assert abs(got - want) <= 1 + 1e-13 / (1 - r) * want


def test_simulate_takes_rational_controllers_bit_for_bit() -> None:
    dt = BenchmarkDisturbances().dt
    c = benchmark_controller_data(dt=dt)
    kw = dict(dt=dt, n_samples=200, substeps=4, reference=np.ones(200))
    a = simulate(hdd_benchmark(), controller=c, **kw)
    b = simulate(hdd_benchmark(), controller=c.to_control(), **kw)
    np.testing.assert_array_equal(a.yc, b.yc)
    np.testing.assert_array_equal(a.u, b.u)


def test_pes_run_matches_python_controls_forced_response() -> None:
    bd = BenchmarkDisturbances()
    plant, c = hdd_benchmark(), benchmark_controller(dt=bd.dt)
    rec = bd.generate(12, seed=1)
    cl = pes_closed_loop(plant, c, bd.dt, rec.force.shape[1])
    data = pes_closed_loop_data(plant, RationalTF.from_control(c), bd.dt, rec.force.shape[1])
    np.testing.assert_array_equal(data.A, cl.A)
    u_in = np.column_stack([rec.force, rec.flutter + rec.rro + rec.sensor]).T
    want = control.forced_response(cl, U=u_in).outputs[:, 5 * 220 :]
    for ctrl, zoh in ((c, "expm"), (benchmark_controller_data(dt=bd.dt), "modal")):
        res = track_following_pes(plant, ctrl, rec, zoh=zoh)
        np.testing.assert_allclose(res.pes, want[0], rtol=0, atol=1e-11 * np.abs(want[0]).max())
        np.testing.assert_allclose(res.u, want[1], rtol=0, atol=1e-11 * np.abs(want[1]).max())


def _long_double_recursion(A, B, C, D, u):  # noqa: ANN001, ANN202
    """The recursion in x87 long double (64-bit mantissa): 11 more bits than the others."""
    A, B, C, D, u = (np.asarray(x, dtype=np.longdouble) for x in (A, B, C, D, u))
    x = np.zeros(A.shape[0], dtype=np.longdouble)
    y = np.empty((u.shape[0], C.shape[0]), dtype=np.longdouble)
    for k in range(u.shape[0]):
        y[k] = C @ x + D @ u[k]
        x = A @ x + B @ u[k]
    return y


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="long double is double here")
@settings(max_examples=25, deadline=None)
@example(seed=2, cond_target=2000.0, K=144, block=64)
@given(
    seed=st.integers(0, 2**32 - 1),
    cond_target=st.floats(10.0, 1e4),
    K=st.integers(2, 200),
    block=st.sampled_from([2, 7, 64]),
)
def test_block_form_as_accurate_as_the_recursion_in_a_non_normal_basis(
    seed: int, cond_target: float, K: int, block: int
) -> None:
    # lightly damped modes in a basis of condition ~cond_target: ||A|| >> ||A^j||, where
    # precomputed powers lost 600 times the recursion's digits (2-sample blocks)
    rng = np.random.default_rng(seed)
    n = 8
    M = np.zeros((n, n))
    for i in range(0, n, 2):
        angle = rng.uniform(0.01, 3.0)
        M[i : i + 2, i : i + 2] = _modal_block(np.exp(-1e-6 * angle), angle)
    U, _, Vt = np.linalg.svd(rng.standard_normal((n, n)))
    T = U @ np.diag(np.geomspace(1.0, cond_target, n)) @ Vt
    A = T @ M @ np.linalg.inv(T)
    B, C = rng.standard_normal((n, 1)), rng.standard_normal((2, n))
    D, u = rng.standard_normal((2, 1)), rng.standard_normal((K, 1))
    exact = _long_double_recursion(A, B, C, D, u)
    top = np.max(np.abs(exact), axis=0).astype(float)

    def err(y: np.ndarray) -> float:
        return float(np.max(np.max(np.abs(y - exact).astype(float), axis=0) / top))

    recursion = err(_dlsim(A, B, C, D, u))
    # measured up to 36 times over 600 random loops (600 times without the halving)
    assert err(forced_outputs(A, B, C, D, u, block)) <= 64 * max(recursion, 1e-15)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 12),
    spread=st.floats(0.0, 8.0),
)
def test_balance_is_an_exact_similarity_like_lapacks(seed: int, n: int, spread: float) -> None:
    from servokit.simulate._scan import balance

    rng = np.random.default_rng(seed)
    d = 10.0 ** rng.uniform(-spread, spread, n)  # a badly scaled basis
    A = (d[:, None] * rng.standard_normal((n, n))) / d[None, :]
    got, scale = balance(A)
    assert np.all(np.log2(scale) == np.round(np.log2(scale)))  # powers of 2: exact
    assert np.array_equal(got, (A / scale[:, None]) * scale[None, :])
    assert np.array_equal(np.diag(got), np.diag(A))
    assert np.linalg.norm(got) <= np.linalg.norm(A)
    lapack = scipy.linalg.matrix_balance(A, permute=False)[0]  # gebal's scaling
    assert np.linalg.norm(got) <= 1.5 * np.linalg.norm(lapack) + 1e-300
