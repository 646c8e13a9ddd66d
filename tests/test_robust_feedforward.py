"""Robust minimum-time feedforward (servokit.robust): maps, guarantee, limits, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.models import HDD_BENCHMARK_TS, ModalPlant, Mode, hdd_benchmark_variants
from servokit.seek import robust_minimum_time
from servokit.seek._matrices import PulseBank
from servokit.simulate import seek_time, simulate

DT = 0.01
TARGET, BAND, U_MAX = 1.0, 0.05, 4.0


def _pair(delay: float = 0.0) -> list[ModalPlant]:
    """A rigid body with one lightly damped mode, and a perturbed copy."""
    p = ModalPlant(gain=100.0, modes=(Mode(0.0, 0.0, 1.0), Mode(20.0, 0.05, -0.3)), delay=delay)
    q = p.replace(modes=(Mode(0.0, 0.0, 1.0), Mode(24.0, 0.08, -0.4)), gain=95.0)
    return [p, q]


@pytest.fixture(scope="module")
def design():
    return robust_minimum_time(_pair(), DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.2)


# ------------------------------------------------------------------ the linear maps
@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    u=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=8),
    delay=st.sampled_from([0.0, 0.0037, 0.02]),
)
def test_output_map_equals_simulation(u, delay):
    """(R1): the shifted pulse responses reproduce the simulator's output for any input."""
    plants = _pair(delay)
    bank = PulseBank.build(plants, DT, 5, 0.3)
    rows = np.arange(bank.pulse.shape[1])
    y_map = bank.output_map(len(u), rows) @ np.asarray(u)
    y_sim = simulate(plants, dt=DT, n_samples=31, substeps=5, feedforward=u).yc[:, : rows.size]
    np.testing.assert_allclose(y_map, y_sim, rtol=1e-9, atol=1e-12)


@settings(max_examples=5, deadline=None)
@given(u=st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=8), tail=st.floats(0.0, 0.1))
def test_tail_maps_exact_at_horizon_and_bound_after(u, tail):
    """(R2)-(R3): modal coefficients give y(T) exactly and bound |y(t) - rigid| for t >= T."""
    plants = _pair(0.004)
    u = np.asarray(u) - np.mean(u)  # rigid body at rest after the input
    N = u.size
    bank = PulseBank.build(plants, DT, 2, 0.3)
    J = bank.horizon_index(N, tail)
    tm = bank.tail_maps(N, J)
    y = simulate(plants, dt=DT, n_samples=80, substeps=2, feedforward=u).yc
    rigid = tm.rigid @ u
    a, b = tm.a @ u, tm.b @ u  # (V, M)
    np.testing.assert_allclose(y[:, J], rigid + a.sum(axis=1), rtol=1e-9, atol=1e-12)
    # (R2) exactly: the free motion of every flexible mode from its (a, b)
    tau = np.arange(y.shape[1] - J) * DT / 2
    sigma, wd = bank.z * bank.w, bank.w * np.sqrt(1 - bank.z**2)
    free = np.exp(-sigma[..., None] * tau) * (
        a[..., None] * np.cos(wd[..., None] * tau) + b[..., None] * np.sin(wd[..., None] * tau)
    )
    np.testing.assert_allclose(y[:, J:], rigid[:, None] + free.sum(axis=1), atol=1e-9)
    bound = (np.abs(a) + np.abs(b)).sum(axis=1)
    assert np.all(np.abs(y[:, J:] - rigid[:, None]) <= bound[:, None] * (1 + 1e-9) + 1e-15)


# ------------------------------------------------------------------ the design
def test_guarantee_verified_by_simulation(design):
    """The ordinary simulator (long record) confirms the LP's worst-case seek time."""
    times = seek_time(_pair(), design, TARGET, band=BAND, horizon=5.0)
    assert times.max() <= design.guaranteed_seek_time + 1e-12
    # the bound is tight on the grid: the binding plant is outside the band one step before
    at_band = seek_time(_pair(), design, TARGET, band=design.band, horizon=5.0)
    assert at_band[design.binding_plant] == pytest.approx(design.guaranteed_seek_time)


def test_limits_and_rest(design):
    assert np.max(np.abs(design.u)) <= U_MAX * (1 + 1e-9)
    assert abs(design.u.sum()) <= 1e-9 * U_MAX  # rigid body at rest
    assert design.dt == DT and design.target == TARGET


def test_not_faster_than_the_rigid_body_allows(design):
    """Reaching target - band from rest with |acceleration| <= g u_max takes sqrt(2 d / a)."""
    g_max = max(p.gain for p in _pair())
    t_min = np.sqrt(2 * (TARGET - BAND) / (g_max * U_MAX))
    assert design.guaranteed_seek_time >= t_min


def test_energy_objective_and_slew(design):
    plants, peak = _pair(), design
    energy = robust_minimum_time(
        plants, DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.2, N=peak.N, objective="energy"
    )
    assert energy.guaranteed_seek_time == pytest.approx(peak.guaranteed_seek_time)
    assert np.sum(energy.u**2) <= np.sum(peak.u**2) * (1 + 1e-6)
    assert np.max(np.abs(peak.u)) <= np.max(np.abs(energy.u)) * (1 + 1e-6)
    slew = robust_minimum_time(
        plants, DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.2, slew_max=1.5
    )
    steps = np.diff(np.concatenate([[0.0], slew.u, [0.0]]))
    assert np.max(np.abs(steps)) <= 1.5 * (1 + 1e-6)
    assert slew.guaranteed_seek_time >= peak.guaranteed_seek_time  # a limit never helps
    times = seek_time(plants, slew, TARGET, band=BAND, horizon=5.0)
    assert times.max() <= slew.guaranteed_seek_time + 1e-12


def test_margin_shrinks_the_band():
    plants = _pair()
    d = robust_minimum_time(plants, DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.2, margin=0.3)
    assert d.band == pytest.approx(0.7 * BAND)
    times = seek_time(plants, d, TARGET, band=d.band, horizon=5.0)
    assert times.max() <= d.guaranteed_seek_time + 1e-12


def test_hdd_one_track_beats_design_2():
    """Beyond the book: >= 15 % shorter worst seek than Design 2 at its peak input."""
    from servokit.cases.hdd_seek import DESIGNS

    plants = [p.replace(delay=0.0) for p in hdd_benchmark_variants()]
    d2 = DESIGNS[2]
    ff2 = d2.design(plants[0])
    worst2 = seek_time(plants, ff2, 1.0, band=0.1).max()
    rob = robust_minimum_time(
        plants, HDD_BENCHMARK_TS, 1.0, band=0.1, u_max=float(np.abs(ff2.u).max()), margin=0.0
    )
    worst = seek_time(plants, rob, 1.0, band=0.1, horizon=0.02).max()
    assert worst <= rob.guaranteed_seek_time + 1e-12
    assert worst <= 0.85 * worst2


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"u_max": 0.0}, "u_max must be > 0"),
        ({"u_max": -1.0}, "u_max must be > 0"),
        ({"band": 0.0}, "band must be > 0"),
        ({"margin": 1.0}, "margin must be in"),
        ({"objective": "time"}, "objective must be"),
        ({"band": 2.0}, "already inside the band"),
        ({"N_max": 14, "band": 0.002}, "raise u_max, widen the band"),
        ({"N_max": 12, "u_max": 0.05}, "raise N_max or u_max"),
        ({"grid": 0.003}, "must divide dt"),
    ],
)
def test_bad_input(kw, match):
    args = {"band": BAND, "u_max": U_MAX, "horizon": 0.2} | kw
    with pytest.raises(ServokitValueError, match=match):
        robust_minimum_time(_pair(), DT, TARGET, **args)


def test_empty_and_rigidless_plant_sets():
    with pytest.raises(ServokitValueError, match="empty"):
        robust_minimum_time([], DT, TARGET, band=BAND, u_max=U_MAX)
    spring = ModalPlant(gain=1.0, modes=(Mode(5.0, 0.1, 1.0),), delay=0.0)
    with pytest.raises(ServokitValueError, match="no rigid-body mode"):
        robust_minimum_time(spring, DT, TARGET, band=BAND, u_max=U_MAX)


def test_public_contract_name():
    import servokit.feedforward as ff_pkg

    assert ff_pkg.robust_minimum_time is robust_minimum_time


def test_voltage_limit_of_section_2_6(design):
    """(2.84): R i + L di/dt + Ke v stays within the limit on every plant's rigid body."""
    from servokit.feedforward import MotorModel, VoltageLimit

    plants = _pair()
    motor = MotorModel(resistance=2.0, inductance=0.02, back_emf=0.2)
    free = design
    lim = robust_minimum_time(
        plants,
        DT,
        TARGET,
        band=BAND,
        u_max=U_MAX,
        horizon=0.2,
        limits=[VoltageLimit(7.0, motor=motor)],
    )
    assert lim.guaranteed_seek_time > free.guaranteed_seek_time  # the limit binds
    for p in plants:
        velocity = p.gain * DT * np.concatenate([[0.0], np.cumsum(lim.u)[:-1]])
        assert np.max(np.abs(motor.voltage(lim.u, velocity, DT))) <= 7.0 * (1 + 1e-6)
    times = seek_time(plants, lim, TARGET, band=BAND, horizon=5.0)
    assert times.max() <= lim.guaranteed_seek_time + 1e-12


@pytest.mark.slow
@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    gains=st.tuples(st.floats(60.0, 140.0), st.floats(60.0, 140.0)),
    freq=st.tuples(st.floats(12.0, 30.0), st.floats(12.0, 30.0)),
    damping=st.tuples(st.floats(0.03, 0.3), st.floats(0.03, 0.3)),
    residue=st.tuples(st.floats(-0.5, -0.05), st.floats(0.05, 0.5)),
    delay=st.sampled_from([0.0, 0.004]),
)
def test_guarantee_holds_on_random_plant_sets(gains, freq, damping, residue, delay):
    """For any plant pair: limits met and the simulator confirms the guaranteed seek."""
    from hypothesis import reject

    from servokit.seek import NoFeasibleSeekError

    plants = [
        ModalPlant(gain=g, modes=(Mode(0.0, 0.0, 1.0), Mode(f, z, r)), delay=delay)
        for g, f, z, r in zip(gains, freq, damping, residue, strict=True)
    ]
    try:
        d = robust_minimum_time(
            plants, DT, TARGET, band=0.1, u_max=U_MAX, horizon=0.2, margin=0.0, N_max=30
        )
    except NoFeasibleSeekError:
        reject()
    assert np.max(np.abs(d.u)) <= U_MAX * (1 + 1e-9) and abs(d.u.sum()) <= 1e-9 * U_MAX
    times = seek_time(plants, d, TARGET, band=0.1, horizon=10.0)
    assert times.max() <= d.guaranteed_seek_time + 1e-12


def test_tail_bound_protects_beyond_a_short_horizon():
    """Lightly damped modes and a short checked record: only (R3) keeps the late output in."""
    plants = [
        ModalPlant(gain=g, modes=(Mode(0.0, 0.0, 1.0), Mode(f, 0.005, -0.5)), delay=0.0)
        for g, f in ((100.0, 20.0), (95.0, 23.0))
    ]
    d = robust_minimum_time(plants, DT, TARGET, band=BAND, u_max=U_MAX, horizon=0.02)
    times = seek_time(plants, d, TARGET, band=d.band, horizon=20.0)
    assert np.all(np.isfinite(times)) and times.max() <= d.guaranteed_seek_time + 1e-12
