"""Models: exact frequency response, exact ZOH with fractional delay, catalogue, variations."""

from __future__ import annotations

import math

import control
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import servokit as sk
from servokit.errors import ServokitValueError
from servokit.models import CATALOGUE, HDD_BENCHMARK_TS, HDD_SAMPLED_DATA_TS, ModalPlant, Mode


def _ss_freqresp(plant: ModalPlant, f: np.ndarray) -> np.ndarray:
    sys = plant.to_statespace()
    H = np.array([complex(sys(2j * np.pi * fi)) for fi in f])
    return H * np.exp(-2j * np.pi * f * plant.delay)


@pytest.mark.parametrize("name", list(CATALOGUE))
def test_freqresp_matches_python_control_for_catalogue(name):
    plant = CATALOGUE[name]()
    f = np.logspace(0.5, 4.8, 300)
    H = plant.freqresp(f)
    ref = _ss_freqresp(plant, f)
    assert np.max(np.abs(H - ref) / np.abs(ref)) < 1e-10


def _step_closed_form(plant: ModalPlant, t: np.ndarray) -> np.ndarray:
    """Analytic step response of the modal plant, delay included."""
    tau = np.clip(t - plant.delay, 0.0, None)
    y = np.zeros_like(t)
    for m in plant.modes:
        k = plant.gain * m.residue
        w, z = m.omega, m.damping
        if w == 0:
            y += k * tau**2 / 2
            continue
        wd = w * math.sqrt(1 - z * z)
        g = 1 - np.exp(-z * w * tau) * (
            np.cos(wd * tau) + z / math.sqrt(1 - z * z) * np.sin(wd * tau)
        )
        y += k * g / w**2
    return y


def test_discretize_hdd_benchmark_matches_continuous_step():
    plant = sk.models.hdd_benchmark()
    d = plant.discretize(HDD_BENCHMARK_TS)
    assert d.dt == HDD_BENCHMARK_TS
    # 10 us delay is not a multiple of 37.879 us: one extra delay state
    assert d.nstates == plant.order + 1
    k = np.arange(60)
    yd = control.step_response(d, T=k * HDD_BENCHMARK_TS).outputs
    yc = _step_closed_form(plant, k * HDD_BENCHMARK_TS)
    assert np.max(np.abs(yd - yc)) / np.max(np.abs(yc)) < 1e-9


@pytest.mark.parametrize("delay_steps", [0.0, 1.0, 2.3, 0.4])
def test_discretize_delay_multiples(delay_steps):
    dt = 1e-4
    plant = ModalPlant(2.0e6, (Mode(0, 0, 1), Mode(900.0, 0.05, -0.4)), delay=delay_steps * dt)
    d = plant.discretize(dt)
    k = np.arange(80)
    yd = control.step_response(d, T=k * dt).outputs
    yc = _step_closed_form(plant, k * dt)
    assert np.max(np.abs(yd - yc)) / np.max(np.abs(yc)) < 1e-9
    expected_extra = math.ceil(delay_steps - 1e-12)
    assert d.nstates == plant.order + expected_extra


modes_st = st.lists(
    st.tuples(
        st.floats(50.0, 20000.0),
        st.floats(0.001, 0.5),
        st.floats(-2.0, 2.0).filter(lambda r: abs(r) > 1e-3),
    ),
    min_size=1,
    max_size=4,
)


@settings(max_examples=30, deadline=None)
@given(modes=modes_st, delay_frac=st.floats(0.0, 3.0), f=st.floats(1.0, 3e4))
def test_random_plants_freqresp_and_discretize(modes, delay_frac, f):
    dt = 5e-5
    plant = ModalPlant(
        1e7, (Mode(0, 0, 1),) + tuple(Mode(*m) for m in modes), delay=delay_frac * dt
    )
    H = plant.freqresp(np.array([f]))
    ref = _ss_freqresp(plant, np.array([f]))
    # modes may nearly cancel: measure the error against the size of the terms summed
    s = 2j * np.pi * f
    scale = sum(
        abs(plant.gain * m.residue / (s * s + 2 * m.damping * m.omega * s + m.omega**2))
        for m in plant.modes
    )
    assert abs(H[0] - ref[0]) / scale < 1e-10
    d = plant.discretize(dt)
    k = np.arange(40)
    yd = control.step_response(d, T=k * dt).outputs
    yc = _step_closed_form(plant, k * dt)
    assert np.max(np.abs(yd - yc)) / np.max(np.abs(yc)) < 1e-8


def test_hdd_benchmark_catalogue_values():
    p = sk.models.hdd_benchmark()
    assert p.gain == pytest.approx(
        1.0 / (1e-3 * 2.54e-7), rel=2e-3
    )  # kf/(m Tp), rounded in the book
    assert p.delay == 1e-5
    assert HDD_BENCHMARK_TS == pytest.approx(37.879e-6, rel=1e-5)
    assert [m.freq_hz for m in p.modes] == [0, 3000, 4100, 5000, 7000, 12300, 16400]


def test_hdd_benchmark_variants_are_the_18_table_2_3_plants():
    v = sk.models.hdd_benchmark_variants()
    assert len(v) == 18
    assert v[0].modes == sk.models.hdd_benchmark().modes
    keys = {tuple((m.freq_hz, m.damping, m.residue) for m in p.modes) for p in v}
    assert len(keys) == 18
    f3 = sorted({p.modes[2].freq_hz for p in v})
    assert f3 == pytest.approx([4100 * 0.95, 4100, 4100 * 1.025])
    z5 = sorted({p.modes[4].damping for p in v})
    assert z5 == pytest.approx([0.005, 0.01, 0.02])
    res = {(p.modes[1].residue, p.modes[2].residue, p.modes[3].residue) for p in v}
    assert len(res) == 2
    perturbed = [p for p in v if p.modes[2].residue != -1.0]
    assert len(perturbed) == 9
    for p in perturbed:
        assert p.modes[1].residue == pytest.approx(0.01)
        assert p.modes[2].residue == pytest.approx(-1.2)
        assert p.modes[3].residue == pytest.approx(-0.3)
    # frequency rows move f2, f3, f4..7 together
    for p in v:
        r2, r3, r7 = (
            p.modes[1].freq_hz / 3000,
            p.modes[2].freq_hz / 4100,
            p.modes[6].freq_hz / 16400,
        )
        assert (r2, r3, r7) in [
            (1, 1, 1),
            pytest.approx((1.01, 1.025, 1.005)),
            pytest.approx((0.98, 0.95, 0.98)),
        ]


def test_monte_carlo_is_reproducible_and_in_range():
    vs = sk.models.hdd_benchmark_variation_set()
    a = vs.monte_carlo(50, seed=3)
    b = vs.monte_carlo(50, seed=3)
    c = vs.monte_carlo(50, seed=4)
    assert a == b and a != c
    for p in a:
        assert 4100 * 0.95 <= p.modes[2].freq_hz <= 4100 * 1.025
        kp = 1.0 / (1e-3 * 2.54e-7)  # kf / (m Tp), the benchmark gain
        assert 0.9 * kp <= p.gain <= 1.1 * kp * (1 + 1e-12)
    assert len(vs.corners()) == 3**5 * 2**2  # gain included; ranges ending at 0: 2 levels


def test_rigid_body_and_statespace_order():
    p = sk.models.hdd_benchmark()
    rb = p.rigid_body()
    assert len(rb.modes) == 1 and rb.modes[0].freq_hz == 0
    ss = p.to_statespace()
    assert ss.nstates == 14
    with pytest.raises(ServokitValueError, match="rigid-body"):
        sk.models.pzt_active_suspension().rigid_body()


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: Mode(100.0, -0.1, 1.0), "damping"),
        (lambda: Mode(float("nan"), 0.1, 1.0), "freq_hz"),
        (lambda: ModalPlant(1.0, ()), "empty"),
        (lambda: ModalPlant(float("inf"), (Mode(0, 0, 1),)), "gain"),
        (lambda: ModalPlant(1.0, (Mode(0, 0, 1),), delay=-1e-6), "delay"),
        (lambda: sk.models.hdd_benchmark().discretize(0.0), "dt"),
        (lambda: sk.models.hdd_benchmark().discretize(-1e-5), "dt"),
        (lambda: sk.models.get_plant("no-such-plant"), "unknown plant"),
    ],
)
def test_bad_input_raises_clear_errors(make, match):
    with pytest.raises(ValueError, match=match):
        make()


def test_personal_mobility_robot_is_unstable_upright():
    sys = sk.models.personal_mobility_robot()
    poles = control.poles(sys)
    assert np.max(poles.real) > 0  # an inverted pendulum
    assert sys.noutputs == 3 and sys.ninputs == 1


def test_book_controllers():
    c = sk.models.controller_eq_4_69()
    assert c.dt == pytest.approx(153.5e-6)
    assert sorted(np.real(control.poles(c))) == pytest.approx([0.0182, 0.409, 1.0])
    assert sorted(np.real(control.zeros(c))) == pytest.approx([0.490, 0.865, 0.908])
    # matched pole-zero: the notch's discrete poles are exp(p Ts)
    dt = sk.models.HDD_SAMPLED_DATA_TS
    cz = sk.models.controller_fig_4_57(dt)
    p_notch = control.poles(sk.models.cnc_eq_4_73())
    zp = control.poles(cz)
    for p in np.exp(p_notch * dt):
        assert np.min(np.abs(zp - p)) < 1e-9
    # Tustin keeps the integrator at z = 1
    assert np.min(np.abs(zp - 1.0)) < 1e-9
    v = sk.models.vcm_controller_table_5_2()
    assert v.dt == pytest.approx(1 / 30000)
    assert len(control.poles(v)) == 10


def test_toml_round_trip_and_validation(tmp_path):
    p = sk.models.hdd_benchmark()
    f = tmp_path / "p.toml"
    sk.models.save_plant(p, f)
    q = sk.models.load_plant(f)
    assert q == p
    assert sk.models.get_plant(str(f)) == p

    def write(text):
        g = tmp_path / "bad.toml"
        g.write_text(text)
        return g

    good_mode = "[[modes]]\nfreq_hz = 0.0\ndamping = 0.0\nresidue = 1.0\n"
    cases = [
        ("gain = 1.0\ncolour = 'red'\n" + good_mode, "unknown key 'colour'"),
        (
            "gain = 1.0\n[[modes]]\nfreq_hz = 10.0\ndamping = -0.1\nresidue = 1.0\n",
            r"modes\[0\].damping",
        ),
        ("delay = 0.0\n" + good_mode, "missing field 'gain'"),
        ("gain = nan\n" + good_mode, "'gain' must be finite"),
        ("gain = 1.0\n", "modes"),
        (
            "gain = 1.0\n[[modes]]\nfreq_hz = 0.0\ndamping = 0.0\nresidue = 1.0\nq = 1\n",
            r"modes\[0\].q",
        ),
    ]
    for text, match in cases:
        with pytest.raises(sk.models.PlantFileError, match=match):
            sk.models.load_plant(write(text))


def test_controller_toml(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text(
        "kind = 'controller'\ndt = 153.5e-6\ngain = 0.872\nzeros = [0.490, 0.865, 0.908]\n"
        "poles = [0.0182, 0.409, 1.0]\n"
    )
    c = sk.models.load_controller(f)
    ref = sk.models.controller_eq_4_69()
    w = np.array([0.1, 0.5, 1.5])
    assert np.allclose(c(np.exp(1j * w)), ref(np.exp(1j * w)))
    g = tmp_path / "c2.toml"
    sk.models.save_controller(ref, g)
    c2 = sk.models.load_controller(g)
    assert np.allclose(c2(np.exp(1j * w)), ref(np.exp(1j * w)))
    f.write_text("dt = -1.0\ngain = 1.0\n")
    with pytest.raises(sk.models.PlantFileError, match="'dt'"):
        sk.models.load_controller(f)


@settings(max_examples=40, deadline=None)
@given(
    w=st.floats(0.0, 2e5), z=st.floats(0.0, 2.0), r=st.floats(-1e10, 1e10), t=st.floats(1e-7, 1e-3)
)
def test_batched_expm_matches_scipy_on_modal_blocks(w, z, r, t):
    # the batched path serves fine simulation steps: at most a few decay times per step
    assume(z * w * t < 5.0)
    import scipy.linalg

    from servokit.models._zoh import expm_batched

    M = np.array([[0.0, 1.0, 0.0], [-(w**2), -2 * z * w, r], [0.0, 0.0, 0.0]]) * t
    ref = scipy.linalg.expm(M)
    got = expm_batched(M[None], 2)[0]
    scale = np.abs(ref).max(axis=1, keepdims=True)  # row scale: rows have different units
    assert np.max(np.abs(got - ref) / scale) < 1e-10


def test_get_discrete_controller_by_name_and_errors(tmp_path):
    c = sk.models.get_discrete_controller("eq-4.69", HDD_SAMPLED_DATA_TS)
    assert c.dt == pytest.approx(HDD_SAMPLED_DATA_TS)
    with pytest.raises(ValueError, match="must match"):
        sk.models.get_discrete_controller("eq-4.69", 1e-4)
    f = tmp_path / "c.toml"
    f.write_text("gain = 1.0\nzeros = [-1.0]\npoles = [-2.0]\n")
    with pytest.raises(ValueError, match="continuous"):
        sk.models.get_discrete_controller(str(f))


def test_freqresp_at_a_pole_raises():
    with pytest.raises(ValueError, match="pole"):
        sk.models.hdd_benchmark().freqresp([10.0, 0.0])
    undamped = ModalPlant(1.0, (Mode(100.0, 0.0, 1.0),))
    with pytest.raises(ValueError, match="100 Hz is a pole"):
        undamped.freqresp([100.0])


def test_toml_wrong_container_types(tmp_path):
    f = tmp_path / "p.toml"
    f.write_text("gain = 1.0\nmodes = 5\n")
    with pytest.raises(sk.models.PlantFileError, match="'modes' must be a list"):
        sk.models.load_plant(f)
    g = tmp_path / "c.toml"
    g.write_text("num = 5\nden = [1.0, 2.0]\n")
    with pytest.raises(sk.models.PlantFileError, match="'num' must be a non-empty list"):
        sk.models.load_controller(g)
