"""``servokit filter ...`` and ``servokit margins``: happy paths and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.feedback import complex_lag, stability_margins
from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data

_discover()
runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, list(args))


def test_filter_lag_json_matches_library():
    out = run("filter", "lag", "--freq", "6900", "--damping", "0.1", "--phase", "1.1519", "--json")
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    ref = complex_lag(6900, 0.1, 1.1519)
    np.testing.assert_allclose(data["num"], ref.num[0][0], rtol=1e-12)
    np.testing.assert_allclose(data["den"], ref.den[0][0], rtol=1e-12)
    wp = np.sqrt(ref.den[0][0][-1]) / (2 * np.pi)
    assert data["poles_hz"] == pytest.approx([wp, wp])
    assert data["pole_dampings"] == pytest.approx([0.1, 0.1])


def test_filter_peak_discrete_and_plot(tmp_path):
    png = tmp_path / "peak.png"
    out = run(
        "filter",
        "peak",
        "--freq",
        "4449",
        "--damping",
        "0.015",
        "--gain",
        "0.1778",
        "--phi",
        "2.5414",
        "--dt",
        str(1 / 30000),
        "--plot",
        str(png),
    )
    assert out.exit_code == 0, out.output
    assert "num_z" in out.stdout and png.stat().st_size > 10_000


@pytest.mark.parametrize("kind", ["notch", "inverse"])
def test_filter_notch_inverse_run(kind):
    args = (
        ["--freq", "4449", "--damping", "0.09"]
        if kind == "notch"
        else ["--zero-freq", "4449", "--pole-freq", "4775"]
    )
    out = run("filter", kind, *args, "--json")
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["den"][0] == 1.0


def test_margins_json_matches_library():
    out = run("margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69", "--json")
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    ref = stability_margins(
        [hdd_sampled_data().discretize(HDD_SAMPLED_DATA_TS), controller_eq_4_69()]
    )
    assert data["phase_margin_deg"] == pytest.approx(ref.phase_margin_deg, rel=1e-9)
    assert data["gain_crossovers_hz"] == pytest.approx(list(ref.gain_crossovers_hz))
    assert data["dt_s"] == pytest.approx(HDD_SAMPLED_DATA_TS)


def test_margins_with_a_filter_changes_the_loop():
    base = json.loads(
        run("margins", "--plant", "vcm-dual-stage", "--controller", "table-5.2", "--json").stdout
    )
    out = run(
        *"margins --plant vcm-dual-stage --controller table-5.2 --json".split(),
        "--filter",
        "notch:2179:0.05:2179:0.7",
    )
    assert out.exit_code == 0, out.output
    assert json.loads(out.stdout)["gain_margin_db"] != pytest.approx(base["gain_margin_db"])


@pytest.mark.parametrize(
    "command, flag",
    [
        ("filter lag --freq 6900 --damping 0.1 --phase 2", "--phase"),
        ("filter notch --freq -5 --damping 0.1", "--freq"),
        ("filter peak --freq 1000 --damping 0.01 --gain 1 --phi 0 --dt 1e-3", "--freq"),
        ("filter notch --freq 100 --damping 0.1 --plot x.pdf", "--plot"),
        ("margins --plant vcm-dual-stage --controller table-5.2 --filter peak:1:2", "--filter"),
        ("margins --plant vcm-dual-stage --controller table-5.2 --filter wobble:1", "--filter"),
        ("margins --plant nope --controller table-5.2", "plant"),
    ],
)
def test_bad_input_is_one_line_exit_2(command, flag, monkeypatch, capsys):
    import sys

    from servokit.cli import main

    monkeypatch.setattr(sys, "argv", ["servokit", *command.split()])
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("servokit: error:") and flag in lines[0]
