"""Constrained FSC: rows of (2.67)-(2.72), (2.84)-(2.88), the QP solve and infeasibility."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize
from hypothesis import example, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.feedforward.constraints import (
    CurrentLimit,
    InfeasibleConstraintsError,
    InputLimit,
    MotorModel,
    PositionLimit,
    SignalLimit,
    VelocityLimit,
    VoltageLimit,
    constraint_rows,
    solve_fsc_qp,
)
from servokit.feedforward.energy import amplifier_power, supply_voltage
from servokit.feedforward.ffsc import augmented_design_model, fsc_input
from servokit.feedforward.fsc import final_state_control, lifted_model
from servokit.models import ModalPlant, Mode


def _rigid_model(dt: float, N: int, gain: float = 1.0):  # noqa: ANN202
    """Integrator-augmented ZOH rigid body (2.40)-(2.41) and its lifted model."""
    plant = ModalPlant(gain, (Mode(0.0, 0.0, 1.0),), name="rigid")
    A, B, n = augmented_design_model(plant, dt)
    lm = lifted_model(
        A,
        B,
        N,
        np.zeros(n + 1),
        dt=dt,
        position=[1, 0, 0],
        velocity=[0, 1, 0],
        input_row=[0, 0, 1],
    )
    return A, B, lm


def _simulate(A: np.ndarray, B: np.ndarray, U: np.ndarray) -> np.ndarray:
    xs = [np.zeros(A.shape[0])]
    for u in U:
        xs.append(A @ xs[-1] + B.reshape(-1) * u)
    return np.array(xs)


def test_lifted_rows_match_book_matrices() -> None:
    # Phi_z (2.70) and Omega_z (2.71) built by explicit powers for a small case
    dt, N = 0.1, 8
    A, B, lm = _rigid_model(dt, N)
    cz = np.array([0.3, -1.2, 0.7])
    offset, gain = SignalLimit(1.0, state_row=cz).signal(lm)
    Omega = np.zeros((N, N))
    for k in range(N):
        for j in range(k):
            Omega[k, j] = cz @ np.linalg.matrix_power(A, k - 1 - j) @ B
    np.testing.assert_allclose(gain, Omega, atol=1e-14)
    np.testing.assert_allclose(offset, 0.0)
    G, h = SignalLimit(2.0, state_row=cz).rows(lm)
    np.testing.assert_allclose(G, np.vstack([Omega, -Omega]), atol=1e-14)
    np.testing.assert_allclose(h, 2.0)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), N=st.integers(4, 40))
def test_voltage_current_velocity_signals_match_simulation(seed: int, N: int) -> None:
    rng = np.random.default_rng(seed)
    dt = 1e-4
    A, B, lm = _rigid_model(dt, N, gain=500.0)
    U = rng.normal(size=N)
    x = _simulate(A, B, U)
    motor = MotorModel(resistance=2.0, inductance=3e-4, back_emf=8.0)
    uc = x[:N, 2]
    vel = x[:N, 1]
    checks = {
        VoltageLimit(50.0, motor=motor): motor.voltage(uc, vel, dt),
        CurrentLimit(3.0): uc,
        InputLimit(3.0): uc,
        VelocityLimit(1.0): vel,
        PositionLimit(1.0): x[:N, 0],
    }
    for con, expected in checks.items():
        off, gain = con.signal(lm)
        np.testing.assert_allclose(off + gain @ U, expected, rtol=1e-10, atol=1e-12)
    # (2.84) spelled out: R uc[k] + L (uc[k+1] - uc[k]) / tau + Ke xv[k], uc[N] = 0
    uc_next = np.append(uc[1:], 0.0)
    np.testing.assert_allclose(
        motor.voltage(uc, vel, dt), 2.0 * uc + 3e-4 * (uc_next - uc) / dt + 8.0 * vel
    )


def _feasible_lp(A_eq, b_eq, G, h) -> bool:  # noqa: ANN001
    res = scipy.optimize.linprog(
        np.zeros(A_eq.shape[1]),
        A_ub=G,
        b_ub=h,
        A_eq=A_eq,
        b_eq=b_eq,
        bounds=(None, None),
        method="highs",
    )
    return res.status == 0


@settings(max_examples=30, deadline=None)
@given(
    N=st.integers(6, 40),
    frac=st.floats(0.3, 1.2),
    vfrac=st.floats(0.5, 1.5),
)
@example(N=6, frac=1.0, vfrac=1.0)  # limits touching the unconstrained optimum (degenerate)
@example(N=8, frac=1.0, vfrac=1.0)
def test_qp_respects_constraints_or_names_binding(N: int, frac: float, vfrac: float) -> None:
    dt = 0.1
    A, B, lm = _rigid_model(dt, N)
    xN = np.array([1.0, 0.0, 0.0])
    U0 = final_state_control(A, B, N, np.zeros(3), xN)
    x0 = _simulate(A, B, U0)
    u_lim = frac * np.abs(x0[:, 2]).max()
    v_lim = vfrac * np.abs(x0[:, 1]).max()
    cons = [InputLimit(u_lim), VelocityLimit(v_lim)]
    G, h, groups = constraint_rows(cons, lm)
    Sigma, X = lm.x_gain[N], xN - lm.x_offset[N]
    try:
        U = solve_fsc_qp(np.eye(N), np.zeros(N), Sigma, X, G, h, groups=groups)
    except InfeasibleConstraintsError as exc:
        assert not _feasible_lp(Sigma, X, G, h)
        assert set(exc.binding) <= {cons[0].name, cons[1].name}
        assert any(c.name in str(exc) for c in cons) or "together" in str(exc)
        return
    x = _simulate(A, B, U)
    np.testing.assert_allclose(x[-1], xN, atol=1e-9)
    assert np.abs(x[:N, 2]).max() <= u_lim * (1 + 1e-6)
    assert np.abs(x[:N, 1]).max() <= v_lim * (1 + 1e-6)
    # optimality: never worse than the unconstrained optimum when that one is feasible,
    # and equal to it when no constraint is active
    assert U @ U >= U0 @ U0 * (1 - 1e-9)
    if frac >= 1.0 and vfrac >= 1.0:
        np.testing.assert_allclose(U, U0, atol=1e-6 * np.abs(U0).max())


def test_qp_matches_kkt_of_active_set() -> None:
    # a bound that is active: compare with scipy SLSQP on the same small problem
    dt, N = 0.1, 30
    A, B, lm = _rigid_model(dt, N)
    xN = np.array([1.0, 0.0, 0.0])
    G, h, groups = constraint_rows([InputLimit(0.6)], lm)
    Sigma, X = lm.x_gain[N], xN - lm.x_offset[N]
    U = solve_fsc_qp(np.eye(N), np.zeros(N), Sigma, X, G, h, groups=groups)
    ref = scipy.optimize.minimize(
        lambda u: u @ u,
        np.zeros(N),
        jac=lambda u: 2 * u,
        method="SLSQP",
        constraints=[
            {"type": "eq", "fun": lambda u: Sigma @ u - X, "jac": lambda u: Sigma},
            {"type": "ineq", "fun": lambda u: h - G @ u, "jac": lambda u: -G},
        ],
        options={"ftol": 1e-14, "maxiter": 500},
    )
    assert ref.success
    np.testing.assert_allclose(U, ref.x, atol=1e-6)
    assert np.abs(lm.plant_input(U)).max() == pytest.approx(0.6, rel=1e-6)


def test_infeasible_names_the_binding_constraint() -> None:
    # 1 unit in 3 s with |u| <= 0.25 needs at least 4 s (bang-bang Topt = 2 sqrt(r/umax))
    plant = ModalPlant(1.0, (Mode(0.0, 0.0, 1.0),), name="rigid")
    dt, N = 0.1, 30
    _, _, lm = _rigid_model(dt, N)
    cons = [VelocityLimit(10.0), InputLimit(0.25)]
    G, h, groups = constraint_rows(cons, lm)
    with pytest.raises(InfeasibleConstraintsError, match=r"input \|u\| <= 0.25") as info:
        solve_fsc_qp(
            np.eye(N), np.zeros(N), lm.x_gain[N], np.array([1.0, 0, 0]), G, h, groups=groups
        )
    assert info.value.binding == ("input |u| <= 0.25",)
    assert isinstance(info.value, ServokitValueError)
    # via the FSC design too (H1's fsc_input); |u| <= 0.6 allows it (Topt = 2.58 s < 3 s)
    with pytest.raises(InfeasibleConstraintsError):
        fsc_input(plant, dt, N, 1.0, constraints=cons)
    ff = fsc_input(plant, dt, N, 1.0, constraints=[InputLimit(0.6), VelocityLimit(0.5)])
    assert np.abs(ff.u).max() <= 0.6 * (1 + 1e-6)


def test_equality_only_and_errors() -> None:
    dt, N = 0.1, 10
    A, B, lm = _rigid_model(dt, N)
    xN = np.array([1.0, 0.0, 0.0])
    U = solve_fsc_qp(np.eye(N), np.zeros(N), lm.x_gain[N], xN)
    np.testing.assert_allclose(U, final_state_control(A, B, N, np.zeros(3), xN), atol=1e-10)
    with pytest.raises(ServokitValueError, match="N=10"):
        solve_fsc_qp(np.eye(N), np.zeros(N + 1), lm.x_gain[N], xN)
    with pytest.raises(ServokitValueError, match="groups"):
        solve_fsc_qp(
            np.eye(N), np.zeros(N), lm.x_gain[N], xN, np.eye(N), np.ones(N), groups=[("a", 3)]
        )
    with pytest.raises(InfeasibleConstraintsError, match="final"):
        solve_fsc_qp(np.eye(N), np.zeros(N), np.zeros((1, N)), np.ones(1))
    with pytest.raises(ServokitTypeError, match="MotorModel"):
        VoltageLimit(10.0)
    with pytest.raises(ServokitValueError, match="max_abs"):
        InputLimit(0.0)
    with pytest.raises(ServokitTypeError, match="rows"):
        constraint_rows([object()], lm)


def test_amplifier_power_eq_2_89() -> None:
    # hand case: |i| (Vp - |V|) averaged over the move
    i = np.array([1.0, -2.0, 0.0, 0.5])
    v = np.array([10.0, -20.0, 5.0, 0.0])
    p = amplifier_power(i, v, 30.0, 0.5)
    assert p == pytest.approx((1 * 20 + 2 * 10 + 0 + 0.5 * 30) * 0.5 / 2.0)
    assert amplifier_power(i, v, 30.0, 0.5, duration=4.0) == pytest.approx(p / 2)
    assert supply_voltage(72.0, 16.0) == 88.0
    with pytest.raises(ServokitValueError, match="saturates"):
        amplifier_power(i, v, 15.0, 0.5)
    with pytest.raises(ServokitValueError, match="same length"):
        amplifier_power(i, v[:2], 30.0, 0.5)
