"""``--variations FILE`` on simulate and sweep: the shipped Table 2.3 file reproduces the
built-in box exactly; a user's box gives its corners."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

import servokit.cli
from servokit.models import HDD_BENCHMARK_VARIATIONS, ModalPlant, Mode, save_plant

ROOT = Path(__file__).resolve().parents[1]


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
    keys = ("percentiles_s", "worst_index", "worst_plant", "worst_plant_detail", "n_unsettled")
    for key in (*keys, "mean_s"):
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
    finals = sorted(data["final_out"])
    assert finals[-1] / finals[0] == pytest.approx(1.1 / 0.9, rel=0.05)


STAGE = ModalPlant(
    4e6,
    (Mode(0, 0, 1.0), Mode(2130, 0.025, -0.42), Mode(5370, 0.012, 0.18)),
    15e-6,
    name="stage",
)


def test_seek_u_max_is_a_qp_constraint_over_the_box(tmp_path, monkeypatch, capsys):
    save_plant(STAGE, tmp_path / "stage.toml")
    (tmp_path / "box.toml").write_text(
        'kind = "variations"\nname = "box"\n[[modes]]\nfreq_hz = 2130\nfreq_rel = 0.05\n'
        "[[modes]]\nfreq_hz = 5370\nfreq_rel = 0.05\n"
    )
    common = [
        "seek",
        "--plant",
        str(tmp_path / "stage.toml"),
        "--dt",
        "5e-5",
        "--target",
        "10",
        "--method",
        "fsc",
        "--n-samples-max",
        "40",
        "--variations",
        str(tmp_path / "box.toml"),
    ]
    free = _run(monkeypatch, capsys, *common)
    limited = _run(monkeypatch, capsys, *common, "--u-max", "8")
    assert free["n_plants"] == limited["n_plants"] == 9  # two frequencies at 3 levels
    assert free["peak_input"] == pytest.approx(max(abs(u) for u in free["input"]))
    assert limited["peak_input"] <= 8 * (1 + 1e-9) and limited["u_max"] == 8
    assert free["peak_input"] > 8  # the limit binds: the unconstrained input is larger
    # no input beats bang-bang: a move of 10 um at 8 V takes 2 sqrt(x / (K u)) = 1.12 ms
    assert limited["n_samples"] * 5e-5 >= 2 * (10 / (4e6 * 8)) ** 0.5 - 1e-12


def test_simulate_u_max_limits_the_input_and_anti_windup_settles(monkeypatch, capsys):
    common = [
        "simulate",
        "--plant",
        "hdd-sampled-data",
        "--dt",
        "153.5e-6",
        "--duration",
        "0.3",
        "--step",
        "100",
        "--controller",
        "eq-4.69",
        "--u-max",
        "0.3",
    ]
    guarded = _run(monkeypatch, capsys, *common)
    wound = _run(monkeypatch, capsys, *common, "--no-anti-windup")
    assert guarded["peak_input"] == pytest.approx(0.3) and guarded["u_max"] == 0.3
    assert guarded["worst_settling_time_s"] < 0.05
    assert wound["worst_settling_time_s"] is None  # inf in JSON: the wound-up loop diverges


def _boxes(tmp_path):
    """The stage saved as a plant file, a box naming it and the same box naming none."""
    save_plant(STAGE, tmp_path / "stage.toml")
    ranges = "[[modes]]\nfreq_hz = 2130\nfreq_rel = 0.05\n"
    named, plantless = tmp_path / "named.toml", tmp_path / "plantless.toml"
    named.write_text(f'kind = "variations"\nname = "box"\nplant = "stage.toml"\n{ranges}')
    plantless.write_text(f'kind = "variations"\nname = "box"\n{ranges}')
    return str(tmp_path / "stage.toml"), str(named), str(plantless)


def test_a_box_naming_its_plant_is_designed_on_and_named_by_it(tmp_path, monkeypatch, capsys):
    """seek without --plant designs on the file's plant and names it (not the default
    --plant); the same plant typed as --plant gives the same design."""
    stage, named, _ = _boxes(tmp_path)
    common = ["seek", "--dt", "5e-5", "--target", "10", "--method", "fsc", "--n-samples", "30"]
    alone = _run(monkeypatch, capsys, *common, "--variations", named)
    typed = _run(monkeypatch, capsys, *common, "--variations", named, "--plant", stage)
    assert alone["plant"] == "stage" and typed["plant"] == stage
    assert alone["n_plants"] == typed["n_plants"] == 3
    assert alone["seek_times_s"] == typed["seek_times_s"]
    assert alone["input"] == typed["input"]


def test_margins_accept_a_box_naming_the_typed_plant(tmp_path, monkeypatch, capsys):
    """margins needs --plant; a box naming that same plant (written with its modes in
    another order) is no conflict and gives the margins of the plantless box (a different
    plant is refused: tests/test_cli_bad_input.py)."""
    stage, named, plantless = _boxes(tmp_path)
    # the box's own plant file lists the modes in reverse; --plant is another file
    save_plant(STAGE.replace(modes=STAGE.modes[::-1]), tmp_path / "stage.toml")
    save_plant(STAGE, tmp_path / "typed.toml")
    typed = str(tmp_path / "typed.toml")
    common = ["margins", "--controller", "examples/data/stage_controller.toml", "--plant", typed]
    monkeypatch.chdir(ROOT)
    by_file = _run(monkeypatch, capsys, *common, "--variations", named)
    by_flag = _run(monkeypatch, capsys, *common, "--variations", plantless)
    assert by_file["plant"] == by_flag["plant"] == "stage"
    assert len(by_file["plants"]) == 3  # the nominal frequency and its two ends
    assert by_file["worst_index"] == by_flag["worst_index"]
    for key in ("min_gain_margin_db", "min_phase_margin_deg", "min_delay_margin_s"):
        assert by_file[key] == pytest.approx(by_flag[key], rel=1e-9)


def test_sweep_nominal_from_plant_and_distance_from_the_design(tmp_path, monkeypatch, capsys):
    """sweep --plant gives a plantless box its nominal (as a box naming the plant does),
    and --design's target_out is the seek distance unless --target says the same."""
    stage, named, plantless = _boxes(tmp_path)
    design = _run(
        monkeypatch, capsys, "seek", "--plant", stage, "--dt", "5e-5", "--target", "10",
        "--method", "fsc", "--n-samples", "30",
    )  # fmt: skip
    (tmp_path / "design.json").write_text(json.dumps(design))
    common = ["sweep", "--design", str(tmp_path / "design.json"), "--n-variants", "200"]
    common += ["--settle-band", "0.5"]
    a = _run(monkeypatch, capsys, *common, "--variations", named)
    b = _run(monkeypatch, capsys, *common, "--variations", plantless, "--plant", stage)
    c = _run(monkeypatch, capsys, *common, "--variations", named, "--target", "10")
    assert a["target_out"] == b["target_out"] == c["target_out"] == 10
    assert a["percentiles_s"] == b["percentiles_s"] == c["percentiles_s"]
    assert a["n_unsettled"] == 0  # settled about 10, not about the default 1


def test_a_conflict_names_the_plant_as_typed(tmp_path, monkeypatch, capsys):
    """The refusal quotes --plant as the user typed it, and says how to agree."""
    stage, named, _ = _boxes(tmp_path)
    other = STAGE.replace(gain=2 * STAGE.gain, name="stage")  # the same name, another plant
    save_plant(other, tmp_path / "other.toml")
    monkeypatch.setattr(sys, "argv", ["servokit", "seek", "--plant", str(tmp_path / "other.toml"),
                                      "--variations", named, "--dt", "5e-5", "--target", "10"])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and len(err.splitlines()) == 1
    assert f"--plant {tmp_path / 'other.toml'} and the plant named in --variations" in err
    assert "give the same plant to both" in err


def test_sweep_refuses_a_target_off_a_tiny_design_distance(tmp_path, monkeypatch, capsys):
    """A nanometre design distance: a --target of another sign and size is no match."""
    design = {"input": [1.0, -1.0], "dt_s": 1e-4, "target_out": 1e-9}
    (tmp_path / "d.json").write_text(json.dumps(design))
    monkeypatch.setattr(sys, "argv", ["servokit", "sweep", "--design", str(tmp_path / "d.json"),
                                      "--target", "-5e-9", "--n-variants", "5"])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 2 and "--target -5e-09 differs" in capsys.readouterr().err
