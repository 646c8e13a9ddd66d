"""servokit.models.rational against python-control: the numpy-only transfer function and state
space give python-control's coefficients, responses, poles, zeros and connections.

Property tests draw the hard corners: lightly damped pairs (damping down to 1e-6), rigid
bodies (repeated poles at s = 0 / z = 1), unstable poles, frequencies from 1e-3 to 1e6 rad/s
and gains from 1e-12 to 1e12.
"""

from __future__ import annotations

import control
import numpy as np
import pytest
from _mp_reference import numerator_roots_mp
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback.factor_response import make_factor
from servokit.models import (
    CONTROLLERS,
    RationalTF,
    StateSpaceData,
    get_discrete_controller,
    get_discrete_rational,
    get_plant,
    load_controller,
    rational_zpk,
    save_controller,
)
from servokit.models.files import load_controller_rational
from servokit.models.rational import series

_SETTINGS = {"deadline": None, "suppress_health_check": [HealthCheck.too_slow]}


@st.composite
def roots(draw: st.DrawFn, discrete: bool, max_pairs: int = 3) -> list[complex]:
    """Conjugate-closed roots: lightly damped pairs, rigid bodies, unstable and real roots."""
    out: list[complex] = []
    for _ in range(draw(st.integers(0, max_pairs))):
        kind = draw(st.sampled_from(["pair", "rigid", "unstable", "real"]))
        wn = 10 ** draw(st.floats(-3, 6)) if not discrete else draw(st.floats(1e-3, 3.0))
        zeta = 10 ** draw(st.floats(-6, 0))
        if kind == "rigid":
            out += [1.0, 1.0] if discrete else [0.0, 0.0]
            continue
        if kind == "real":
            out.append(draw(st.floats(-0.99, 0.99)) if discrete else -wn)
            continue
        s = complex(-zeta * wn, wn * np.sqrt(max(1 - zeta * zeta, 0.0)))
        if kind == "unstable":
            s = complex(-s.real, s.imag)
        if discrete:  # a pair inside the unit disc (outside for unstable)
            r = (1 - zeta) if kind == "pair" else 1 + zeta
            s = r * np.exp(1j * wn)
        out += [s, s.conjugate()]
    return out


@st.composite
def systems(draw: st.DrawFn, proper: bool = False) -> RationalTF:
    discrete = draw(st.booleans())
    poles = draw(roots(discrete))
    zeros = draw(roots(discrete, max_pairs=2))
    if proper and len(zeros) > len(poles):
        zeros = []  # (cutting the list could split a conjugate pair)
    gain = 10 ** draw(st.floats(-12, 12)) * draw(st.sampled_from([1.0, -1.0]))
    return rational_zpk(zeros, poles, gain, 1e-4 if discrete else None)


def _points(sys: RationalTF) -> np.ndarray:
    """Test points of the complex plane on the system's own scale, off its roots."""
    r = np.abs(np.r_[sys.poles(), sys.zeros(), 1.0])
    scale = float(np.max(r[np.isfinite(r)]))
    return scale * np.array([0.37 + 0.91j, -0.23 + 1.7j, 2.9 - 0.4j, 0.05 + 0.011j])


def _close(a: np.ndarray, b: np.ndarray, rtol: float) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    if a.size == 0 or b.size == 0:
        return a.shape == b.shape
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= rtol * np.max(np.abs(b))))


def _same_roots(a: np.ndarray, b: np.ndarray) -> bool:
    """The same multiset of roots: a root in a cluster of m moves by ``eps^(1/m)`` of its
    scale under rounding of the coefficients (python-control normalises them first)."""
    a, b = list(np.asarray(a)), list(np.asarray(b))
    if len(a) != len(b):
        return False
    scale = max([1.0, *np.abs(a)])
    for r in a:
        m = sum(abs(r - q) < 0.05 * scale for q in a)
        # a simple root near a cluster inherits some of its ill-conditioning (1e-9)
        tol = max(1e-9, 100 * np.finfo(float).eps ** (1 / m)) * scale
        j = int(np.argmin([abs(r - q) for q in b]))
        if abs(r - b[j]) > tol:
            return False
        b.pop(j)
    return True


def _backward_stable_roots(p: np.ndarray, roots_: np.ndarray) -> bool:
    """Each root zeroes the polynomial to rounding, normwise (companion-matrix eigenvalues
    are backward stable in the norm of the coefficients): ``|p(r)| <= 1e-12 ||p|| sum |r|^i``."""
    for r in roots_:
        powers = np.abs(r) ** np.arange(p.size - 1, -1, -1)
        if abs(np.polyval(p, r)) > 1e-12 * np.max(np.abs(p)) * np.sum(powers):
            return False
    return True


@settings(max_examples=60, **_SETTINGS)
@given(sys=systems())
def test_coefficients_response_poles_zeros_match_python_control(sys: RationalTF) -> None:
    ref = control.tf(sys.numerator, sys.denominator, sys.dt)
    assert np.array_equal(ref.num[0][0], sys.num[0][0])
    assert np.array_equal(ref.den[0][0], sys.den[0][0])
    x = _points(sys)
    want = np.array([ref(xi) for xi in x])
    assert np.allclose(sys(x), want, rtol=1e-12, atol=0)
    assert _backward_stable_roots(sys.denominator, sys.poles())
    assert _same_roots(sys.poles(), ref.poles())
    if sys.numerator.size > 1:
        assert _backward_stable_roots(sys.numerator, sys.zeros())
        assert _same_roots(sys.zeros(), ref.zeros())
    assert sys.isdtime() == ref.isdtime() and sys.nstates == ref.den[0][0].size - 1


@settings(max_examples=40, **_SETTINGS)
@given(st.data())
def test_zpk_matches_python_control(data: st.DataObject) -> None:
    discrete = data.draw(st.booleans())
    z, p = data.draw(roots(discrete)), data.draw(roots(discrete))
    k = 10 ** data.draw(st.floats(-12, 12))
    dt = 1e-4 if discrete else 0
    mine, ref = rational_zpk(z, p, k, dt), control.zpk(z, p, k, dt)
    assert _close(mine.numerator, ref.num[0][0], 1e-12)
    assert _close(mine.denominator, ref.den[0][0], 1e-12)


@settings(max_examples=40, **_SETTINGS)
@given(a=systems(), data=st.data())
def test_series_and_feedback_match_python_control(a: RationalTF, data: st.DataObject) -> None:
    b = data.draw(systems())
    b = RationalTF(b.numerator, b.denominator, a.dt)  # one timebase
    ca, cb = a.to_control(), b.to_control()
    prod, ref = a * b, ca * cb
    assert _close(prod.numerator, ref.num[0][0], 1e-12)
    assert _close(prod.denominator, ref.den[0][0], 1e-12)
    k = data.draw(st.floats(-1e3, 1e3).filter(lambda v: v != 0))
    assert _close((k * a).numerator, (k * ca).num[0][0], 1e-15)
    unity = RationalTF([1.0], [1.0], a.dt)
    for h, sign in ((b, -1), (b, 1), (unity, -1)):
        den = np.polysub(
            np.polymul(a.denominator, h.denominator), sign * np.polymul(a.numerator, h.numerator)
        )
        if not np.any(den):  # ill-posed (1 - sign G H == 0): refused, nothing to compare
            with pytest.raises(ServokitValueError, match="ill-posed"):
                a.feedback(h, sign)
            continue
        cl = a.feedback(1.0 if h is unity else h, sign)
        ref = control.feedback(ca, 1 if h is unity else cb, sign)
        # neither cancels anything: the same polynomials up to a common factor
        c = ref.den[0][0][0] / cl.denominator[0]
        assert _close(c * cl.denominator, ref.den[0][0], 1e-12)
        assert _close(c * cl.numerator, ref.num[0][0], 1e-12)


@settings(max_examples=40, **_SETTINGS)
@given(sys=systems(proper=True))
def test_companion_realisation_has_the_poles_and_response(sys: RationalTF) -> None:
    ss = sys.to_state_space()
    # np.roots is the eigenvalues of this companion matrix (after it strips roots at 0)
    assert _same_roots(ss.poles(), sys.poles())
    ref = control.ss(ss.A, ss.B, ss.C, ss.D, ss.dt)
    x = _points(sys)
    assert np.allclose([ss(xi)[0, 0] for xi in x], [ref(xi) for xi in x], rtol=1e-12, atol=0)
    # against the transfer function itself: the companion solve loses accuracy with the
    # spread of the root scales, so this check keeps to systems within four decades
    r = np.abs(np.r_[sys.poles(), sys.zeros()])
    r = r[r > 0]
    if r.size and r.max() / r.min() < 1e4:
        got = np.array([ss(xi)[0, 0] for xi in x])
        assert np.allclose(got, sys(x), rtol=1e-7, atol=0)


@pytest.mark.parametrize(
    "name", ["hdd-benchmark", "hdd-sampled-data", "vcm-dual-stage", "galvano-scanner"]
)
def test_discretize_data_is_the_control_state_space(name: str) -> None:
    plant = get_plant(name)
    for dt in (1e-4, 3.7e-5):
        data, ref = plant.discretize_data(dt), plant.discretize(dt)
        modal = plant.discretize_data(dt, method="modal")
        for m in "ABCD":
            assert np.array_equal(getattr(data, m), getattr(ref, m))
            # closed-form modal ZOH against scipy.linalg.expm: the same states, to rounding
            assert _close(getattr(modal, m), getattr(ref, m), 1e-12)
        assert data.dt == ref.dt and isinstance(data, StateSpaceData)
        assert np.allclose(np.sort_complex(data.zeros()), np.sort_complex(ref.zeros()), rtol=1e-9)
        x = np.exp(2j * np.pi * np.array([50.0, 900.0, 4000.0]) * dt)
        assert np.allclose([data(xi)[0, 0] for xi in x], [ref(xi) for xi in x], rtol=1e-12)


def test_margins_factors_equal_their_python_control_forms() -> None:
    ctrl = get_discrete_rational("table-5.2")
    mine, ref = make_factor(ctrl), make_factor(ctrl.to_control())
    f = np.geomspace(1.0, 14e3, 200)
    assert np.array_equal(mine.response(f), ref.response(f))
    assert np.array_equal(mine.poles, ref.poles) and mine.dt == ref.dt
    plant = get_plant("vcm-dual-stage").discretize_data(ctrl.dt)
    mine, ref = make_factor(plant), make_factor(plant.to_control())
    assert np.allclose(mine.response(f), ref.response(f), rtol=1e-13, atol=0)


@pytest.mark.parametrize("name", sorted(CONTROLLERS))
def test_registry_coefficients_are_the_book_controllers(name: str) -> None:
    mine, ref = get_discrete_rational(name), get_discrete_controller(name)
    assert np.array_equal(mine.numerator, ref.num[0][0])
    assert np.array_equal(mine.denominator, ref.den[0][0])
    assert mine.dt == ref.dt
    with pytest.raises(ServokitValueError, match="must match"):
        get_discrete_rational(name, dt=2 * mine.dt)


def test_controller_file_reads_the_same_without_python_control(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "c.toml"
    save_controller(get_discrete_controller("eq-4.69"), path)
    mine, ref = load_controller_rational(path), load_controller(path)
    assert np.array_equal(mine.numerator, ref.num[0][0]) and mine.dt == ref.dt
    zpk_file = tmp_path / "z.toml"
    zpk_file.write_text("gain = 2.0\nzeros = [0.5]\npoles = [0.1, 0.2]\ndt = 1e-3\n")
    mine, ref = load_controller_rational(zpk_file), load_controller(zpk_file)
    assert np.array_equal(mine.denominator, ref.den[0][0]) and mine.dt == ref.dt


def test_connecting_different_periods_and_improper_realisation_are_refused() -> None:
    a, b = RationalTF([1.0], [1.0, 0.5], 1e-3), RationalTF([1.0], [1.0, 0.5], 2e-3)
    with pytest.raises(ServokitValueError, match="different sampling periods"):
        a * b
    with pytest.raises(ServokitValueError, match="improper"):
        RationalTF([1.0, 0.0, 1.0], [1.0, 1.0]).to_state_space()
    with pytest.raises(ServokitValueError, match="all zeros"):
        RationalTF([1.0], [0.0, 0.0])
    with pytest.raises(ServokitValueError, match="conjugate"):
        rational_zpk([1j], [], 1.0)
    # read-only coefficients: the factor cache keys on identity
    with pytest.raises(ValueError):
        a.numerator[0] = 2.0


def test_round_trip_and_dc_gain() -> None:
    ref = control.tf([2.0, 1.0], [1.0, 3.0, 2.0], 0.01)
    mine = RationalTF.from_control(ref)
    assert mine.dcgain() == pytest.approx(float(np.real(control.dcgain(ref))), rel=1e-14)
    back = mine.to_control()
    assert np.array_equal(back.num[0][0], ref.num[0][0]) and back.dt == ref.dt
    assert RationalTF([1.0], [1.0, 0.0]).dcgain() == float("inf")
    assert (-mine).numerator.tolist() == [-2.0, -1.0]


def _tustin_numerator_exact(
    zeros: list[complex], poles: list[complex], gain: float, dt: float, warp: float | None
) -> np.ndarray:
    """The Tustin numerator of ``gain prod(s - z) / prod(s - p)`` over its denominator's
    leading coefficient, by substituting s = c (z - 1)/(z + 1) in 50 digits."""
    import mpmath

    with mpmath.workdps(50):
        c = 2 / mpmath.mpf(dt) if warp is None else warp / mpmath.tan(mpmath.mpf(warp) * dt / 2)
        # a factor (a z + b): c (z - 1) - q (z + 1) per zero q, (z + 1) per excess pole
        factors = [(c - q, -c - q) for q in map(mpmath.mpc, zeros)]
        factors += [(1, 1)] * (len(poles) - len(zeros))
        num = [mpmath.mpf(gain)]
        for a, b in factors:
            padded = [0, *num, 0]
            num = [padded[i + 1] * a + padded[i] * b for i in range(len(num) + 1)]
        lead = mpmath.fprod([c - mpmath.mpc(q) for q in poles])
        return np.array([float(mpmath.re(x / lead)) for x in num])


@settings(max_examples=40, **_SETTINGS)
@given(st.data())
def test_tustin_is_python_controls_sample_system(data: st.DataObject) -> None:
    poles = data.draw(roots(discrete=False))
    assume(poles)  # (SciPy realises a static gain with a cancelled pole-zero pair at z = 1)
    zeros = data.draw(roots(discrete=False, max_pairs=1))
    if len(zeros) > len(poles):
        zeros = []
    gain = 10 ** data.draw(st.floats(-6, 6))
    sys = rational_zpk(zeros, poles, gain)
    scale = max([1.0, *np.abs(poles), *np.abs(zeros)])
    dt = data.draw(st.floats(0.01, 1.0)) / scale
    warp = data.draw(st.one_of(st.none(), st.floats(0.01, 1.0).map(lambda v: v / dt)))
    mine = sys.tustin(dt, prewarp_rad_s=warp)
    ref = control.sample_system(sys.to_control(), dt, "tustin", prewarp_frequency=warp)
    assert mine.dt == ref.dt
    if not np.any(ref.num[0][0]):  # the numerator is below eps |den|: zero in both
        assert np.max(np.abs(mine.numerator)) <= 1e-12 * np.max(np.abs(mine.denominator))
        return
    # the same arithmetic (numpy's LAPACK solve for SciPy's): coefficients to rounding
    k = ref.den[0][0][0] / mine.denominator[0]
    assert _close(k * mine.denominator, ref.den[0][0], 1e-10)
    # num = det(zI - Ad + Bd Cd) + (Dd - 1) den cancels, so both numerators lose digits
    # with the gain (measured against the exact substitution s = c (z - 1)/(z + 1) in
    # 50 digits, relative to max(|num|, |den|): 6e-12 for python-control on a double
    # integrator with a gain of 1e4, 1.9e-11 for both on 1e6/(s + 1)^2): ours within
    # 1e-9 of the exact numerator, and within 1e-10 of python-control's
    exact = _tustin_numerator_exact(zeros, poles, gain, dt, warp)
    num_ref = np.trim_zeros(ref.num[0][0], "f") / ref.den[0][0][0]
    num_mine = mine.numerator / mine.denominator[0]
    scale = max(np.max(np.abs(mine.denominator / mine.denominator[0])), np.max(np.abs(exact)))
    n = max(num_ref.size, num_mine.size, exact.size)
    pad = lambda v: np.r_[np.zeros(n - v.size), v]  # noqa: E731
    assert np.max(np.abs(pad(num_mine) - pad(exact))) <= 1e-9 * scale
    assert np.max(np.abs(pad(num_mine) - pad(num_ref))) <= 1e-10 * scale


@settings(max_examples=30, **_SETTINGS)
@given(a=systems(proper=True), data=st.data())
def test_state_space_series_and_static_feedback_are_python_controls(
    a: RationalTF, data: st.DataObject
) -> None:
    b = data.draw(systems(proper=True))
    b = RationalTF(b.numerator, b.denominator, a.dt)
    sa, sb = a.to_state_space(), b.to_state_space()
    mine, ref = series(sa, sb), control.series(sa.to_control(), sb.to_control())
    for m in "ABCD":
        assert np.array_equal(getattr(mine, m), getattr(ref, m))
    gain = data.draw(st.floats(-10.0, 10.0))
    sign = data.draw(st.sampled_from([-1, 1]))
    assume(abs(1.0 - sign * gain * sa.D[0, 0]) > 1e-6)
    mine, ref = sa.feedback(gain, sign), control.feedback(sa.to_control(), gain, sign)
    for m in "ABCD":
        want = np.asarray(getattr(ref, m))
        assert _close(getattr(mine, m), want, 1e-14) or not np.any(want)


def test_multirate_model_and_filter_equal_the_python_control_build() -> None:
    from servokit.models import HDD_SAMPLED_DATA_TS
    from servokit.sampled import hdd_multirate, multirate_filter_4_68
    from servokit.sampled.hdd_multirate import FILTER_HZ

    dt, m = HDD_SAMPLED_DATA_TS, 4
    wf = 2 * np.pi * FILTER_HZ
    fmc = 1 - control.tf([0.1, 0.0, 0.0], [1.0, 2 * 0.003 * wf, wf**2])
    ref_fm = control.sample_system(fmc, dt / m, method="tustin", prewarp_frequency=wf)
    fm = multirate_filter_4_68(dt, m)
    assert _close(fm.num[0][0], ref_fm.num[0][0], 1e-12)
    assert _close(fm.den[0][0], ref_fm.den[0][0], 1e-12)
    # the python-control build of eq. (4.25) as it was: series of ss(Ip Fm) and the plant
    plant = get_plant("hdd-sampled-data")
    ip = control.tf(np.ones(m), np.r_[1.0, np.zeros(m - 1)], dt / m)
    fast = control.series(control.ss(control.series(ip, ref_fm)), plant.discretize(dt / m))
    Am1 = np.linalg.matrix_power(np.asarray(fast.A), m - 1)
    mine = hdd_multirate(dt, m).discretize(plant, dt)
    assert _close(mine.A, Am1 @ fast.A, 1e-12) and _close(mine.B, Am1 @ fast.B, 1e-12)
    assert np.array_equal(mine.C, fast.C) and mine.dt == dt
    assert isinstance(hdd_multirate(dt, m).chain(dt), control.TransferFunction)


@pytest.mark.slow
def test_siso_zeros_of_the_vcm_plant_against_150_digits() -> None:
    from servokit.models import vcm_dual_stage
    from servokit.models.modal import modal_matrices
    from servokit.models.rational import siso_zeros

    A, B, C = modal_matrices(*vcm_dual_stage().arrays())
    ref = numerator_roots_mp(A, B.ravel(), C.ravel())
    got = siso_zeros(A, B, C)
    assert got.size == ref.size == A.shape[0] - 2  # relative degree 2 (force to position)
    err = [np.min(np.abs(got - r)) / abs(r) for r in ref]
    assert max(err) < 1e-12  # measured 2.2e-14 (the pencil's QZ: 1.8e-6)


@settings(max_examples=40, **_SETTINGS)
@given(data=st.data())
def test_siso_zeros_are_the_numerators_roots(data: st.DataObject) -> None:
    """Random modal systems (damping down to 1e-6, a rigid body or not, relative degree 1
    or 2): the zero dynamics' eigenvalues against the numerator's roots in 60 digits."""
    from servokit.models.rational import siso_zeros

    rng = np.random.default_rng(data.draw(st.integers(0, 2**32 - 1)))
    n_modes = data.draw(st.integers(1, 4))
    blocks = []
    for _ in range(n_modes):
        w = 10 ** rng.uniform(0, 2)
        z = 10 ** rng.uniform(-6, -0.5)
        blocks.append(np.array([[0.0, 1.0], [-w * w, -2 * z * w]]))
    if data.draw(st.booleans()):
        blocks.append(np.array([[0.0, 1.0], [0.0, 0.0]]))  # a rigid body: Jordan block
    n = 2 * len(blocks)
    A = np.zeros((n, n))
    for i, blk in enumerate(blocks):
        A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] = blk
    b = np.zeros(n)
    b[1::2] = rng.uniform(0.5, 2.0, n // 2)  # force into every velocity
    c = np.zeros(n)
    c[0::2] = rng.choice([-1, 1], n // 2) * rng.uniform(0.5, 2.0, n // 2)  # positions
    if data.draw(st.booleans()):
        c[1::2] = 0.3 * rng.standard_normal(n // 2)  # velocity read too: relative degree 1
    ref = numerator_roots_mp(A, b, c, dps=60)
    got = siso_zeros(A, b, c)
    assert got.size == ref.size
    scale = max([1.0, *np.abs(ref)])
    for r in ref:  # well-separated for these sizes: each root matched to rounding
        assert np.min(np.abs(got - r)) <= 1e-7 * scale
