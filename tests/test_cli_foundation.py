"""The `servokit` command: plant show/bode, simulate, error handling (one line, exit 2)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

EXE = [sys.executable, "-c", "from servokit.cli import main; main()"]


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*EXE, *args], capture_output=True, text=True, timeout=120)


def test_plant_show_json():
    r = run("plant", "show", "hdd-benchmark", "--json")
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["gain"] == pytest.approx(1 / (1e-3 * 2.54e-7)) and len(data["modes"]) == 7
    assert data["modes"][2] == {"freq_hz": 4100.0, "damping": 0.03, "residue": -1.0}


def test_plant_bode_plot(tmp_path: Path):
    out = tmp_path / "bode.png"
    r = run("plant", "bode", "hdd-sampled-data", "--plot", str(out), "--json", "--n-freq", "50")
    assert r.returncode == 0, r.stderr
    assert out.stat().st_size > 10_000
    data = json.loads(r.stdout)
    assert len(data["freq_hz"]) == 50


def test_simulate_closed_loop_step_json():
    r = run(
        "simulate",
        "--plant",
        "hdd-sampled-data",
        "--dt",
        "153.5e-6",
        "--duration",
        "0.02",
        "--step",
        "1",
        "--controller",
        "eq-4.69",
        "--json",
    )
    assert r.returncode == 0, r.stderr
    data = json.loads(r.stdout)
    assert data["final_out"][0] == pytest.approx(1.0, abs=1e-3)  # integral action


def test_simulate_input_file(tmp_path: Path):
    f = tmp_path / "u.txt"
    f.write_text("1e-3\n-1e-3\n")
    r = run(
        "simulate",
        "--variants",
        "--dt",
        "37.879e-6",
        "--duration",
        "1e-3",
        "--input",
        str(f),
        "--json",
    )
    assert r.returncode == 0, r.stderr
    assert len(json.loads(r.stdout)["plants"]) == 18


@pytest.mark.parametrize(
    "args",
    [
        ("plant", "show", "no-such-plant"),
        ("simulate", "--dt", "0", "--duration", "1", "--step", "1"),
        (
            "simulate",
            "--dt",
            "1e-4",
            "--duration",
            "1e-3",
            "--step",
            "1",
            "--controller",
            "eq-4.69",
        ),
        ("plant", "show", "missing.toml"),
    ],
)
def test_bad_input_one_line_exit_2(args):
    r = run(*args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("servokit: error:")
    assert "Traceback" not in r.stderr


def test_malformed_plant_file(tmp_path: Path):
    f = tmp_path / "p.toml"
    f.write_text("gain = 1.0\n[[modes]]\nfreq_hz = 10.0\ndamping = -0.2\nresidue = 1.0\n")
    r = run("plant", "show", str(f))
    assert r.returncode == 2 and "modes[0].damping" in r.stderr
