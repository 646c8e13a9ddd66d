"""Final-state control (2.35): hand cases, minimum-norm property, large N, errors."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedforward import (
    augmented_design_model,
    final_state_control,
    fsc_input,
    lifted_model,
    lifted_state_map,
)
from servokit.models import ModalPlant, Mode, galvano_scanner
from servokit.models._zoh import zoh_pair


def _simulate(A: np.ndarray, B: np.ndarray, x0: np.ndarray, U: np.ndarray) -> np.ndarray:
    """Independent forward recursion of (2.26): states x[0..N]."""
    B = np.asarray(B).reshape(-1)
    xs = [np.asarray(x0, dtype=float)]
    for u in U:
        xs.append(A @ xs[-1] + B * u)
    return np.array(xs)


def _final_error(traj: np.ndarray, xN: np.ndarray) -> float:
    """Final-state miss of each component relative to its largest value along the move."""
    scale = np.maximum(np.abs(traj).max(axis=0), np.abs(xN))
    scale[scale == 0] = 1.0
    return float(np.max(np.abs(traj[-1] - xN) / scale))


def _sigma_by_powers(A: np.ndarray, B: np.ndarray, N: int) -> np.ndarray:
    B = np.asarray(B).reshape(-1)
    return np.column_stack([np.linalg.matrix_power(A, N - 1 - j) @ B for j in range(N)])


DOUBLE_INT_A = np.array([[1.0, 1.0], [0.0, 1.0]])
DOUBLE_INT_B = np.array([0.5, 1.0])


def test_double_integrator_two_steps_hand_case() -> None:
    # x2 = A x1 + B u1 with x1 = B u0: position 1.5 u0 + 0.5 u1 = 1, velocity u0 + u1 = 0.
    u = final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 2, [0, 0], [1, 0])
    np.testing.assert_allclose(u, [1.0, -1.0], rtol=1e-13)


def test_double_integrator_matches_closed_form_pseudo_inverse() -> None:
    N = 9
    S = _sigma_by_powers(DOUBLE_INT_A, DOUBLE_INT_B, N)
    x0, xN = np.array([0.3, -0.2]), np.array([2.0, 0.5])
    expected = S.T @ np.linalg.solve(S @ S.T, xN - np.linalg.matrix_power(DOUBLE_INT_A, N) @ x0)
    u = final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, N, x0, xN)
    np.testing.assert_allclose(u, expected, rtol=1e-10)


def test_minimum_norm_against_null_space_perturbations() -> None:
    rng = np.random.default_rng(1)
    A = np.array([[0.9, 0.2, 0.0], [-0.1, 0.8, 0.3], [0.0, 0.1, 1.0]])
    B = np.array([0.0, 0.5, 1.0])
    N = 12
    x0, xN = rng.normal(size=3), rng.normal(size=3)
    u = final_state_control(A, B, N, x0, xN)
    S = _sigma_by_powers(A, B, N)
    null = scipy.linalg.null_space(S)
    assert null.shape[1] == N - 3
    # u is orthogonal to every feasible direction, so any other feasible input is longer.
    np.testing.assert_allclose(null.T @ u, 0.0, atol=1e-12 * np.linalg.norm(u))
    for _ in range(20):
        other = u + null @ rng.normal(size=null.shape[1])
        np.testing.assert_allclose(S @ other, S @ u, rtol=1e-9, atol=1e-12)
        assert np.linalg.norm(other) > np.linalg.norm(u)
    np.testing.assert_allclose(
        u, np.linalg.lstsq(S, xN - np.linalg.matrix_power(A, N) @ x0, rcond=None)[0], rtol=1e-9
    )


def test_weighted_solution_solves_the_kkt_system() -> None:
    rng = np.random.default_rng(2)
    N = 8
    M = rng.normal(size=(N, N))
    Q = M @ M.T + N * np.eye(N)
    S = _sigma_by_powers(DOUBLE_INT_A, DOUBLE_INT_B, N)
    X = np.array([1.0, 0.0])
    kkt = np.block([[2 * Q, -S.T], [S, np.zeros((2, 2))]])
    expected = np.linalg.solve(kkt, np.concatenate([np.zeros(N), X]))[:N]
    u_q = final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, N, [0, 0], X, Q)
    np.testing.assert_allclose(u_q, expected, rtol=1e-9)
    # the same weight given as a factor W with Q = W^T W
    W = np.vstack([scipy.linalg.cholesky(Q), np.zeros((3, N))])
    u_w = final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, N, [0, 0], X, Q_factor=W)
    np.testing.assert_allclose(u_w, expected, rtol=1e-9)
    unweighted = final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, N, [0, 0], X)
    assert u_q @ Q @ u_q < unweighted @ Q @ unweighted


def test_lifted_state_map_matches_recursion() -> None:
    A = np.array([[0.9, 0.2], [-0.3, 0.7]])
    B = np.array([0.1, 1.0])
    N = 7
    Phi, Gamma = lifted_state_map(A, B, N)
    rng = np.random.default_rng(3)
    x0, U = rng.normal(size=2), rng.normal(size=N)
    traj = _simulate(A, B, x0, U)
    np.testing.assert_allclose(Phi @ x0 + Gamma @ U, traj, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(Gamma[N], _sigma_by_powers(A, B, N), rtol=1e-12)
    lm = lifted_model(
        A,
        B,
        N,
        x0,
        dt=0.1,
        position=np.array([1.0, 0.0]),
        velocity=np.array([0.0, 1.0]),
        input_row=np.array([0.0, 1.0]),
    )
    np.testing.assert_allclose(lm.plant_input(U), traj[:N, 1], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(lm.states(U), traj, rtol=1e-12, atol=1e-14)


def test_galvano_n351_reaches_final_state() -> None:
    plant = galvano_scanner()
    dt = 10e-6
    A, B, n = augmented_design_model(plant, dt)
    xN = np.zeros(n + 1)
    xN[0] = 1.0
    u = final_state_control(A, B, 351, np.zeros(n + 1), xN)
    assert _final_error(_simulate(A, B, np.zeros(n + 1), u), xN) < 1e-9
    # the same design through fsc_input, checked on the plant's own exact ZOH model
    ff = fsc_input(plant, dt, 351, 1.0)
    sysd = plant.replace(delay=0.0).discretize(dt)
    traj = _simulate(sysd.A, sysd.B, np.zeros(n), np.concatenate([ff.u, [0.0]]))
    target = np.zeros(n)
    target[0] = 1.0
    assert _final_error(traj, target) < 1e-9


@st.composite
def modal_systems(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray, int]:
    n_modes = draw(st.integers(1, 3))
    freqs = sorted(draw(st.lists(st.floats(50.0, 4000.0), min_size=n_modes, max_size=n_modes)))
    assume(all(b - a > 20.0 for a, b in zip(freqs, freqs[1:], strict=False)))
    modes = [Mode(0.0, 0.0, 1.0)] + [
        Mode(f, draw(st.floats(0.0, 0.3)), sign * draw(st.floats(0.1, 2.0)))
        for f, sign in zip(
            freqs,
            draw(st.lists(st.sampled_from([-1.0, 1.0]), min_size=n_modes, max_size=n_modes)),
            strict=True,
        )
    ]
    dt = draw(st.floats(2e-5, 2e-4))
    assume(all(abs(np.sin(np.pi * f * dt)) > 0.05 for f in freqs))  # no pathological sampling
    plant = ModalPlant(gain=draw(st.floats(1.0, 1e4)), modes=tuple(modes))
    ss = plant.to_statespace()
    Ad, Bd = zoh_pair(ss.A, ss.B, dt)
    N = draw(st.integers(Ad.shape[0], 200))
    return Ad, Bd[:, 0], N


@settings(max_examples=30, deadline=None)
@given(modal_systems(), st.floats(-10, 10), st.integers(0, 2**31 - 1))
def test_random_controllable_systems_reach_final_state(sys_n, target, seed) -> None:
    A, B, N = sys_n
    n = A.shape[0]
    rng = np.random.default_rng(seed)
    x0 = 0.1 * rng.normal(size=n)
    xN = np.zeros(n)
    xN[0] = target
    u = final_state_control(A, B, N, x0, xN)
    assert np.all(np.isfinite(u))
    assert _final_error(_simulate(A, B, x0, u), xN) < 1e-9


def test_uncontrollable_pair_raises() -> None:
    # two identical decoupled modes driven identically: their difference is uncontrollable
    A = scipy.linalg.block_diag(DOUBLE_INT_A, DOUBLE_INT_A)
    B = np.concatenate([DOUBLE_INT_B, DOUBLE_INT_B])
    with pytest.raises(ServokitValueError, match="not controllable"):
        final_state_control(A, B, 10, np.zeros(4), [1.0, 0.0, 0.0, 0.0])
    # a state the input never reaches
    A2 = np.diag([1.0, 0.5])
    with pytest.raises(ServokitValueError, match="not controllable"):
        final_state_control(A2, [1.0, 0.0], 5, [0.0, 0.0], [1.0, 1.0])


def test_argument_errors_name_the_argument() -> None:
    with pytest.raises(ServokitValueError, match="N=1 is below the system order 2"):
        final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 1, [0, 0], [1, 0])
    with pytest.raises(ServokitValueError, match="xN must have 2"):
        final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 4, [0, 0], [1, 0, 0])
    with pytest.raises(ServokitValueError, match="B must have 2 rows"):
        final_state_control(DOUBLE_INT_A, [1.0], 4, [0, 0], [1, 0])
    with pytest.raises(ServokitValueError, match="single input"):
        final_state_control(DOUBLE_INT_A, np.eye(2), 4, [0, 0], [1, 0])
    with pytest.raises(ServokitValueError, match="positive definite"):
        final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 3, [0, 0], [1, 0], -np.eye(3))
    with pytest.raises(ServokitValueError, match="x0 must be finite"):
        final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 3, [np.nan, 0], [1, 0])
    with pytest.raises(TypeError, match="N must be an integer"):
        final_state_control(DOUBLE_INT_A, DOUBLE_INT_B, 3.0, [0, 0], [1, 0])  # type: ignore[arg-type]


def test_unreachable_precision_raises_instead_of_returning_garbage() -> None:
    # Poles 1 and 1 + 1e-15 are distinct in theory but not in double precision.
    A = np.diag([1.0, 1.0 + 1e-15])
    with pytest.raises(ServokitValueError, match="not controllable|rtol"):
        final_state_control(A, [1.0, 1.0], 4, [0.0, 0.0], [1.0, 0.0])
