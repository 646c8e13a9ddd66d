"""python-control interoperability: ModalPlant conversions and LTI plants accepted."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitTypeError, ServokitValueError
from servokit.models import CATALOGUE, ModalPlant, Mode, hdd_benchmark
from servokit.models.convert import as_modal_plant, as_modal_plants
from servokit.simulate import seek_time, simulate

PLANTS = {name: make() for name, make in CATALOGUE.items()}
# off-grid frequencies: the rigid body has its pole at 0 Hz, undamped modes at theirs
F = np.geomspace(3.1, 9.7e4, 300)


@pytest.mark.parametrize("name", PLANTS)
def test_to_frd_is_the_exact_response(name: str) -> None:
    p = PLANTS[name]
    frd = p.to_frd(F)
    np.testing.assert_allclose(frd.omega, 2 * np.pi * F)
    np.testing.assert_array_equal(np.asarray(frd.frdata).ravel(), p.freqresp(F))
    import matplotlib.pyplot as plt

    control.bode_plot(frd)  # python-control accepts it
    plt.close("all")


@pytest.mark.parametrize("name", PLANTS)
def test_to_statespace_none_drops_only_the_delay(name: str) -> None:
    p = PLANTS[name]
    H = np.asarray(p.to_statespace()(2j * np.pi * F)).ravel()
    np.testing.assert_allclose(H * np.exp(-2j * np.pi * F * p.delay), p.freqresp(F), rtol=1e-9)


@pytest.mark.parametrize("name", PLANTS)
def test_pade_model_matches_below_its_bandwidth_and_closes_a_loop(name: str) -> None:
    p = PLANTS[name]
    ss = p.to_statespace(delay="pade", pade_order=6)
    assert ss.nstates == p.order + (6 if p.delay > 0 else 0)
    # a Pade approximant of order n is accurate while w Td << n
    f = F[2 * np.pi * F * p.delay < 1.0]
    np.testing.assert_allclose(np.asarray(ss(2j * np.pi * f)).ravel(), p.freqresp(f), rtol=1e-6)
    loop = control.feedback(ss * control.tf([1.0], [1.0, 1.0]))  # any controller multiplies
    assert loop.ninputs == 1 and loop.noutputs == 1


def test_to_discrete_is_discretize() -> None:
    p = hdd_benchmark()
    a, b = p.to_discrete(37.879e-6), p.discretize(37.879e-6)
    for m in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(a, m), getattr(b, m))


def test_bad_conversion_arguments() -> None:
    p = hdd_benchmark()
    with pytest.raises(ServokitValueError, match="'none' or 'pade'"):
        p.to_statespace(delay="exact")  # type: ignore[arg-type]
    with pytest.raises(ServokitValueError, match="pade_order"):
        p.to_statespace(delay="pade", pade_order=0)
    with pytest.raises(ServokitValueError, match="freq_hz"):
        p.to_frd([0.0, 10.0])


@pytest.mark.parametrize("delay", [10.0, 1.5, 1e6])
def test_delay_in_seconds_slip_is_refused(delay: float) -> None:
    # regression: ModalPlant(..., delay=10) meant 10 us and ran out of memory discretising
    with pytest.raises(ServokitValueError, match="delay must be <= 1 s"):
        ModalPlant(1.0, (Mode(0, 0, 1),), delay=delay)


@pytest.mark.parametrize("name", PLANTS)
def test_statespace_round_trip_through_convert(name: str) -> None:
    p = PLANTS[name]
    q = as_modal_plant(p.to_statespace(), p.delay)
    assert len(q.modes) == len(p.modes) and q.delay == p.delay
    np.testing.assert_allclose(q.freqresp(F), p.freqresp(F), rtol=1e-10)


def test_simulate_python_control_plant_equals_modal_plant() -> None:
    p = hdd_benchmark()
    u = np.r_[1e-3, -2e-3, 1e-3, 0.0, 5e-4]
    ref = simulate(p.replace(delay=0.0), dt=37.879e-6, n_samples=60, feedforward=u).yc
    for sys in (p.to_statespace(), control.tf(p.to_statespace())):
        got = simulate(sys, dt=37.879e-6, n_samples=60, feedforward=u).yc
        assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref)) * (
            1 if isinstance(sys, control.StateSpace) else 1e3  # polynomial roots: 1e-9
        )
    delayed = simulate(
        as_modal_plant(p.to_statespace(), p.delay), dt=37.879e-6, n_samples=60, feedforward=u
    ).yc
    full = simulate(p, dt=37.879e-6, n_samples=60, feedforward=u).yc
    assert np.max(np.abs(delayed - full)) <= 1e-12 * np.max(np.abs(full))


def test_sensitivity_accepts_python_control_plant() -> None:
    from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data
    from servokit.sampled import sampled_data_sensitivity

    p = hdd_sampled_data().replace(delay=0.0)
    f = np.linspace(100, 5000, 7)
    a = sampled_data_sensitivity(p, controller_eq_4_69(), HDD_SAMPLED_DATA_TS, f)
    b = sampled_data_sensitivity(p.to_statespace(), controller_eq_4_69(), HDD_SAMPLED_DATA_TS, f)
    np.testing.assert_allclose(b.Ssd, a.Ssd, rtol=1e-9)


@pytest.mark.parametrize(
    ("sys", "message"),
    [
        (control.tf([1.0, 2.0], [1.0, 1.0, 100.0]), "not a sum of modes"),  # s in numerator
        (control.tf([1.0], [1.0, 3.0]), "real pole"),
        (control.tf([1.0], [1.0, 0.0]), "1 pole"),
        (control.tf([1.0, 0.0, 1.0], [1.0, 1.0, 1.0]), "feed-through"),
    ],
)
def test_unrepresentable_plants_are_refused(sys, message: str) -> None:
    with pytest.raises(ServokitValueError, match=message):
        as_modal_plant(sys)


@pytest.mark.parametrize(
    "bad",
    [
        "hdd",
        3.0,
        control.tf([1.0], [1.0, 1.0, 1.0], 1e-3),
        control.ss(np.eye(2), np.ones((2, 2)), np.eye(2), np.zeros((2, 2))),
    ],
)
def test_wrong_plant_types_raise_type_errors(bad) -> None:
    with pytest.raises(ServokitTypeError):
        as_modal_plants(bad)
    with pytest.raises(ServokitTypeError):
        simulate(bad, dt=1e-4, n_samples=3, feedforward=[1.0])


def test_seek_time_of_a_bare_array_says_what_is_accepted() -> None:
    # regression: seek_time(plants, ndarray) gave AttributeError: 'numpy.ndarray' has no 'u'
    with pytest.raises(ServokitTypeError, match=r"\.u \(samples\) and \.dt"):
        seek_time([hdd_benchmark()], np.ones(4), 1.0)


@settings(max_examples=40, deadline=None)
@given(
    modes=st.lists(
        st.tuples(
            st.floats(50.0, 5e4), st.floats(0.0, 0.5), st.floats(0.05, 5.0) | st.floats(-5.0, -0.05)
        ),
        min_size=1,
        max_size=5,
        unique_by=lambda m: round(np.log(m[0]), 1),
    ),
    rigid=st.booleans(),
    delay=st.floats(0.0, 1e-4),
)
def test_convert_recovers_any_modal_plant(modes, rigid, delay) -> None:
    p = ModalPlant(
        2.5, tuple(Mode(*m) for m in ([(0.0, 0.0, 1.0)] if rigid else []) + modes), delay=delay
    )
    q = as_modal_plant(p.to_statespace(), delay)
    np.testing.assert_allclose(q.freqresp(F), p.freqresp(F), rtol=1e-8, atol=0)


@pytest.mark.parametrize("name", PLANTS)
def test_transfer_function_round_trip_through_convert(name: str) -> None:
    """Through a TransferFunction the polynomials round the modes: every catalogue plant
    comes back within the default rtol but the galvano scanner (1.5e-6), which is refused
    as rounding (not as a wrong structure) and comes back with rtol=1e-5."""
    p = PLANTS[name]
    tf = control.tf(p.to_statespace())
    rtol = 1e-6
    if name == "galvano-scanner":
        with pytest.raises(ServokitValueError, match="rounding in the system's coefficients"):
            as_modal_plant(tf, p.delay)
        rtol = 1e-5
    q = as_modal_plant(tf, p.delay, rtol=rtol)
    np.testing.assert_allclose(q.freqresp(F), p.freqresp(F), rtol=10 * rtol)
