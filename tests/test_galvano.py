"""Galvano scanner I/II case (§2.5, §2.6) with the illustrative model."""

from __future__ import annotations

from pathlib import Path

import control
import numpy as np
import pytest

from servokit.cases import registry
from servokit.cases.galvano import (
    GALVANO_GAIN,
    GALVANO_II_TS,
    GALVANO_MOTOR,
    GALVANO_TS,
    ffsc_bands,
    galvano_i,
    galvano_ii,
    normalised_plant,
    primary_mode_variants,
)
from servokit.feedforward.constraints import (
    CurrentLimit,
    InfeasibleConstraintsError,
    VelocityLimit,
    VoltageLimit,
)
from servokit.feedforward.ffsc import fsc_input
from servokit.models import galvano_scanner


@pytest.fixture(scope="module")
def g1():  # noqa: ANN201
    return galvano_i()


@pytest.fixture(scope="module")
def g2():  # noqa: ANN201
    return galvano_ii()


def test_normalisation_and_variants() -> None:
    p = normalised_plant(galvano_scanner(), 1e-3)
    assert p.modes[1].freq_hz == pytest.approx(3.02)
    assert p.delay == pytest.approx(15.5e-3)
    # the normalised frequency response is the physical one at f * unit, up to the gain
    g = galvano_scanner()
    f = np.array([500.0, 2000.0, 5000.0])
    ratio = g.freqresp(f) / p.freqresp(f * 1e-3)
    np.testing.assert_allclose(ratio, ratio[0], rtol=1e-9)
    v = primary_mode_variants(p, np.array([-6.0, 6.0]))
    assert v[0].modes[1].freq_hz == pytest.approx(3.02 * 0.94)
    assert v[1].modes[2] == p.modes[2]


def test_galvano_i_ffsc_more_robust_than_fsc(g1) -> None:  # noqa: ANN001
    nominal = int(np.flatnonzero(g1.percents == 0)[0])
    # nominal plant: both reach the target with no residual vibration
    assert g1.residual_fsc[nominal] < 1e-6 and g1.residual_ffsc[nominal] < 1e-6
    # +-6 %: FSC leaves the 0.08 % band, FFSC stays well inside (Fig. 2.28)
    assert g1.residual_fsc.max() > 8e-4
    assert g1.residual_ffsc.max() < 0.1 * g1.residual_fsc.max()
    assert np.all(np.isfinite(g1.settle_ffsc))
    assert g1.settle_fsc.max() > 1.2 * g1.settle_ffsc.max()
    # the FFSC input is larger than the FSC input (end of §2.5.2)
    assert np.abs(g1.ffsc.u).max() > np.abs(g1.fsc.u).max()
    # spectrum reduced over the +-6 % band of the primary mode
    f1 = normalised_plant(galvano_scanner(), 79 * GALVANO_TS).modes[1].freq_hz
    band = np.linspace(0.94 * f1, 1.06 * f1, 25)
    assert np.abs(g1.ffsc.spectrum(band)).max() < 0.1 * np.abs(g1.fsc.spectrum(band)).max()


def test_band_weights_are_unit_consistent() -> None:
    # the same FFSC input designed in seconds and in a time unit of T seconds
    N, dt = 79, GALVANO_TS
    T = N * dt
    plant_s = galvano_scanner()
    plant_n = normalised_plant(plant_s, T)
    u_s = fsc_input(plant_s, dt, N, 1.0, input_weight=1.0, band_weights=ffsc_bands(plant_s)).u
    u_n = fsc_input(
        plant_n, 1.0 / N, N, 1.0, input_weight=1.0, band_weights=ffsc_bands(plant_n, T)
    ).u
    # gain-1 double integrator: position ~ u t^2, so u scales with 1/T^2
    np.testing.assert_allclose(u_s * T**2, u_n, rtol=1e-8, atol=1e-10 * np.abs(u_n).max())


def _by(g2, target):  # noqa: ANN001, ANN202
    return {d.voltage_limit: d for d in g2 if d.target == target}


def test_galvano_ii_constraints_hold(g2) -> None:  # noqa: ANN001
    assert len(g2) == 9
    m = GALVANO_MOTOR
    for d in g2:
        assert np.abs(d.current).max() <= 12.0 * (1 + 1e-6)
        assert np.abs(d.velocity).max() <= 5.0 * (1 + 1e-6)
        if d.voltage_limit is not None:
            assert np.abs(d.voltage).max() <= d.voltage_limit * (1 + 1e-6)
        # voltage recomputed from (2.84) independently
        i_next = np.append(d.current[1:], 0.0)
        v = m.resistance * d.current + m.inductance * (i_next - d.current) / GALVANO_II_TS
        np.testing.assert_allclose(d.voltage, v + m.back_emf * d.velocity, atol=1e-9)
    # the 72 V and 36 V limits bind for the 0.1 mm and 1 mm steps
    for target in (1e-4, 1e-3):
        ds = _by(g2, target)
        assert np.abs(ds[None].voltage).max() > 72.0
        for lim in (72.0, 36.0):
            assert np.abs(ds[lim].voltage).max() == pytest.approx(lim, rel=1e-6)


def test_galvano_ii_unconstrained_peak_near_book(g2) -> None:  # noqa: ANN001
    # book §2.6.3: VM peaks at 146 V for the unconstrained 1 mm design (L chosen for it)
    peak = np.abs(_by(g2, 1e-3)[None].voltage).max()
    assert peak == pytest.approx(146.0, rel=0.05)
    for d in g2:
        expected = peak + 16.0 if d.voltage_limit is None else d.voltage_limit + 16.0
        assert d.supply == pytest.approx(max(expected, np.abs(d.voltage).max() + 16.0))


def test_galvano_ii_energy_drops_with_voltage_limit(g2) -> None:  # noqa: ANN001
    for target in (1e-4, 1e-3, 1e-2):
        ds = _by(g2, target)
        # Fig. 2.39: Pamp drops drastically as the constraint (and supply) is lowered
        assert ds[None].pamp > 1.5 * ds[72.0].pamp
        assert ds[72.0].pamp > 1.3 * ds[36.0].pamp
    one, ten = _by(g2, 1e-3), _by(g2, 1e-2)
    for lim in (None, 72.0, 36.0):
        assert ten[lim].pamp < 0.6 * one[lim].pamp
    # with the book's N = 37 the unconstrained 0.1 mm design costs far more than 10 mm
    assert _by(g2, 1e-4)[None].book_N_free_pamp > 2 * ten[None].pamp


def test_galvano_ii_ten_mm_coasts_at_velocity_limit(g2) -> None:  # noqa: ANN001
    for d in _by(g2, 1e-2).values():
        assert d.N == 351
        coast = np.abs(d.velocity) >= 0.99 * 5.0
        assert coast.sum() * GALVANO_II_TS > 0.8e-3
        # constant velocity, hence (almost) zero current, in the middle of the coast
        idx = np.flatnonzero(coast)
        mid = slice(idx[0] + 10, idx[-1] - 10)
        assert np.abs(d.current[mid]).max() < 0.1 * np.abs(d.current).max()


def test_galvano_ii_final_state_by_independent_simulation(g2) -> None:  # noqa: ANN001
    plant = galvano_scanner().replace(gain=GALVANO_GAIN, delay=0.0)
    sysd = control.c2d(plant.to_statespace(), GALVANO_II_TS, method="zoh")
    A, B = np.asarray(sysd.A), np.asarray(sysd.B)[:, 0]
    for d in _by(g2, 1e-2).values():
        x = np.zeros(A.shape[0])
        for u in d.ff.u:
            x = A @ x + B * u
        # state order [q_i, dq_i/dt] per mode: rigid body at the target, all else at rest
        expected = np.zeros_like(x)
        expected[0] = d.target
        scale = np.where(np.arange(x.size) % 2 == 0, d.target, 5.0)  # [m], [m/s]
        np.testing.assert_allclose((x - expected) / scale, 0.0, rtol=0, atol=1e-9)


def test_galvano_ii_book_N_infeasible_for_short_step() -> None:
    plant = galvano_scanner().replace(gain=GALVANO_GAIN)
    cons = [CurrentLimit(12.0), VelocityLimit(5.0), VoltageLimit(72.0, motor=GALVANO_MOTOR)]
    with pytest.raises(InfeasibleConstraintsError) as err:
        fsc_input(
            plant,
            GALVANO_II_TS,
            37,
            1e-4,
            input_weight=1.0,
            band_weights=ffsc_bands(plant),
            constraints=cons,
        )
    assert err.value.binding == ("voltage |V| <= 72 V",)


def test_galvano_ii_short_step_uses_smallest_feasible_N(g2) -> None:  # noqa: ANN001
    ds = _by(g2, 1e-4)
    assert all(d.book_N == 37 and d.N > 37 for d in ds.values())
    assert set(ds[36.0].infeasible) == {"voltage |V| <= 72 V", "voltage |V| <= 36 V"}
    # the book-N unconstrained design already needs about twice the 1 mm voltage
    assert ds[None].book_N_free_peak > 1.5 * np.abs(_by(g2, 1e-3)[None].voltage).max()
    # one step fewer is infeasible for some limit
    plant = galvano_scanner().replace(gain=GALVANO_GAIN)
    cons = [CurrentLimit(12.0), VelocityLimit(5.0), VoltageLimit(36.0, motor=GALVANO_MOTOR)]
    with pytest.raises(InfeasibleConstraintsError):
        fsc_input(
            plant,
            GALVANO_II_TS,
            ds[36.0].N - 1,
            1e-4,
            input_weight=1.0,
            band_weights=ffsc_bands(plant),
            constraints=cons,
        )


def test_registered_case_writes_figures(tmp_path: Path) -> None:
    res = registry()["galvano"](tmp_path)
    assert res.name == "galvano" and len(res.figures) == 4
    assert all(p.exists() and p.stat().st_size > 10_000 for p in res.figures)
    assert res.comparisons == []
    assert res.extra["galvano_I"]["N"] == 79


def test_galvano_ii_dense_qp_equals_auto_path() -> None:
    """The case designs with ``qp="dense"``: the banded QP fails on its 8 us problems, so
    ``"auto"`` ends on the dense QP too and both give the same input (demo speed-up)."""
    plant = galvano_scanner().replace(gain=GALVANO_GAIN)
    kw = {"input_weight": 1.0, "band_weights": ffsc_bands(plant)}
    cons = [CurrentLimit(12.0), VelocityLimit(5.0)]
    auto = fsc_input(plant, GALVANO_II_TS, 351, 1e-2, constraints=cons, **kw)
    dense = fsc_input(plant, GALVANO_II_TS, 351, 1e-2, constraints=cons, qp="dense", **kw)
    np.testing.assert_allclose(dense.jerk, auto.jerk, rtol=1e-12, atol=0)
    np.testing.assert_allclose(dense.u, auto.u, rtol=1e-12, atol=0)


@pytest.mark.slow
def test_galvano_ii_dense_qp_equals_auto_path_voltage_limited() -> None:
    plant = galvano_scanner().replace(gain=GALVANO_GAIN)
    kw = {"input_weight": 1.0, "band_weights": ffsc_bands(plant)}
    cons = [CurrentLimit(12.0), VelocityLimit(5.0), VoltageLimit(36.0, motor=GALVANO_MOTOR)]
    auto = fsc_input(plant, GALVANO_II_TS, 351, 1e-2, constraints=cons, **kw)
    dense = fsc_input(plant, GALVANO_II_TS, 351, 1e-2, constraints=cons, qp="dense", **kw)
    np.testing.assert_allclose(dense.jerk, auto.jerk, rtol=1e-12, atol=0)


def test_fsc_input_rejects_unknown_qp() -> None:
    plant = galvano_scanner().replace(gain=GALVANO_GAIN)
    with pytest.raises(ValueError, match="qp must be"):
        fsc_input(plant, GALVANO_II_TS, 351, 1e-2, qp="sparse")  # type: ignore[arg-type]
