"""The FSC design path in numpy (issue 23, start-up) against the SciPy routines it replaced.

``augmented_design_model`` takes each mode's ZOH in closed form (``modal_zoh``) instead of
``scipy.linalg.expm`` of the block-diagonal modal matrix, and ``min_norm_final_state``
factorises with ``numpy.linalg`` instead of ``scipy.linalg``: both are compared here with
the SciPy forms on hard corners (damping 1e-6, rigid bodies, overdamped modes, steps
spanning many decay times, huge and tiny scales).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedforward import augmented_design_model, final_state_control, fsc_input
from servokit.feedforward.fsc import _solve_upper, lifted_state_map, min_norm_final_state
from servokit.models import ModalPlant, Mode, hdd_benchmark
from servokit.models.modal import modal_matrices

EPS = np.finfo(float).eps


def _expm_design_model(plant: ModalPlant, dt: float) -> np.ndarray:
    """The replaced path: ``scipy.linalg.expm`` of the augmented block-diagonal matrix."""
    Ac, Bc, _ = modal_matrices(*plant.arrays())
    n = Ac.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = Ac * dt, Bc * dt
    E = scipy.linalg.expm(M)
    A = np.zeros((n + 1, n + 1))
    A[:n, :n], A[:n, n], A[n, n] = E[:n, :n], E[:n, n], 1.0
    return A


def _reference_min_norm(Sigma: np.ndarray, X: np.ndarray, R: np.ndarray | None) -> np.ndarray:
    """The replaced SciPy form of ``min_norm_final_state`` (without its checks)."""
    M = Sigma if R is None else scipy.linalg.solve_triangular(R, Sigma.T, trans="T").T
    row = np.linalg.norm(M, axis=1)
    Qf, Rf = scipy.linalg.qr((M / row[:, None]).T, mode="economic")
    V = Qf @ scipy.linalg.solve_triangular(Rf, X / row, trans="T")
    return V if R is None else scipy.linalg.solve_triangular(R, V)


#: zero (an unobservable mode) or 0.01-3 of either sign (subnormal gains underflow Gamma)
residue = st.just(0.0) | st.floats(0.01, 3.0) | st.floats(-3.0, -0.01)
damping = st.sampled_from([0.0, 1e-6, 1e-3, 0.05, 0.7, 1.0, 3.0]) | st.floats(0.0, 2.0)


@st.composite
def modal_plants(draw: st.DrawFn) -> tuple[ModalPlant, float]:
    """Plants with 0-2 rigid bodies and 0-4 flexible modes over a wide range of scales."""
    n_rigid = draw(st.integers(0, 2))
    n_flex = draw(st.integers(0 if n_rigid else 1, 4))
    scale = 10.0 ** draw(st.integers(-3, 6))  # Hz: a slow stage up to a MHz resonator
    modes = [Mode(0.0, 0.0, draw(st.floats(0.1, 3.0))) for _ in range(n_rigid)]
    modes += [
        Mode(scale * draw(st.floats(0.1, 10.0)), draw(damping), draw(residue))
        for _ in range(n_flex)
    ]
    gain = 10.0 ** draw(st.integers(-12, 12))
    dt = 10.0 ** draw(st.floats(-2.0, 1.0)) / scale  # hold times of 0.01 to 10 periods
    return ModalPlant(gain=gain, modes=tuple(modes)), dt


def _expm_per_mode(plant: ModalPlant, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Each mode's ``(Phi, Gamma)`` from ``scipy.linalg.expm`` of its own 3x3 Van Loan matrix
    (the whole-matrix expm above errs by eps * ||A dt|| in every block, even a rigid body's),
    balanced: with ``T = diag(1, s, s^2)``, ``s = max(w, 1/dt)``, every entry of
    ``T^-1 M T`` is at most about ``w dt``.  Unbalanced, ``w^2 dt`` sets expm's squarings: at
    10000.1 Hz, dt 1e-4 it erred by 2.2e-11 in the balanced norm where the closed form is
    within 2.8e-16 of a 50-digit ``mpmath.expm`` (hypothesis found it)."""
    Phis, Gammas = [], []
    for w, z, r in zip(*plant.arrays(), strict=True):
        s = max(w, 1.0 / dt)
        # Gamma is linear in r: a unit input column keeps expm's scaling to the mode itself
        M = np.array([[0.0, s, 0.0], [-w * w / s, -2.0 * z * w, s], [0.0, 0.0, 0.0]]) * dt
        E = scipy.linalg.expm(M)
        Phis.append(E[:2, :2] * np.array([[1.0, 1.0 / s], [s, 1.0]]))
        Gammas.append(r * E[:2, 2] * np.array([1.0 / (s * s), 1.0 / s]))
    return np.array(Phis), np.array(Gammas)


@settings(max_examples=100, deadline=None)
@given(modal_plants())
@example((ModalPlant(1.0, (Mode(0.0, 0.0, 1.0), Mode(0.0, 0.0, 2.0))), 1e-4))  # Jordan pair
@example((ModalPlant(1e-9, (Mode(1e6, 1e-6, 1.0),)), 1e-3))  # 1000 periods, undamped
@example((ModalPlant(1e9, (Mode(1e-3, 3.0, -1.0),)), 1e-5))  # overdamped, tiny step
@example((ModalPlant(1e8, (Mode(0.0, 0.0, 1.0), Mode(10.0, 3.0, 1.0))), 0.1))
@example((ModalPlant(1.0, (Mode(10000.1, 1e-6, 0.0),)), 1e-4))  # one period: expm unbalanced
def test_design_model_equals_the_expm_of_each_mode(case) -> None:  # noqa: ANN001
    plant, dt = case
    A, B, n = augmented_design_model(plant, dt)
    assert np.array_equal(B, np.eye(n + 1)[n]) and np.array_equal(A[n], B)
    blocks = np.kron(np.eye(n // 2), np.ones((2, 2)))  # one 2x2 block per mode, zero elsewhere
    assert np.all(A[:n, :n][blocks == 0] == 0.0)
    Phi_ref, Gamma_ref = _expm_per_mode(plant, dt)
    w, _, r = plant.arrays()
    for i in range(w.size):
        rows = slice(2 * i, 2 * i + 2)
        if w[i] == 0.0:  # a rigid body (a Jordan block): exact
            assert np.array_equal(A[rows, rows], [[1.0, dt], [0.0, 1.0]])
            np.testing.assert_allclose(A[rows, n], r[i] * np.array([dt * dt / 2, dt]), rtol=4 * EPS)
        # as in test_perf_simulate: rows balanced by D = diag(1, s), s = max(w, 1/dt) (they
        # carry position and velocity), the input column by its natural size r / s^2
        s = max(w[i], 1.0 / dt)
        D = np.array([1.0, s])
        eP = np.abs((A[rows, rows] - Phi_ref[i]) * D[None, :] / D[:, None]).max()
        eG = np.abs((A[rows, n] - Gamma_ref[i]) / D).max() * s * s / max(abs(r[i]), 1e-300)
        # the phase w dt is rounded in both computations (an error of eps * w dt), and
        # expm's squarings amplify its own rounding by about as much
        assert max(eP, eG) < 2e-13 * (1.0 + w[i] * dt), (i, eP, eG)


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(1, 80),
    log_scale=st.integers(-150, 150),
    spread=st.floats(0.0, 6.0),
    trans=st.booleans(),
    seed=st.integers(0, 2**31 - 1),
)
def test_triangular_solve_equals_scipy(n, log_scale, spread, trans, seed) -> None:  # noqa: ANN001
    rng = np.random.default_rng(seed)
    # a triangular factor with diagonal entries spread over 10^spread, scaled far out
    R = np.triu(rng.standard_normal((n, n))) + np.diag(10.0 ** rng.uniform(0, spread, n))
    R *= 10.0**log_scale
    b = rng.standard_normal((n, 3))
    got = _solve_upper(R, b, trans=trans)
    ref = scipy.linalg.solve_triangular(R, b, trans="T" if trans else "N")
    if not trans:  # the same back substitution: the same rounding
        assert np.array_equal(got, ref)
    # both backward stable: the residuals are of rounding size
    Rt = R.T if trans else R
    resid = np.abs(Rt @ got - b).max() / (np.abs(Rt).max() * np.abs(got).max() + 1e-300)
    assert resid < 100 * n * EPS
    cond = np.linalg.cond(Rt)
    assert np.abs(got - ref).max() <= 10 * n * EPS * cond * np.abs(ref).max()


def test_qr_is_scipy_economic_qr() -> None:
    rng = np.random.default_rng(1)
    for shape in ((40, 9), (300, 5), (26, 26)):
        M = rng.standard_normal(shape) * np.exp(rng.uniform(-20, 20, shape[1]))
        got, ref = np.linalg.qr(M, mode="reduced"), scipy.linalg.qr(M, mode="economic")
        assert all(np.array_equal(g, r) for g, r in zip(got, ref, strict=True))


@settings(max_examples=40, deadline=None)
@given(modal_plants(), st.booleans(), st.integers(0, 2**31 - 1))
def test_min_norm_final_state_equals_the_scipy_form(case, weighted, seed) -> None:  # noqa: ANN001
    plant, dt = case
    A, B, n = augmented_design_model(plant, dt)
    N = n + 1 + seed % 40
    _, Gamma = lifted_state_map(A, B, N)
    Sigma = Gamma[N]
    row = np.linalg.norm(Sigma, axis=1)
    assume(np.all(row > 0) and np.all(np.isfinite(Sigma)))
    rng = np.random.default_rng(seed)
    X = Sigma @ rng.standard_normal(N)  # a reachable final state
    R = None
    if weighted:  # a frequency-shaped weight: the R of a QR of W (Q = W^T W)
        W = np.vstack([np.eye(N), rng.standard_normal((N // 2, N))])
        R = scipy.linalg.qr(W, mode="r")[0][:N]
    Ms = Sigma if R is None else scipy.linalg.solve_triangular(R, Sigma.T, trans="T").T
    cond = np.linalg.cond(Ms / np.linalg.norm(Ms, axis=1)[:, None])
    try:
        got = min_norm_final_state(Sigma, X, R)
    except ServokitValueError:  # numerically uncontrollable (many periods per step)
        assert cond > 1e10
        return
    ref = _reference_min_norm(Sigma, X, R)
    kappa = 1.0 if R is None else np.linalg.cond(R)
    tol = 1e3 * N * EPS * cond * kappa
    assert np.abs(got - ref).max() <= tol * np.abs(ref).max()


def test_cholesky_weight_is_the_scipy_factor() -> None:
    rng = np.random.default_rng(3)
    W = rng.standard_normal((30, 12))
    Q = W.T @ W
    A, B = np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([0.5, 1.0])
    got = final_state_control(A, B, 12, [0, 0], [1, 0], Q=Q)
    R = scipy.linalg.cholesky(Q, lower=False)
    ref = _reference_min_norm(
        np.array([np.linalg.matrix_power(A, 11 - j) @ B for j in range(12)]).T,
        np.array([1.0, 0.0]),
        R,
    )
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15 * np.abs(ref).max())
    # the same factor (potrf on the other triangle: the same values up to rounding)
    np.testing.assert_allclose(np.linalg.cholesky(Q).T, R, rtol=0, atol=1e-14 * np.abs(R).max())


@pytest.mark.parametrize("N", [26, 60, 150])
@pytest.mark.parametrize("bands", [(), ((2500.0, 3500.0, 1e-2, 40), (5000.0, 7000.0, 1.0, 30))])
def test_hdd_seek_design_equals_the_scipy_path(N: int, bands: tuple) -> None:
    # the CLI's seek design (the benchmark plant, without and with band weights)
    from servokit.feedforward.ffsc import _cost_factor, _final_state

    plant = hdd_benchmark().replace(delay=0.0)
    dt = 3.787878787878788e-05
    ff = fsc_input(plant, dt, N, 1.0, band_weights=bands)
    A = _expm_design_model(plant, dt)
    n = A.shape[0] - 1
    _, Gamma = lifted_state_map(A, np.eye(n + 1)[n], N)
    W = _cost_factor(dt, N, list(bands), 1.0 / N)
    R = None if W is None else scipy.linalg.qr(W, mode="r")[0][:N]
    jerk = _reference_min_norm(Gamma[N], _final_state(plant, 1.0, n), R)
    np.testing.assert_allclose(ff.jerk, jerk, rtol=0, atol=1e-10 * np.abs(jerk).max())
