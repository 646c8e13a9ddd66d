"""FRF-set loop shaping (issue 25): Nyquist count, table, structures, the iteration, the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitValueError
from servokit.feedback import fixed_order_structure, loopshape, pid_notch_structure
from servokit.feedback.loopshape_eval import closed_loop_unstable, evaluate_loop
from servokit.feedback.loopshape_init import initial_parameters, plant_integrators
from servokit.feedback.loopshape_iterate import _Problem, certify_models
from servokit.feedback.loopshape_problem import model_frfs, packed_grid
from servokit.models import HDD_BENCHMARK_TS, ModalPlant, Mode, benchmark_controller

DT = 1e-4


def _grid(n: int = 4000, dt: float = DT) -> np.ndarray:
    return np.geomspace(0.01, 0.5 / dt, n)


def _resp(tf: control.TransferFunction, f: np.ndarray) -> np.ndarray:
    return np.asarray(tf(np.exp(2j * np.pi * f * float(tf.dt)))).ravel()


@pytest.mark.parametrize(("k", "expect"), [(0.5, 0), (1.9, 0), (2.5, 1), (4.0, 1)])
def test_integrator_loop_count_and_crossover(k: float, expect: int) -> None:
    # L = k/(z - 1): closed-loop pole 1 - k, crossover 2 asin(k/2) (closed forms)
    f = _grid()
    L = _resp(control.tf([k], [1, -1], DT), f)
    z_out, resolved = closed_loop_unstable(f, L, DT, n_integrators=1)
    assert resolved and z_out == expect
    if k < 2:
        row = evaluate_loop(f, L, DT, n_integrators=1)
        fc = 2 * np.arcsin(k / 2) / (2 * np.pi * DT)
        assert row.crossover_hz == pytest.approx(fc, rel=2e-4)
        assert row.s_peak_db == pytest.approx(-20 * np.log10(1 - k / 2), abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(
    gain=st.floats(1e-3, 30.0),
    zero=st.floats(0.05, 0.95),
    pole=st.floats(-0.9, 0.9),
)
def test_nyquist_count_matches_closed_loop_poles(gain: float, zero: float, pole: float) -> None:
    # discrete double integrator with one-sample delay, PI-lead controller: the count of
    # closed-loop poles outside the unit disc from the Nyquist plot equals the roots' count
    plant = control.tf([0.5, 0.5], [1, -2, 1, 0], DT)
    ctrl = control.tf(
        gain * np.convolve([1, -zero], [1, -0.5]), np.convolve([1, -1], [1, -pole]), DT
    )
    loop = plant * ctrl
    char = np.polyadd(loop.den[0][0], loop.num[0][0])
    roots = np.roots(char)
    margin = np.min(np.abs(np.abs(roots) - 1.0))
    if margin < 1e-3:  # a pole on the circle: the count is not defined
        return
    f = _grid(20000)
    z_out, resolved = closed_loop_unstable(f, _resp(loop, f), DT, n_integrators=3)
    if resolved:
        assert z_out == int(np.sum(np.abs(roots) > 1.0))


def test_structures_and_transfer_function() -> None:
    st_ = pid_notch_structure(DT, notches=((1000.0, 0.2),), lowpass_hz=(2000.0,))
    assert st_.order == 4 and st_.n_den_free == 0 and st_.den_fixed[0] == 1.0
    assert np.polyval(st_.den_fixed[::-1], 1.0) == pytest.approx(0.0, abs=1e-12)  # integrator
    fo = fixed_order_structure(5)
    theta = np.arange(1.0, fo.n_params + 1) / 10
    tf = fo.transfer_function(theta, DT)
    f = _grid(50)
    pb = _Problem(f, np.ones((1, f.size)), DT, fo, 6.0, None, 0, None)
    np.testing.assert_allclose(_resp(tf, f), pb.K(theta), rtol=1e-9)


def test_benchmark_controller_is_exact_in_its_own_structure() -> None:
    c0 = benchmark_controller()
    st_ = fixed_order_structure(12)
    f = np.geomspace(10, 0.5 / HDD_BENCHMARK_TS, 300)
    pb = _Problem(f, np.ones((1, f.size)), HDD_BENCHMARK_TS, st_, 6.0, None, 2, None)
    theta, note = initial_parameters(pb, c0)
    assert note == ""
    np.testing.assert_allclose(pb.K(theta), _resp(c0, f), rtol=1e-8)


def _small_set():
    base = ModalPlant(gain=1e8, modes=(Mode(0.0, 0.0, 1.0), Mode(3000.0, 0.02, -0.5)), delay=2e-5)
    plants = [
        base.replace(modes=(Mode(0.0, 0.0, 1.0), Mode(3000.0 * s, 0.02, -0.5)))
        for s in (0.95, 1.0, 1.05)
    ]
    f = packed_grid(DT, [(3000.0 * s, 0.02) for s in (0.95, 1.0, 1.05)], n_freq=400, fmin=1.0)
    return plants, f, model_frfs(plants, DT, f)


def test_loopshape_small_set_is_certified_and_improves() -> None:
    plants, f, P = _small_set()
    assert plant_integrators(f, P, DT) == 2
    res = loopshape(f, P, DT, s_max_db=6.0, structure="order", order=4, max_iter=5, time_limit_s=60)
    t = res.table
    assert t.all_stable and t.worst_s_peak_db <= 6.0 + 1e-6
    assert t.min_crossover_hz >= res.history[1]["min_crossover_hz"] - 1e-9
    # the low-frequency floor |L| >= 0.9 |L_0| below 0.7 x the initial crossover holds
    low = f <= 0.7 * res.initial_table.min_crossover_hz
    L0 = P[:, low] * _resp(res.initial_controller, f[low])[None, :]
    L1 = P[:, low] * _resp(res.controller, f[low])[None, :]
    assert np.all(np.abs(L1) >= 0.9 * np.abs(L0) * (1 - 1e-6))
    # exact certificate on the models: every closed-loop pole inside the unit disc
    assert certify_models(res.controller, plants).max() < 1.0
    # the table's ||S||inf is the FRF maximum, recomputed independently
    S = 1.0 / (1.0 + P * _resp(res.controller, f)[None, :])
    assert t.worst_s_peak_db == pytest.approx(20 * np.log10(np.abs(S).max()), abs=1e-9)


def test_loopshape_rejects_bad_input() -> None:
    _, f, P = _small_set()
    with pytest.raises(ValueError, match="s_max_db"):
        loopshape(f, P, DT, s_max_db=-1.0)
    with pytest.raises(ValueError, match="order"):
        loopshape(f, P, DT, s_max_db=6.0, structure="order")
    with pytest.raises(ValueError, match="Nyquist"):
        loopshape(f * 10, P, DT, s_max_db=6.0)
    with pytest.raises(ValueError, match="stabilise"):
        loopshape(
            f,
            P,
            DT,
            s_max_db=6.0,
            structure="order",
            order=2,
            initial=control.tf([-1.0, 0.0], [1.0, -1.0], DT),
        )


def test_a_t_bound_the_start_misses_is_named_as_such() -> None:
    """A stable initial controller above the ‖T‖∞ bound is refused for that bound, not as
    unstable; a bound at or below 0 dB (|T| -> 1 where |L| is large) is refused at once."""
    _, f, P = _small_set()
    start = loopshape(f, P, DT, s_max_db=6.0, structure="order", order=4, max_iter=0)
    t_peak = max(r.t_peak_db for r in start.table.rows)
    assert start.table.all_stable and t_peak > 0.5
    with pytest.raises(ValueError, match=r"‖T‖∞ .* dB is above t_max_db"):
        loopshape(f, P, DT, s_max_db=6.0, structure="order", order=4, max_iter=0,
                  initial=start.controller, t_max_db=t_peak - 0.25)  # fmt: skip
    with pytest.raises(ValueError, match="t_max_db must be > 0 dB"):
        loopshape(f, P, DT, s_max_db=6.0, t_max_db=0.0)


def test_cli_loopshape_writes_a_readable_controller(tmp_path, monkeypatch, capsys) -> None:
    import sys

    import servokit.cli
    from servokit.models import load_controller, save_frf

    _, f, P = _small_set()
    files = []
    for i, p in enumerate(P):
        files.append(str(save_frf(tmp_path / f"p{i}.csv", f, p)))
    monkeypatch.setattr(
        sys,
        "argv",
        [
            "servokit",
            "loopshape",
            *files,
            "--dt",
            str(DT),
            "--order",
            "4",
            "--s-max-db",
            "6",
            "--out",
            str(tmp_path / "o"),
            "--json",
            "--time-limit",
            "2",
        ],
    )
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 0
    data = json.loads(capsys.readouterr().out)
    assert data["summary"]["all_stable"] and data["order"] == 4
    ctrl = load_controller(tmp_path / "o" / "controller.toml")
    assert ctrl.dt == pytest.approx(DT)
    assert len(data["plants"]) == 3


def test_cli_loopshape_checks_the_models_it_is_given(tmp_path, monkeypatch, capsys) -> None:
    """--plant: the largest closed-loop pole of each model with the designed controller, as
    python-control computes it from the written controller file and the exact ZOH model."""
    import runpy
    import shutil
    import sys

    import servokit.cli
    from servokit.models import load_controller, save_plant

    root = Path(__file__).resolve().parents[1]
    stage = runpy.run_path(str(root / "examples" / "data" / "make_stage_frf.py"))["STAGE"]
    shutil.copy(root / "examples" / "data" / "stage_frf.csv", tmp_path / "stage.csv")
    save_plant(stage, tmp_path / "stage.toml")
    monkeypatch.chdir(tmp_path)
    args = ["servokit", "loopshape", "stage.csv", "--dt", "2.5e-5", "--order", "4", "--out",
            "ctrl", "--time-limit", "3", "--plant", "stage.toml", "--json"]  # fmt: skip
    monkeypatch.setattr(sys, "argv", args)
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    radii = json.loads(out)["model_spectral_radii"]
    K = load_controller(tmp_path / "ctrl" / "controller.toml")
    loop = control.feedback(stage.discretize(float(K.dt)) * control.tf2ss(K), 1)
    assert radii[0] == pytest.approx(np.max(np.abs(loop.poles())), rel=1e-9)
    assert radii[0] < 1.0


def test_model_frfs_blocks_match_dense_solve_and_certify_matches_python_control():
    # closed-form modal blocks vs the dense expm + solve reference; batched closed-loop
    # spectral radii vs python-control's feedback of the discretised model
    from servokit.feedback.loopshape_problem import model_resonances
    from servokit.models import hdd_benchmark_variants

    plants = hdd_benchmark_variants()[:6]
    extra = (Mode(0.0, 0.0, 1.0), Mode(3000.0, 0.02, -0.5))
    plants += [ModalPlant(gain=2e5, modes=extra, delay=0.0)]  # no delay: other bank
    dt = HDD_BENCHMARK_TS
    f = packed_grid(dt, model_resonances(plants, dt), n_freq=800)
    ref = model_frfs(plants, dt, f)
    fast = model_frfs(plants, dt, f, method="blocks")
    assert np.max(np.abs(fast - ref) / np.abs(ref)) < 1e-10
    with pytest.raises(ServokitValueError, match="method"):
        model_frfs(plants, dt, f, method="eig")
    c = benchmark_controller()
    k = control.tf2ss(c)
    gains = (0.9, 1.1)
    got = certify_models(c, plants, gains)
    for j, p in enumerate(plants):
        for i, g in enumerate(gains):
            cl = control.feedback(g * p.discretize(dt) * k, 1)
            expect = np.max(np.abs(np.linalg.eigvals(np.asarray(cl.A))))
            assert got[i, j] == pytest.approx(expect, rel=1e-12)


def test_notch_damping_above_one_is_refused_as_no_notch() -> None:
    """(s^2 + 2 z w s + w^2) has real roots for z > 1: a damping typed in percent (20) is
    refused, while z = 1 (critically damped, the widest pair) is kept."""
    assert pid_notch_structure(DT, notches=((1000.0, 1.0),)).order == 3
    with pytest.raises(ServokitValueError, match=r"20 % is 0\.2"):
        pid_notch_structure(DT, notches=((1000.0, 20.0),))
