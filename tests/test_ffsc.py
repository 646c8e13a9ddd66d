"""FSC/FFSC inputs for modal plants (2.40)-(2.75): boundary conditions, spectrum, shaping."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedforward import (
    FeedforwardInput,
    band_frequencies,
    fsc_input,
    held_spectrum_matrix,
)
from servokit.models import HDD_BENCHMARK_TS, ModalPlant, Mode, hdd_benchmark
from servokit.seek import choose_N

TS = HDD_BENCHMARK_TS


def _response(plant: ModalPlant, ff: FeedforwardInput, n_after: int) -> np.ndarray:
    """Output at the sampling instants by python-control's own ZOH discretisation."""
    sysd = control.c2d(plant.to_statespace(), ff.dt, method="zoh")
    u = np.concatenate([ff.u, np.zeros(n_after + 1)])
    return control.forced_response(sysd, U=u).outputs


def _exact_spectrum(u: np.ndarray, dt: float, f: np.ndarray) -> np.ndarray:
    """Integral (2.43) of the staircase, interval by interval (independent of (2.51))."""
    w = 2 * np.pi * f[:, None]
    k = np.arange(u.size)[None, :]
    pieces = (np.exp(-1j * w * k * dt) - np.exp(-1j * w * (k + 1) * dt)) / (1j * w)
    return pieces @ u


def test_fsc_on_rigid_body_reaches_target_and_rests() -> None:
    plant = hdd_benchmark()
    ff = fsc_input(plant, TS, 12, 1.0, model="rigid-body")
    assert ff.N == 12 and ff.u[0] == 0.0
    assert abs(ff.jerk.sum()) < 1e-12 * np.abs(ff.jerk).max()  # u_c[N] = 0
    y = _response(plant.rigid_body(), ff, 20)
    np.testing.assert_allclose(y[12:], 1.0, rtol=1e-10)  # at the target and at rest
    assert np.all(np.abs(y[:12] - 1.0) > 1e-6)  # not before N steps
    # minimum jerk of a double integrator is antisymmetric about the midpoint
    np.testing.assert_allclose(ff.u[1:], -ff.u[1:][::-1], atol=1e-12 * np.abs(ff.u).max())


def test_fsc_on_full_plant_leaves_no_residual_vibration() -> None:
    plant = ModalPlant(2.0e8, (Mode(0, 0, 1.0), Mode(3000, 0.01, -0.5), Mode(7000, 0.02, 0.3)))
    ff = fsc_input(plant, 40e-6, 30, 2.0)
    y = _response(plant, ff, 200)
    np.testing.assert_allclose(y[30:], 2.0, rtol=1e-9)
    # the same input on the rigid body alone still moves but keeps vibrating on the plant
    ff_rb = fsc_input(plant, 40e-6, 30, 2.0, model="rigid-body")
    y_rb = _response(plant, ff_rb, 200)
    assert np.max(np.abs(y_rb[30:] - 2.0)) > 1e-4


def test_spectrum_matches_piecewise_integral_and_dc() -> None:
    ff = fsc_input(hdd_benchmark(), TS, 12, 1.0, model="rigid-body")
    f = np.linspace(10.0, 30e3, 200)
    np.testing.assert_allclose(
        ff.spectrum(f),
        _exact_spectrum(ff.u, TS, f),
        rtol=1e-9,
        atol=1e-12 * np.abs(ff.u).max() * TS,
    )
    # f = 0: area of the staircase, which is zero because the move ends at rest
    np.testing.assert_allclose(ff.spectrum(0.0), TS * ff.u.sum(), atol=1e-20)
    assert ff.spectrum(np.zeros((2, 3))).shape == (2, 3)


def test_frequency_shaping_lowers_the_weighted_band() -> None:
    plant = hdd_benchmark()
    band = (6860.0, 7070.0, 1e10, 60)
    fsc = fsc_input(plant, TS, 14, 1.0, model="rigid-body")
    ffsc = fsc_input(plant, TS, 14, 1.0, model="rigid-body", band_weights=[band])
    f = band_frequencies(*band[:2], 60)
    assert np.max(np.abs(ffsc.spectrum(f))) < 0.05 * np.max(np.abs(fsc.spectrum(f)))
    # both reach the target on the rigid body
    for ff in (fsc, ffsc):
        np.testing.assert_allclose(_response(plant.rigid_body(), ff, 5)[14:], 1.0, rtol=1e-9)


def test_ffsc_minimises_the_weighted_cost_kkt() -> None:
    """Independent check of (2.59)-(2.61): dense KKT solve of min U^T Qw U, Sigma U = X."""
    plant = hdd_benchmark()
    N = 15
    bands = [(3895.0, 4305.0, 5e9, 7), (6860.0, 7070.0, 1e10, 5)]
    ff = fsc_input(plant, TS, N, 1.0, model="rigid-body", band_weights=bands)
    # Qw from (2.60)-(2.61) written with S_R, S_I and Omega_w as in the book
    omega_w = np.tril(np.ones((N, N)), -1)
    Qw = np.eye(N) / N
    for lo, hi, q, n in bands:
        for fi in np.linspace(lo, hi, n):
            w = 2 * np.pi * fi
            u1 = 2 * np.sin(w * TS / 2) / w
            SR = np.cos(np.arange(N) * w * TS)[None, :]
            SI = np.sin(np.arange(N) * w * TS)[None, :]
            Qw += q * u1**2 * omega_w.T @ (SR.T @ SR + SI.T @ SI) @ omega_w
    # rigid-body augmented model (2.41): states [position, velocity, u_c]
    K = plant.gain
    A = np.array([[1, TS, K * TS**2 / 2], [0, 1, K * TS], [0, 0, 1]])
    B = np.array([0.0, 0.0, 1.0])
    Sigma = np.column_stack([np.linalg.matrix_power(A, N - 1 - j) @ B for j in range(N)])
    D = np.diag(1 / np.linalg.norm(Sigma, axis=1))
    kkt = np.block([[2 * Qw, -(D @ Sigma).T], [D @ Sigma, np.zeros((3, 3))]])
    rhs = np.concatenate([np.zeros(N), D @ np.array([1.0, 0.0, 0.0])])
    expected = np.linalg.solve(kkt, rhs)[:N]
    np.testing.assert_allclose(ff.jerk, expected, rtol=1e-6, atol=1e-9 * np.abs(expected).max())


@settings(max_examples=25, deadline=None)
@given(
    N=st.integers(4, 40),
    target=st.floats(-20, 20).filter(lambda x: abs(x) > 1e-3),
    bands=st.lists(
        st.tuples(
            st.floats(500, 12000), st.floats(0, 2000), st.floats(0, 1e10), st.integers(1, 20)
        ),
        max_size=3,
    ),
)
def test_property_boundary_conditions(N: int, target: float, bands: list) -> None:
    plant = hdd_benchmark()
    bw = [(lo, lo + width, q, n) for lo, width, q, n in bands]
    ff = fsc_input(plant, TS, N, target, model="rigid-body", band_weights=bw)
    assert ff.u[0] == 0.0 and ff.u.shape == (N,)
    y = _response(plant.rigid_body(), ff, 3)
    np.testing.assert_allclose(y[N:], target, rtol=1e-9)


def test_band_frequencies_and_spectrum_matrix() -> None:
    np.testing.assert_allclose(band_frequencies(100.0, 200.0, 5), [100, 125, 150, 175, 200])
    E = held_spectrum_matrix(np.array([0.0]), 0.5, 3)
    np.testing.assert_allclose(E, [[0.5, 0.5, 0.5]])


def test_time_response_holds_samples() -> None:
    ff = fsc_input(hdd_benchmark(), TS, 6, 1.0, model="rigid-body")
    t, u = ff.time_response(4, n_after=1)
    assert t.size == u.size == 7 * 4 + 1
    np.testing.assert_allclose(u[:24:4], ff.u)
    np.testing.assert_allclose(u[24:], 0.0)
    np.testing.assert_allclose(t[4], TS)


def test_choose_n_picks_the_smallest_worst_case() -> None:
    plant = hdd_benchmark()
    calls = []

    def fake_seek(plants, ff, target, band=0.1, grid=None, horizon=None):
        calls.append(ff.N)
        return np.array([abs(ff.N - 9) + 1.0, 0.5])

    res = choose_N(
        [plant, plant], TS, 1.0, [12, 7, 9, 11], model="rigid-body", seek_time_fn=fake_seek
    )
    assert res.N == 9 and res.seek_time == 1.0 and res.worst_plant == 0
    assert sorted(calls) == [7, 9, 11, 12] and list(res.N_values) == [7, 9, 11, 12]
    assert res.ff.N == 9


def test_choose_n_with_the_simulator_on_the_rigid_body() -> None:
    plant = hdd_benchmark().rigid_body()
    res = choose_N(plant, TS, 1.0, range(4, 9))
    # the rigid body reaches and holds the target after N steps, so N=4 wins; its seek time
    # is at most 4 Ts and at least when the FSC input enters the band
    assert res.N == 4
    assert 0 < res.seek_time <= 4 * TS + 1e-12


def test_errors() -> None:
    plant = hdd_benchmark()
    with pytest.raises(ServokitValueError, match="N=2 is below the order 3"):
        fsc_input(plant, TS, 2, 1.0, model="rigid-body")
    with pytest.raises(ServokitValueError, match="below the order 15"):
        fsc_input(plant, TS, 10, 1.0)
    with pytest.raises(ServokitValueError, match="no rigid-body mode"):
        fsc_input(ModalPlant(1.0, (Mode(100.0, 0.1, 1.0),)), 1e-3, 5, 1.0)
    with pytest.raises(ServokitValueError, match="model must be"):
        fsc_input(plant, TS, 12, 1.0, model="rigid")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="band_weights\\[0\\] must be a tuple"):
        fsc_input(plant, TS, 12, 1.0, model="rigid-body", band_weights=[(1.0, 2.0)])
    with pytest.raises(ServokitValueError, match="weight must be >= 0"):
        fsc_input(plant, TS, 12, 1.0, model="rigid-body", band_weights=[(1.0, 2.0, -1.0, 3)])
    with pytest.raises(ServokitValueError, match="f_low_hz <= f_high_hz"):
        fsc_input(plant, TS, 12, 1.0, model="rigid-body", band_weights=[(5.0, 2.0, 1.0, 3)])
    with pytest.raises(ServokitValueError, match="dt must be > 0"):
        fsc_input(plant, -1.0, 12, 1.0)
    with pytest.raises(TypeError, match="ModalPlant"):
        fsc_input("hdd", TS, 12, 1.0)  # type: ignore[arg-type]
    with pytest.raises(ServokitValueError, match="N_range is empty"):
        choose_N(plant, TS, 1.0, [])


def test_constrained_design_respects_input_limit_and_final_state() -> None:
    from servokit.feedforward.constraints import InputLimit

    plant = hdd_benchmark()
    free = fsc_input(plant, TS, 20, 1.0, model="rigid-body")
    limit = 0.8 * np.abs(free.u).max()
    ff = fsc_input(plant, TS, 20, 1.0, model="rigid-body", constraints=[InputLimit(limit)])
    assert np.abs(ff.u).max() <= limit * (1 + 1e-6)
    assert np.abs(ff.u).max() >= limit * (1 - 1e-6)  # the limit is active
    np.testing.assert_allclose(_response(plant.rigid_body(), ff, 5)[20:], 1.0, rtol=1e-8)
    # the constraint can only raise the jerk cost of (2.36)
    assert ff.jerk @ ff.jerk > free.jerk @ free.jerk


def test_constraints_are_duck_typed_and_infeasibility_is_reported() -> None:
    from servokit.feedforward.constraints import InputLimit

    class PositiveInput:
        """u_c[k] >= 0 during the first half, through the LiftedModel maps."""

        def rows(self, model):
            half = model.N // 2
            return -model.u_gain[:half], model.u_offset[:half]

    plant = hdd_benchmark()
    ff = fsc_input(plant, TS, 16, 1.0, model="rigid-body", constraints=[PositiveInput()])
    assert np.all(ff.u[:8] >= -1e-9 * np.abs(ff.u).max())
    np.testing.assert_allclose(_response(plant.rigid_body(), ff, 3)[16:], 1.0, rtol=1e-8)
    free = fsc_input(plant, TS, 16, 1.0, model="rigid-body")
    with pytest.raises(ServokitValueError, match="input"):
        fsc_input(
            plant,
            TS,
            16,
            1.0,
            model="rigid-body",
            constraints=[InputLimit(0.1 * np.abs(free.u).max())],
        )
    with pytest.raises(TypeError, match="rows"):
        fsc_input(plant, TS, 16, 1.0, model="rigid-body", constraints=[object()])


def test_public_namespace_resolves_every_name() -> None:
    import servokit.feedforward as ff_pkg

    assert len(set(ff_pkg.__all__)) == len(ff_pkg.__all__)
    for name in ff_pkg.__all__:
        assert getattr(ff_pkg, name) is not None, name
    import importlib

    lazy = set()
    for mod in ff_pkg._LAZY_MODULES:
        lazy |= set(importlib.import_module(f"servokit.feedforward.{mod}").__all__)
    assert lazy <= set(ff_pkg.__all__)


def test_zero_steps_and_bad_bands_are_reported_not_skipped():
    from servokit.feedforward.ffsc import StepsBelowOrderError

    rigid = hdd_benchmark().rigid_body()
    with pytest.raises(StepsBelowOrderError, match="N must be >= 1"):
        fsc_input(rigid, HDD_BENCHMARK_TS, 0, 1.0)
    # a user mistake inside the design must surface, not read as "no N settles"
    with pytest.raises(ServokitValueError, match="f_low_hz <= f_high_hz"):
        choose_N(
            hdd_benchmark(),
            HDD_BENCHMARK_TS,
            1.0,
            range(5, 8),
            design_plant=rigid,
            band_weights=[(5000.0, 1000.0, 1.0, 10)],
        )
