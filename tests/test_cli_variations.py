"""``--variations FILE`` on simulate and sweep: the shipped Table 2.3 file reproduces the
built-in box exactly; a user's box gives its corners."""

from __future__ import annotations

import json
import sys

import pytest

import servokit.cli
from servokit.models import HDD_BENCHMARK_VARIATIONS, ModalPlant, Mode, save_plant


def _run(monkeypatch, capsys, *args: str) -> dict:
    monkeypatch.setattr(sys, "argv", ["servokit", *args, "--json"])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    return json.loads(out)


def test_sweep_with_the_shipped_file_equals_the_builtin_box(monkeypatch, capsys):
    common = ["sweep", "--method", "fsc", "--n-samples", "12", "--n-variants", "300"]
    builtin = _run(monkeypatch, capsys, *common, "--gain-range", "--seed", "4")
    filed = _run(
        monkeypatch, capsys, *common, "--variations", str(HDD_BENCHMARK_VARIATIONS), "--seed", "4"
    )
    for key in ("percentiles_s", "worst_index", "worst_plant", "n_unsettled", "mean_s"):
        assert filed[key] == builtin[key]
    assert filed["variations"] == "hdd-benchmark Table 2.3"


def test_simulate_runs_every_corner_of_a_user_box(tmp_path, monkeypatch, capsys):
    stage = ModalPlant(4e6, (Mode(0, 0, 1.0), Mode(2130, 0.025, -0.42)), 15e-6, name="stage")
    save_plant(stage, tmp_path / "stage.toml")
    (tmp_path / "box.toml").write_text(
        'kind = "variations"\nname = "box"\ngain_rel = 0.1\n[[modes]]\nfreq_hz = 2130\n'
        "freq_rel = 0.05\nresidue_rel = 0.1\n"
    )
    data = _run(
        monkeypatch,
        capsys,
        "simulate",
        "--plant",
        str(tmp_path / "stage.toml"),
        "--dt",
        "5e-5",
        "--duration",
        "0.002",
        "--step",
        "1e-3",
        "--variations",
        str(tmp_path / "box.toml"),
    )
    assert len(data["plants"]) == 27  # frequency, residue and gain at nominal/low/high
    assert data["plants"][0] == "box corner 0"
    # open loop: the output of a rigid body under a held step scales with the gain
    finals = sorted(data["final"])
    assert finals[-1] / finals[0] == pytest.approx(1.1 / 0.9, rel=0.05)
