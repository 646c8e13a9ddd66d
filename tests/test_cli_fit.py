"""``servokit fit`` on the shipped example FRF: the plant file it writes is read by every
command, and its numbers are those of the generating plant (examples/data/make_stage_frf.py),
which the fitter never sees."""

from __future__ import annotations

import json
import runpy
import sys
from pathlib import Path

import pytest

import servokit.cli
from servokit.models import load_plant, read_frf

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"


def _run(monkeypatch, capsys, *args: str) -> str:
    monkeypatch.setattr(sys, "argv", ["servokit", *args])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    return out


def test_example_csv_is_what_its_script_generates(tmp_path):
    script = runpy.run_path(str(DATA / "make_stage_frf.py"))
    script["main"](tmp_path / "again.csv")
    assert (tmp_path / "again.csv").read_bytes() == (DATA / "stage_frf.csv").read_bytes()


def test_fit_example_writes_a_plant_every_command_reads(tmp_path, monkeypatch, capsys):
    truth = runpy.run_path(str(DATA / "make_stage_frf.py"))["STAGE"]
    out = _run(
        monkeypatch,
        capsys,
        "fit",
        str(DATA / "stage_frf.csv"),
        "--out",
        str(tmp_path / "fitted"),
        "--plot",
        str(tmp_path / "fit.png"),
        "--json",
    )
    data = json.loads(out)
    plant = load_plant(tmp_path / "fitted" / "plant.toml")
    assert data["plant_file"] == str(tmp_path / "fitted" / "plant.toml")
    assert data["n_modes"] == 3 and len(plant.modes) == 4
    for m, mq, row in zip(truth.modes, plant.modes, data["modes"], strict=True):
        assert mq.freq_hz == pytest.approx(m.freq_hz, rel=0.005, abs=1e-12)
        assert mq.damping == pytest.approx(m.damping, rel=0.15, abs=1e-12)
        b = row["gain_residue_out_per_in_s2"]
        assert b == pytest.approx(truth.gain * m.residue, rel=0.10)
        assert b == pytest.approx(plant.gain * mq.residue, rel=1e-12)
    assert plant.delay == pytest.approx(truth.delay, abs=1e-6) == data["delay_s"]
    assert data["median_error"] < 0.02 and data["plot"] == str(tmp_path / "fit.png")
    f, H = read_frf(DATA / "stage_frf.csv")
    assert abs(data["noise_rel"] - 0.015) < 0.002  # the generator's noise level
    # another command reads the plant file
    shown = json.loads(
        _run(
            monkeypatch, capsys, "plant", "show", str(tmp_path / "fitted" / "plant.toml"), "--json"
        )
    )
    assert shown["delay_s"] == plant.delay and len(shown["modes"]) == 4
    assert f.size == data["n_points"] == 2000


def test_fit_console_output_and_fixed_modes(tmp_path, monkeypatch, capsys):
    out = _run(
        monkeypatch,
        capsys,
        "fit",
        str(DATA / "stage_frf.csv"),
        "--out",
        str(tmp_path),
        "--modes",
        "3",
        "--band",
        "100:20000",
    )
    assert "fit error over" in out and "2130" in out
    assert load_plant(tmp_path / "plant.toml").modes[1].freq_hz == pytest.approx(2130, rel=5e-3)
