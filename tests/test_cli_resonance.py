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


@pytest.mark.parametrize(
    ("args", "identity"),
    [
        (["lag", "--freq", "6900", "--damping", "0.1", "--phase", "0"], True),
        (["inverse", "--zero-freq", "4449", "--pole-freq", "4449"], True),
        (["inverse", "--zero-freq", "4449", "--pole-freq", "4775"], False),
    ],
)
def test_an_identity_filter_is_explained(args, identity):
    """num = den is the right answer to these flags; the output says so (issue 23)."""
    data = json.loads(run("filter", *args, "--json").stdout)
    same = np.allclose(data["num"], data["den"], rtol=1e-12, atol=0.0)
    assert same == identity
    assert ("identity" in data.get("note", "")) == identity


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


def test_margins_json_has_the_stability_verdict_and_modulus_margin():
    out = run("margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69", "--json")
    data = json.loads(out.stdout)
    assert data["closed_loop_stable"] is True
    assert 0 < data["modulus_margin"] < 1
    assert len(data["delay_margins_s"]) == len(data["gain_crossovers_hz"])


def test_margins_of_an_unstable_loop_print_one_warning_line():
    # 12 samples of extra delay: far beyond the ~0.1 ms delay margin of the section 4.5 loop
    out = run(
        "margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69", "--loop-delay", "2e-3"
    )
    assert out.exit_code == 0, out.output
    warnings = [ln for ln in out.output.splitlines() if "warning" in ln]
    assert len(warnings) == 1 and "UNSTABLE" in warnings[0]
    # no crossover offers a delay margin to an unstable loop: the headline 0 and the rows
    # say the same thing
    text = " ".join(out.stdout.split())
    assert "delay margin 0 us (the closed loop is already unstable)" in text
    rows = [ln for ln in out.stdout.splitlines() if "gain crossover" in ln]
    assert rows and all(ln.rstrip().endswith("delay margin      n/a") for ln in rows)
    js = run(
        *"margins --plant hdd-sampled-data --controller eq-4.69 --loop-delay 2e-3 --json".split()
    )
    assert json.loads(js.stdout)["closed_loop_stable"] is False


def test_margins_over_a_variation_file_name_the_worst_plant(tmp_path):
    box = tmp_path / "box.toml"
    box.write_text(
        'kind = "variations"\ngain_rel = 0.2\n[[modes]]\nfreq_hz = 4449.0\nfreq_rel = 0.05\n'
    )
    out = run(
        *"margins --plant vcm-dual-stage --controller table-5.2 --json --variations".split(),
        str(box),
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert len(data["plants"]) == 9  # 3 gain levels x 3 frequency levels
    worst = data["plants"][data["worst_index"]]
    assert worst["modulus_margin"] == min(p["modulus_margin"] for p in data["plants"])
    assert data["all_stable"] is True
