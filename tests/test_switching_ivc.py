"""IVC on the feedback controller (book §3.3.1): J-min and pole-zero, on random loops."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.switching import (
    free_response,
    ivc_jmin,
    ivc_pole_zero,
    ivc_transfer,
    jmin_cost,
    lyapunov_cost,
    switched_loop,
)


def _stable(rng: np.random.Generator, k: int, radius: float) -> np.ndarray:
    A = rng.standard_normal((k, k))
    return A * radius / max(np.max(np.abs(np.linalg.eigvals(A))), 1e-9)


def random_loop(seed: int, n: int, m: int):
    """A stable plant and controller with a small enough loop gain to be stable."""
    rng = np.random.default_rng(seed)
    plant = control.ss(
        _stable(rng, n, 0.9), rng.standard_normal((n, 1)), rng.standard_normal((1, n)), 0, 1e-3
    )
    ctrl = control.ss(
        _stable(rng, m, 0.8),
        rng.standard_normal((m, 1)),
        rng.standard_normal((1, m)),
        rng.standard_normal(),
        1e-3,
    )
    loop = switched_loop(plant, ctrl)
    for _ in range(40):
        if np.max(np.abs(loop.poles())) < 0.97:
            return loop
        ctrl = control.ss(ctrl.A, ctrl.B * 0.5, ctrl.C, ctrl.D * 0.5, 1e-3)
        loop = switched_loop(plant, ctrl)
    pytest.skip("no stable loop found")  # pragma: no cover


def brute_cost(loop, Q, xp0, xc0, n_samples=4000):
    x = np.concatenate([xp0, xc0])
    J = 0.0
    for _ in range(n_samples):
        J += x @ Q @ x
        x = loop.A @ x
    return J


dims = st.tuples(st.integers(0, 2**31), st.integers(1, 4), st.integers(1, 3))


@settings(max_examples=25, deadline=None)
@given(dims)
def test_jmin_zero_gradient_and_not_beaten(args):
    seed, n, m = args
    loop = random_loop(seed, n, m)
    rng = np.random.default_rng(seed + 1)
    Q = np.diag(rng.uniform(0.1, 2.0, n + m))
    K = ivc_jmin(loop, None, Q)
    assert K.shape == (m, n)
    P = lyapunov_cost(loop, Q)
    xp0 = rng.standard_normal(n)
    xc0 = K @ xp0
    grad = 2 * P[n:, n:] @ xc0 + 2 * P[:n, n:].T @ xp0
    assert np.linalg.norm(grad) <= 1e-8 * max(1.0, np.linalg.norm(P) * np.linalg.norm(xp0))
    J0 = jmin_cost(loop, Q, xp0, xc0)
    assert J0 == pytest.approx(brute_cost(loop, Q, xp0, xc0), rel=1e-6)
    for _ in range(5):
        assert jmin_cost(loop, Q, xp0, xc0 + 1e-3 * rng.standard_normal(m)) >= J0 - 1e-12


def test_jmin_output_weight_semidefinite():
    loop = random_loop(7, 3, 2)
    K = ivc_jmin(loop, None, output_weight=loop.Cu)
    xp0 = np.array([1.0, -0.5, 0.2])
    u = free_response(loop.A, loop.Cu, loop.stack(K) @ xp0, 3000)
    rng = np.random.default_rng(0)
    for _ in range(5):
        xc = K @ xp0 + 1e-2 * rng.standard_normal(2)
        u2 = free_response(loop.A, loop.Cu, np.concatenate([xp0, xc]), 3000)
        assert np.sum(u**2) <= np.sum(u2**2) + 1e-12


def _cancellable(eig: np.ndarray, m: int) -> list[complex]:
    """Up to m conditions' worth of poles (a complex pair counts two)."""
    chosen, used = [], 0
    for lam in sorted(eig, key=lambda e: -abs(e)):
        if lam.imag < -1e-9 or abs(lam) < 1e-3:
            continue
        cost = 2 if abs(lam.imag) > 1e-9 else 1
        if used + cost <= m:
            chosen.append(lam)
            used += cost
    return chosen


def _numerator_at(tf: control.TransferFunction, lam: complex) -> float:
    num = np.asarray(tf.num[0][0], dtype=float)
    return abs(np.polyval(num, lam)) / max(np.max(np.abs(num)), 1e-300)


@settings(max_examples=30, deadline=None)
@given(dims)
def test_pole_zero_cancels_on_every_state(args):
    seed, n, m = args
    loop = random_loop(seed, n, m)
    poles = _cancellable(loop.poles(), m)
    K = ivc_pole_zero(loop, None, poles)
    for i in range(n):
        tf = control.ss2tf(ivc_transfer(loop, K, i))
        for lam in poles:
            assert _numerator_at(tf, lam) < 1e-8


def test_pole_zero_complex_pair_real_gain_and_free_response():
    loop = random_loop(3, 2, 2)
    A = loop.A
    eig, vr = np.linalg.eig(A)
    pair = [e for e in eig if e.imag > 1e-9]
    if not pair:  # make a loop with a complex pair by searching seeds
        for seed in range(100):
            loop = random_loop(seed, 2, 2)
            pair = [e for e in loop.poles() if e.imag > 1e-9]
            if pair:
                break
    K = ivc_pole_zero(loop, None, pair[:1])
    assert K.dtype == float
    # brute force: the free response from [e_i; K_i] holds no component of the pair
    y = free_response(loop.A, loop.C, loop.stack(K), 60)
    lam = pair[0]
    others = [e for e in loop.poles() if min(abs(e - lam), abs(e - np.conj(lam))) > 1e-9]
    V = np.array([[e**k for e in others] for k in range(60)])  # fit without the pair
    for col in y.T:
        coef, *_ = np.linalg.lstsq(V, col.astype(complex), rcond=None)
        assert np.linalg.norm(V @ coef - col) < 1e-9 * max(1, np.linalg.norm(col))


def test_pole_zero_refuses_too_many_and_unknown_poles():
    loop = random_loop(11, 2, 1)
    eig = loop.poles()
    real = [e for e in eig if abs(e.imag) < 1e-12]
    with pytest.raises(ServokitValueError, match="exceed"):
        ivc_pole_zero(loop, None, list(eig))
    with pytest.raises(ServokitValueError, match="not a closed-loop pole"):
        ivc_pole_zero(loop, None, [5.0])
    if real:
        assert ivc_pole_zero(loop, None, real[:1]).shape == (1, 2)


def test_fewer_poles_than_states_min_norm():
    loop = random_loop(5, 2, 3)
    lam = max(loop.poles(), key=lambda e: (abs(e.imag) < 1e-9, abs(e)))
    K = ivc_pole_zero(loop, None, [lam])
    for i in range(2):
        tf = control.ss2tf(ivc_transfer(loop, K, i))
        assert _numerator_at(tf, lam) < 1e-8


def test_bad_inputs():
    plant = control.ss([[1.0]], [[1.0]], [[1.0]], 0, 1e-3)
    with pytest.raises(ServokitValueError, match="differ"):
        switched_loop(plant, control.ss([[0.5]], [[1]], [[1]], 0, 2e-3))
    with pytest.raises(ServokitValueError, match="discrete"):
        switched_loop(plant, control.ss([[0.5]], [[1]], [[1]], 0))
    unstable = switched_loop(plant, control.ss([[0.5]], [[1]], [[-1]], -3, 1e-3))
    with pytest.raises(ServokitValueError, match="not stable"):
        ivc_jmin(unstable, None, np.eye(2))
    with pytest.raises(ServokitValueError, match="exactly one"):
        ivc_jmin(unstable, None)


def _brute_jerk_cost(loop, Qs, qu, qj, xp0, xc0, r, uw, n_samples=3000):
    from servokit.switching import equilibrium

    x_ss = equilibrium(loop, r)
    u_ss = loop.Cu[0] @ x_ss + loop.Dr[0, 0] * r
    x = np.concatenate([xp0, xc0])
    J, u_prev = 0.0, uw
    for _ in range(n_samples):
        z = x - x_ss
        u = loop.Cu[0] @ x + loop.Dr[0, 0] * r
        J += z @ Qs @ z + qu * (u - u_ss) ** 2 + qj * (u - u_prev) ** 2
        u_prev = u
        x = loop.A @ x + loop.B[:, 0] * r
    return J


@settings(max_examples=10, deadline=None)
@given(dims)
def test_jmin_jerk_gains_minimise_the_brute_force_cost(args):
    from servokit.switching import ivc_jmin_jerk

    seed, n, m = args
    loop = random_loop(seed, n, m)
    rng = np.random.default_rng(seed + 3)
    Qs = np.diag(rng.uniform(0.1, 1.0, n + m))
    gains = ivc_jmin_jerk(loop, Qs, input_weight=0.5, jerk_weight=2.0)
    xp0, r, uw = rng.standard_normal(n), float(rng.standard_normal()), float(rng.standard_normal())
    xc0 = gains.state(xp0, [r], uw)
    J0 = _brute_jerk_cost(loop, Qs, 0.5, 2.0, xp0, xc0, r, uw)
    for _ in range(4):
        dx = 1e-3 * rng.standard_normal(m)
        assert _brute_jerk_cost(loop, Qs, 0.5, 2.0, xp0, xc0 + dx, r, uw) >= J0 - 1e-9 * J0
