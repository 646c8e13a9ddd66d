"""Margins on named loops: the issue's resonant example, delay margins re-derived from
closed-loop poles, the stability verdict on boundary/unstable poles, the worst plant."""

from __future__ import annotations

import control
import numpy as np
import pytest
from _margin_loops import brute_crossings, build, packed_grid

from servokit.feedback import frequency_grid, margins_over_set, stability_margins
from servokit.feedback.factor_response import make_factor
from servokit.models import Mode, benchmark_controller, hdd_benchmark_variants


def _cl_unstable(loop: control.LTI, delay: float = 0.0, order: int = 10) -> bool:
    """Closed-loop instability from poles; a continuous delay by a Padé approximant."""
    if delay:
        loop = loop * control.tf(*control.pade(delay, order))
    p = np.asarray(control.feedback(loop, 1).poles())
    return bool(np.any(np.abs(p) > 1)) if loop.isdtime() else bool(np.any(p.real > 0))


def _phase_stabilised() -> control.TransferFunction:
    w1 = 2 * np.pi * 5000.0
    plant = control.tf([1.0], [1, 0, 0]) + control.tf([5.0], [1, 2 * 0.01 * w1, w1 * w1])
    wc = 2 * np.pi * 500.0
    ctrl = control.tf([1 / (wc / 3), 1], [1 / (3 * wc), 1])
    return plant * ctrl * (1 / abs(complex((plant * ctrl)(1j * wc))))


def test_resonant_loop_of_the_issue_finds_all_five_phase_crossovers():
    # rigid body + modes at 3.0/7.1/11.3 kHz with zeta = 1e-5, 10 us delay, a lead
    modes = [Mode(0, 0, 1), Mode(3000, 1e-5, 0.5), Mode(7100, 1e-5, 0.6), Mode(11300, 1e-5, 0.8)]
    case = build(modes, 10e-6, 400.0, 1.0, None)
    m = stability_margins(case.factors, fmax=20e3)
    f = packed_grid(case, 1e-4, 20e3)
    wc, w180 = brute_crossings(case.response, f)
    assert len(m.phase_crossovers_hz) == 5
    seen = [f for f, gm in zip(m.phase_crossovers_hz, m.gain_margins_db, strict=True) if gm < 80]
    assert np.array(seen) == pytest.approx(w180, rel=1e-5)  # the reference sees |L| > 1e-4
    # two of the five sit at the anti-resonances (|L| ~ 1e-5): verified on the exact response
    l180 = case.response(np.array(m.phase_crossovers_hz))
    assert np.all(l180.real < 0) and np.all(np.abs(np.angle(-l180)) < 1e-6)
    assert np.array(m.gain_crossovers_hz) == pytest.approx(wc, rel=1e-5)
    # the old search (20 000 log points, left point only) steps over the mode peaks
    g = np.geomspace(1e-4, 20e3, 20000)
    L = case.response(g)
    naive = np.nonzero((np.sign(L.imag[:-1]) != np.sign(L.imag[1:])) & (L.real[:-1] < 0))[0]
    assert naive.size < 5
    # the peaks cross 0 dB with the wrong phase: unstable, as the closed-loop poles say
    assert m.closed_loop_stable is False
    assert case.unstable()[0]
    assert m.delay_margin_s == 0.0


def test_delay_margin_minimum_over_crossovers_uses_the_modulo_and_is_exact():
    loop = _phase_stabilised()
    m = stability_margins(loop)
    assert m.closed_loop_stable is True
    assert len(m.gain_crossovers_hz) == 3
    # every crossover's delay margin puts L e^{-jw tau} on -1, and is >= 0 even where the
    # wrapped phase margin is negative (-171.7 deg at 4.6 kHz: reached after 188.3 deg)
    assert min(m.phase_margins_deg) < 0
    for f, tau in zip(m.gain_crossovers_hz, m.delay_margins_s, strict=True):
        assert tau >= 0
        v = complex(loop(2j * np.pi * f)) * np.exp(-2j * np.pi * f * tau)
        assert v == pytest.approx(-1.0, abs=1e-9)
    # the headline is the minimum (the 5.4 kHz peak), not the crossover of smallest PM
    assert m.delay_margin_s == pytest.approx(min(m.delay_margins_s))
    k_small_pm = int(np.argmin(m.phase_margins_deg))
    assert m.delay_margin_s < m.delay_margins_s[k_small_pm]
    # closed-loop poles with the delay (Pade order 10): stable just below, unstable above
    assert not _cl_unstable(loop, 0.999 * m.delay_margin_s)
    assert _cl_unstable(loop, 1.001 * m.delay_margin_s)


@pytest.mark.parametrize("fc", [150.0, 400.0])
def test_delay_margin_of_a_rigid_body_loop_by_closed_loop_poles(fc):
    case = build([Mode(0, 0, 1), Mode(6000, 0.02, -0.3)], 0.0, fc, 1.0, None)
    m = stability_margins(case.factors)
    assert m.closed_loop_stable is True
    loop = case.plant.to_statespace() * control.ss(case.ctrl)
    assert not _cl_unstable(loop, 0.999 * m.delay_margin_s)
    assert _cl_unstable(loop, 1.001 * m.delay_margin_s)
    # the verdict at the delayed loop agrees too
    assert stability_margins(case.factors, 1.001 * m.delay_margin_s).closed_loop_stable is False


def test_delay_margin_of_a_discrete_loop_in_whole_samples():
    # a discrete loop whose delay margin is a whole number of samples is exact: z^-d
    dt = 0.05
    base = control.sample_system(control.tf([1.0], [1, 1, 0]), dt)
    z = control.tf([1.0, 0.0], [1.0], dt)
    w = 2 * np.pi * 0.1
    k = 1 / abs(complex(base(np.exp(1j * w * dt))))
    m0 = stability_margins(base * k)
    d = int(np.floor(m0.delay_margin_s / dt))
    assert d > 10
    loop = base * k * (1 / z) ** d  # just inside
    assert stability_margins(loop).closed_loop_stable is not _cl_unstable(loop)
    over = loop * (1 / z)
    assert stability_margins(over).closed_loop_stable is not _cl_unstable(over)
    assert _cl_unstable(over) and not _cl_unstable(loop)


@pytest.mark.parametrize(
    "loop, stable",
    [
        (control.tf([2.0], [1, -1]), True),  # P = 1, cl pole -1
        (control.tf([0.5], [1, -1]), False),  # cl pole +0.5
        (control.tf([1.0], [1, -1.5], 0.1), True),  # P = 1, cl pole 0.5
        (control.tf([0.3], [1, -1.5], 0.1), False),  # cl pole 1.2
        (control.tf([1.0], [1, 1, 0]), True),  # integrator
        (control.tf([10.0, 10.0], [1, 0, 0, 0]) * control.tf([1], [0.01, 1]), False),
        (control.tf([100.0, 200.0, 100.0], [1, 0, 0, 0]) * control.tf([1], [0.01, 1]), True),
    ],
)
def test_verdict_matches_closed_loop_poles(loop, stable):
    assert _cl_unstable(loop) is not stable
    assert stability_margins(loop).closed_loop_stable is stable


def test_verdict_on_a_rigid_body_jordan_block_state_space():
    # rigid body as the Jordan block [[0, 1], [0, 0]], PID-lead on it, continuous and ZOH
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    plant = control.ss(A, [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]])
    wc = 2 * np.pi * 100
    ctrl = control.tf([1 / (wc / 3), 1], [1 / (3 * wc), 1]) * control.tf([1, wc / 8], [1, 0])
    for gain in (wc**2 / 3, wc**2 * 300):
        loop = plant * ctrl * gain
        assert stability_margins(loop).closed_loop_stable is not _cl_unstable(loop)
        dt = 1e-4
        loop_d = control.sample_system(plant, dt) * control.sample_system(ctrl * gain, dt, "tustin")
        assert stability_margins(loop_d).closed_loop_stable is not _cl_unstable(loop_d)


def test_modulus_margin_is_the_minimum_distance_to_minus_one():
    loop = _phase_stabilised()
    m = stability_margins(loop)
    f = np.geomspace(1.0, 1e5, 400_001)
    d = np.abs(1 + np.asarray(loop(2j * np.pi * f)).ravel())
    assert m.modulus_margin == pytest.approx(d.min(), rel=1e-6)
    assert m.modulus_margin <= d.min()
    assert m.modulus_margin_freq_hz == pytest.approx(f[np.argmin(d)], rel=1e-4)


def test_reduced_forms_agree_with_python_control():
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark

    pd = hdd_benchmark().discretize(HDD_BENCHMARK_TS)  # Jordan block at z = 1
    f = np.geomspace(1.0, 0.5 / HDD_BENCHMARK_TS, 500)
    ref = np.asarray(pd(np.exp(2j * np.pi * f * HDD_BENCHMARK_TS))).ravel()
    fa = make_factor(pd)
    assert fa.response(f) == pytest.approx(ref, rel=1e-8)
    assert np.sum(np.abs(fa.poles - 1) < 1e-6) == 2
    # continuous rigid body + modes as a state space, and a dense random one
    sys = hdd_benchmark().to_statespace()
    ref = np.asarray(sys(2j * np.pi * f)).ravel()
    assert make_factor(sys).response(f) == pytest.approx(ref, rel=1e-8)
    rnd = control.rss(12, 1, 1, strictly_proper=False)
    ref = np.asarray(rnd(2j * np.pi * f)).ravel()
    assert make_factor(rnd).response(f) == pytest.approx(ref, rel=1e-8)


def test_frequency_grid_resolves_a_mode_with_damping_1e_6():
    wn = 2 * np.pi * 5000.0
    sys = control.tf([wn * wn], [1, 2e-6 * wn, wn * wn])
    f = frequency_grid(sys, 10.0, 1e5, 500)
    peak = np.abs(np.asarray(sys(2j * np.pi * f)).ravel()).max()
    assert peak == pytest.approx(1 / (2e-6), rel=1e-3)  # the resonance peak 1/(2 zeta)
    assert f[0] == 10.0 and f[-1] == 1e5


def test_margins_over_a_plant_set_name_the_worst_plant():
    plants = hdd_benchmark_variants()[:6]
    ctrl = benchmark_controller()
    ticks = []
    res = margins_over_set(ctrl, plants, progress=lambda: ticks.append(len(ticks)))
    assert ticks == list(range(len(plants)))  # one progress call after each plant
    direct = [stability_margins([p.discretize(ctrl.dt), ctrl]) for p in plants]
    assert [m.phase_margin_deg for m in res.margins] == pytest.approx(
        [m.phase_margin_deg for m in direct]
    )
    assert res.all_stable is True
    mm = [m.modulus_margin for m in direct]
    assert res.worst_index == int(np.argmin(mm))
    assert res.min_phase_margin_deg == pytest.approx(min(m.phase_margin_deg for m in direct))
    # a plant with ten times the gain destabilises the loop and becomes the worst
    loud = plants[2].replace(gain=plants[2].gain * 10)
    res2 = margins_over_set(ctrl, [*plants, loud])
    assert res2.all_stable is False and res2.worst_index == len(plants)
    assert res2.to_dict()["worst_index"] == len(plants)


def test_ieej_benchmark_loop_margins_against_python_control_and_poles():
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark, ieej_example_controller

    pd = hdd_benchmark().discretize(HDD_BENCHMARK_TS)
    ctrl = ieej_example_controller()
    m = stability_margins([pd, *ctrl])
    full = control.ss(pd)
    for c in ctrl:
        full = full * control.ss(c)
    assert full.nstates == 25
    gm, pm, sm, w180, wc, wms = control.stability_margins(full)
    assert m.phase_margin_deg == pytest.approx(pm, abs=1e-3)  # python-control's polynomials
    assert m.pm_freq_hz == pytest.approx(wc / (2 * np.pi), rel=1e-5)
    assert m.modulus_margin == pytest.approx(sm, rel=1e-6)
    # python-control's headline GM is at its own (spurious-prone) choice; ours is listed
    assert min(abs(np.array(m.phase_crossovers_hz) - w180 / (2 * np.pi))) < 1e-3 * w180
    assert m.closed_loop_stable is True and not _cl_unstable(full)
    # the values the docstring of ieej_example_controller states
    assert m.phase_margin_deg == pytest.approx(33.45, abs=0.01)
    assert m.gain_margin_db == pytest.approx(4.307, abs=0.001)
    assert m.gm_freq_hz == pytest.approx(1634.2, abs=0.1)
    assert m.delay_margin_s == pytest.approx(95.54e-6, abs=0.01e-6)
    # an independent grid (python-control's dense evaluation) sees the same crossings
    f = np.linspace(1.0, 0.5 / HDD_BENCHMARK_TS * (1 - 1e-9), 20_001)
    L = np.asarray(full(np.exp(2j * np.pi * f * HDD_BENCHMARK_TS))).ravel()
    wc_ref, w180_ref = brute_crossings(lambda x: L, f)
    assert np.array(m.gain_crossovers_hz) == pytest.approx(wc_ref, rel=1e-4)
    assert np.array(m.phase_crossovers_hz) == pytest.approx(w180_ref, rel=1e-4)


def _book_loop() -> tuple:
    from servokit.models import hdd_benchmark, ieej_example_controller

    return hdd_benchmark(), ieej_example_controller()


def _issue_loop() -> tuple:
    from servokit.models import ieej_benchmark_loop, ieej_benchmark_plant

    return ieej_benchmark_plant(), ieej_benchmark_loop()[1:]


@pytest.mark.parametrize("make", [_book_loop, _issue_loop], ids=["book-plant", "issue-20-loop"])
def test_delay_margin_of_the_sampled_data_benchmark_loop_by_exact_rediscretisation(make):
    # discrete controller + continuous plant: the extra delay (2.5 samples, fractional)
    # is put into the continuous plant and the loop discretised again exactly (delayed ZOH,
    # extra delay states); the closed-loop poles decide
    from scipy.optimize import brentq

    from servokit.models import HDD_BENCHMARK_TS

    plant, ctrl = make()
    m = stability_margins([plant.discretize(HDD_BENCHMARK_TS), *ctrl])
    tau = m.delay_margin_s
    assert 0.05 < tau / HDD_BENCHMARK_TS % 1 < 0.95  # a fractional number of samples
    c_ss = control.ss(ctrl[0])
    for c in ctrl[1:]:
        c_ss = c_ss * control.ss(c)
    assert control.ss(plant.discretize(HDD_BENCHMARK_TS)).nstates + c_ss.nstates == 25

    def radius(extra: float) -> float:
        pd = plant.replace(delay=plant.delay + extra).discretize(HDD_BENCHMARK_TS)
        return float(np.max(np.abs(control.feedback(control.ss(pd) * c_ss, 1).poles())))

    assert radius(0.999 * tau) < 1.0 < radius(1.001 * tau)
    # the e^{-j w tau} model of the extra delay ignores how the aliased images of the plant
    # turn with it: the exact critical delay is a few 1e-4 shorter
    exact = brentq(lambda x: radius(x) - 1.0, 0.99 * tau, 1.01 * tau, xtol=1e-13)
    assert exact / tau == pytest.approx(1.0, abs=1e-3)
    assert exact < tau


def test_issue_20_benchmark_loop_numbers():
    # issue 20: PM 35.17 deg, GM 4.11 dB at 1626 Hz, delay margin 97.68 us (25 states)
    from servokit.models import ieej_benchmark_loop

    loop = ieej_benchmark_loop()
    m = stability_margins(loop)
    assert m.phase_margin_deg == pytest.approx(35.17, abs=0.01)
    assert m.gain_margin_db == pytest.approx(4.11, abs=0.01)
    assert m.gm_freq_hz == pytest.approx(1626.0, abs=1.0)
    assert m.delay_margin_s * 1e6 == pytest.approx(97.68, abs=0.01)
    full = control.ss(loop[0])
    for c in loop[1:]:
        full = full * control.ss(c)
    assert full.nstates == 25
    assert m.closed_loop_stable is True and not _cl_unstable(full)
    # python-control's dense state-space evaluation at our crossings: exact
    from servokit.models import HDD_BENCHMARK_TS

    def dense(f: float) -> complex:
        return complex(full(np.exp(2j * np.pi * f * HDD_BENCHMARK_TS)))

    assert abs(dense(m.pm_freq_hz)) == pytest.approx(1.0, abs=1e-10)
    assert 180 + np.degrees(np.angle(dense(m.pm_freq_hz))) == pytest.approx(35.17, abs=0.01)
    assert -20 * np.log10(abs(dense(m.gm_freq_hz))) == pytest.approx(m.gain_margin_db, abs=1e-9)
    # python-control's own stability_margins (polynomial roots) drifts here: |L| = 0.99991
    # at its crossover, PM 35.165 deg
    _gm, pm, _sm, _w180, wc, _wms = control.stability_margins(full)
    assert abs(dense(wc / (2 * np.pi))) != pytest.approx(1.0, abs=1e-5)
    assert m.phase_margin_deg == pytest.approx(pm, abs=0.01)


def test_issue_20_loop_fit_predicts_the_other_two_numbers():
    # fit the low-pass damping and the crossover (notch pole damping 0.5) to the PM and the
    # delay margin only: the gain margin and the phase crossover are then predictions
    from servokit.feedback import fit_ieej_loop
    from servokit.models import ieej_benchmark_loop
    from servokit.models.benchmark_controller import (
        IEEJ_FITTED_CROSSOVER_HZ,
        IEEJ_FITTED_LOWPASS_DAMPING,
    )

    fit = fit_ieej_loop()
    assert fit.fitted_to == ("phase_margin_deg", "delay_margin_s")
    # the library's constants are this fit, rounded to their printed digits
    assert IEEJ_FITTED_LOWPASS_DAMPING == pytest.approx(fit.lowpass_damping, abs=5e-5)
    assert IEEJ_FITTED_CROSSOVER_HZ == pytest.approx(fit.crossover_hz, abs=5e-3)
    assert fit.notch_pole_damping == (0.5, 0.5, 0.5)
    assert fit.residuals["phase_margin_deg"] == pytest.approx(0.0, abs=1e-6)
    assert fit.residuals["delay_margin_s"] == pytest.approx(0.0, abs=1e-12)
    # predictions, within the issue's digits
    assert fit.numbers["gain_margin_db"] == pytest.approx(4.11, abs=0.01)
    assert fit.numbers["gm_freq_hz"] == pytest.approx(1626.0, abs=1.0)
    # and the loop built from the rounded constants gives the issue's four numbers too
    m = stability_margins(ieej_benchmark_loop())
    assert m.phase_margin_deg == pytest.approx(35.17, abs=0.005)
    assert m.delay_margin_s == pytest.approx(97.68e-6, abs=0.005e-6)


def test_ieej_controller_options_crossover_and_matched_sections():
    from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark, ieej_example_controller

    pd = hdd_benchmark().discretize(HDD_BENCHMARK_TS)
    for method in ("tustin", "matched"):
        ctrl = ieej_example_controller(crossover_hz=1000.0, method=method)
        z = np.exp(2j * np.pi * 1000.0 * HDD_BENCHMARK_TS)
        loop = complex(pd(z)) * np.prod([complex(c(z)) for c in ctrl])
        assert abs(loop) == pytest.approx(1.0, rel=1e-12)
        m = stability_margins([pd, *ctrl])
        assert m.gain_crossovers_hz[0] == pytest.approx(1000.0, rel=1e-6)
        for c in ctrl[1:]:  # notches and low-pass: unit DC gain, poles inside |z| < 1
            assert complex(c(1.0)) == pytest.approx(1.0, rel=1e-12)
            assert np.all(np.abs(c.poles()) < 1)
    # matched low-pass: its two zeros at infinity go to z = -1 (zero gain at Nyquist)
    low = ieej_example_controller(method="matched")[-1]
    assert abs(complex(low(-1.0))) < 1e-12
    with pytest.raises(ValueError, match="method"):
        ieej_example_controller(method="zoh")
    with pytest.raises(ValueError, match="lowpass_damping"):
        ieej_example_controller(lowpass_damping=0.0)
    with pytest.raises(ValueError, match="notch_pole_damping"):
        ieej_example_controller(notch_pole_damping=(0.5, -1.0, 0.5))


def test_a_crossing_pair_beside_a_grid_point_exactly_on_0_db():
    # found by the slow property test: |L(600 Hz)| = 1 exactly at a packed grid point, and
    # the resonance rises above 0 dB just after it and falls back at 600.2157 Hz
    from _margin_loops import LoopCase, lead

    from servokit.models import ModalPlant

    plant = ModalPlant(94713.47792893233, (Mode(5.0, 0.5, 1.0), Mode(600.0, 0.01, 1.0)))
    case = LoopCase(plant, lead(600.0), None, lead(600.0))
    m = stability_margins(case.factors, fmin=1, fmax=30e3)
    assert len(m.gain_crossovers_hz) == 3
    assert m.gain_crossovers_hz[2] == pytest.approx(600.2157, abs=1e-3)
    assert abs(case.response(np.array([600.1]))[0]) > 1 > abs(case.response(np.array([600.3]))[0])


def test_two_modes_at_one_frequency_discrete_split_form():
    # found by the slow property test: two 1 kHz modes (zeta 1e-3 and 5.2e-4) give a pole
    # cluster that the Sylvester split keeps in one triangular block; the crossings are
    # exact on python-control's dense evaluation (a zpk product loses 2e-6 there)
    from _margin_loops import LoopCase, lead

    from servokit.models import ModalPlant

    modes = (Mode(0, 0, 1), Mode(4907.5, 0.01, 0.5), Mode(1000, 1e-3, 1), Mode(1000, 5.233e-4, 1))
    plant = ModalPlant(13433.318205545413, modes)
    ctrl = control.sample_system(lead(100.0), 5e-5, method="tustin")
    case = LoopCase(plant, lead(100.0), 5e-5, ctrl)
    m = stability_margins(case.factors, fmin=1, fmax=1e4)
    assert len(m.gain_crossovers_hz) == 3
    assert np.abs(case.dense(np.array(m.gain_crossovers_hz))) == pytest.approx(1.0, rel=1e-9)
    assert m.closed_loop_stable is not case.unstable()[0]


def test_bode_plot_unwrapped_phase_has_no_jumps(tmp_path, monkeypatch):
    """``unwrap=True`` draws the principal phase plus multiples of 360° with no step above
    180° between grid points, where the principal value jumps at the resonances."""
    import servokit.feedback.plots as plots

    drawn = {}

    def keep(fig, path, **kw):
        drawn["lines"] = [ln.get_ydata() for ln in fig.axes[1].get_lines()]
        return path

    monkeypatch.setattr(plots, "save_figure", keep)
    pd = hdd_benchmark_variants()[0].discretize(benchmark_controller().dt)
    loop = [pd, benchmark_controller()]
    f = frequency_grid(loop, 10.0, 0.5 / benchmark_controller().dt, 3000)
    phases = {}
    for unwrap in (False, True):
        plots.bode_responses_plot({"L": loop}, f, path=tmp_path / "b.png", title="t",
                                  unwrap=unwrap)  # fmt: skip
        (phases[unwrap],) = drawn["lines"]
    assert np.abs(np.diff(phases[False])).max() > 300.0  # the principal value jumps
    assert np.abs(np.diff(phases[True])).max() < 180.0
    turns = (phases[True] - phases[False]) / 360.0  # the same angle, whole turns apart
    assert np.allclose(turns, np.round(turns), atol=1e-9)
