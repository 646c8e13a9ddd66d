"""Track-following PES simulation, baseline controller and peak filter on the benchmark."""

from __future__ import annotations

import control
import numpy as np
import pytest

from servokit.cases.hdd_pes import CASE_FILTER, PeakFilterSpec, peak_filtered_controller
from servokit.errors import ServokitError
from servokit.models import (
    HDD_BENCHMARK_TS,
    BenchmarkDisturbances,
    benchmark_controller,
    hdd_benchmark,
    hdd_benchmark_variants,
)
from servokit.simulate.pes import lifted_plant, pes_closed_loop, track_following_pes

TS = HDD_BENCHMARK_TS


def test_lifted_plant_control_channel_is_the_ts_discretisation():
    plant = hdd_benchmark()
    a, bu, _, c = lifted_plant(plant, TS, 2)
    lifted = control.ss(a, bu, c, 0, TS)
    direct = plant.discretize(TS)
    z = np.exp(2j * np.pi * np.array([100.0, 2000.0, 9000.0]) * TS)
    np.testing.assert_allclose(np.ravel(lifted(z)), np.ravel(direct(z)), rtol=1e-7)


def test_baseline_controller_crossover_and_robustness():
    c = benchmark_controller()
    pd = hdd_benchmark().discretize(TS)
    z = np.exp(2j * np.pi * 1000.0 * TS)
    assert abs(complex(c(z)) * complex(pd(z))) == pytest.approx(1.0, rel=1e-9)
    for p in hdd_benchmark_variants():
        cl = control.feedback(control.ss(c) * p.discretize(TS), 1)
        assert np.all(np.abs(cl.poles()) < 1.0)


def test_sensor_noise_variance_matches_the_h2_norm():
    """PES = -S n for sensor noise alone: var = sigma^2 ||S||_2^2 (Lyapunov, independent)."""
    bd = BenchmarkDisturbances(
        force_sigma_a=0.0, flutter_peak_track=(0.0,) * 9, rro_amplitude_track=(0.0, 0.0, 0.0)
    )
    rec = bd.generate(300, seed=7)
    res = track_following_pes(hdd_benchmark(), benchmark_controller(), rec)
    cl = pes_closed_loop(hdd_benchmark(), benchmark_controller(), TS)
    s = cl[0, 2]  # sensor/output-disturbance input -> PES
    P = control.dlyap(np.asarray(s.A).T, np.asarray(s.C).T @ np.asarray(s.C))
    h2 = float((np.asarray(s.B).T @ P @ np.asarray(s.B))[0, 0] + np.asarray(s.D)[0, 0] ** 2)
    assert np.var(res.pes) == pytest.approx(0.015**2 * h2, rel=0.05)


def test_rro_only_is_all_repeatable():
    bd = BenchmarkDisturbances(
        sensor_sigma_track=0.0, force_sigma_a=0.0, flutter_peak_track=(0.0,) * 9
    )
    res = track_following_pes(
        hdd_benchmark(), benchmark_controller(), bd.generate(40, seed=1), discard_revolutions=20
    )
    assert res.nrpe_3sigma_percent < 1e-6 and np.ptp(res.rpe) > 1e-3


def test_peak_filter_depth_is_exact_at_its_centre():
    c0 = benchmark_controller()
    pd = hdd_benchmark().discretize(TS)
    spec = PeakFilterSpec(960.0, 0.08, 12.0)
    c1 = peak_filtered_controller(c0, pd, spec)
    z = np.exp(2j * np.pi * 960.0 * TS)
    s0 = 1 / (1 + complex(c0(z)) * complex(pd(z)))
    s1 = 1 / (1 + complex(c1(z)) * complex(pd(z)))
    assert abs(s1 / s0) == pytest.approx(10 ** (-12 / 20), rel=1e-6)


@pytest.mark.slow
def test_case_filter_lowers_nrpe_and_keeps_stability():
    from servokit.cases.hdd_pes import loop_report

    rec = BenchmarkDisturbances().generate(60, seed=0)
    c0 = benchmark_controller()
    base = loop_report(c0, rec)
    filt = loop_report(
        peak_filtered_controller(c0, hdd_benchmark().discretize(TS), CASE_FILTER), rec
    )
    assert filt.nrpe_3sigma_percent < base.nrpe_3sigma_percent
    assert filt.all_stable and filt.worst_gain_margin_db > 0 and filt.worst_phase_margin_deg > 0


def test_bad_inputs():
    rec = BenchmarkDisturbances().generate(2, seed=0)
    with pytest.raises(ServokitError, match="whole revolutions"):
        track_following_pes(hdd_benchmark(), benchmark_controller(), rec, discard_revolutions=5)
    with pytest.raises(ServokitError, match="unstable"):
        track_following_pes(
            hdd_benchmark(), benchmark_controller() * 50, rec, discard_revolutions=0
        )


def test_cli_pes_json_plot_and_errors(tmp_path):
    import json

    from typer.testing import CliRunner

    from servokit.cli import _discover
    from servokit.cli._app import app

    _discover()
    runner = CliRunner()
    png = tmp_path / "p.png"
    out = runner.invoke(app, ["pes", "--n-revolutions", "20", "--json", "--plot", str(png)])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    ref = track_following_pes(
        hdd_benchmark(), benchmark_controller(), BenchmarkDisturbances().generate(20, seed=0)
    )
    assert data["nrpe_3sigma_percent"] == pytest.approx(ref.nrpe_3sigma_percent, rel=1e-9)
    assert len(data["freq_hz"]) == len(data["pes_psd_db"]) and png.stat().st_size > 5000
    for args, flag in (
        (["--peak-filter", "960:0.08"], "--peak-filter"),
        (["--controller", "nope.toml"], "nope"),
        (["--n-revolutions", "100000000"], "--max-memory-mb"),
    ):
        bad = runner.invoke(app, ["pes", *args])
        assert isinstance(bad.exception, ServokitError), bad.output
        assert flag in str(bad.exception)


@pytest.mark.slow
def test_frequency_domain_variance_matches_simulated_nrpe():
    """(6.13) on the lumped disturbance model vs the time-domain NRPE (independent paths)."""
    from servokit.cases.hdd_pes import disturbance_magnitude
    from servokit.limits import output_variance

    bd = BenchmarkDisturbances(rro_amplitude_track=(0.0, 0.0, 0.0))
    pd = hdd_benchmark().discretize(TS)
    loop = control.ss(benchmark_controller()) * pd
    var = output_variance(loop, disturbance_magnitude(bd, pd), breakpoints_hz=bd.flutter_freq_hz)
    sim = track_following_pes(hdd_benchmark(), benchmark_controller(), bd.generate(400, seed=3))
    assert np.var(sim.pes) == pytest.approx(var, rel=0.05)
