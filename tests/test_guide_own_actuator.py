"""docs/guide/own_actuator.md: every ``$ servokit`` command runs (in a scratch copy of the
example data), and the numbers it quotes hold against independent computations."""

from __future__ import annotations

import json
import re
import runpy
import shlex
import shutil
import sys
from pathlib import Path

import pytest

import servokit.cli
from servokit.models import load_plant, read_variations

ROOT = Path(__file__).resolve().parents[1]
GUIDE = ROOT / "docs" / "guide" / "own_actuator.md"


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", GUIDE.read_text(encoding="utf-8"), re.S)


def _run(line: str, monkeypatch, capsys) -> None:
    cmd, _, target = line.partition(" > ")
    args = shlex.split(cmd)
    assert args[0] == "servokit"
    monkeypatch.setattr(sys, "argv", args)
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    out, err = capsys.readouterr()
    assert exc.value.code == 0, (line, err)
    if target:
        Path(target.strip()).write_text(out)


@pytest.mark.slow
def test_guide_commands_run_and_numbers_hold(tmp_path, monkeypatch, capsys):
    shutil.copytree(ROOT / "examples" / "data", tmp_path / "examples" / "data")
    monkeypatch.chdir(tmp_path)
    commands = [
        ln[2:] for block in _blocks("console") for ln in block.splitlines() if ln.startswith("$ ")
    ]
    assert [c.split()[1] for c in commands] == [
        "fit",
        "seek",
        "sweep",
        "seek",
        "margins",
        "report",
        "export",
        "export",
    ]
    _run(commands[0], monkeypatch, capsys)
    (tmp_path / "fitted" / "box.toml").write_text(_blocks("toml")[0])
    for line in commands[1:]:
        _run(line, monkeypatch, capsys)
    # the fit against the generator the fitter never saw
    truth = runpy.run_path(str(ROOT / "examples" / "data" / "make_stage_frf.py"))["STAGE"]
    plant = load_plant("fitted/plant.toml")
    for m, mq in zip(truth.modes, plant.modes, strict=True):
        assert mq.freq_hz == pytest.approx(m.freq_hz, rel=0.005, abs=1e-12)
        assert plant.gain * mq.residue == pytest.approx(truth.gain * m.residue, rel=0.10)
    assert plant.delay == pytest.approx(15e-6, abs=1e-6)
    # the seek over the box: 27 corners, the input limit held, no faster than bang-bang
    vset = read_variations("fitted/box.toml")
    design = json.loads(Path("design.json").read_text())
    assert design["n_plants"] == vset.n_corners == 27
    assert design["peak_input"] <= 40 * (1 + 1e-9)
    bang_bang = 2 * (100 / (plant.gain * 40)) ** 0.5
    assert design["seek_time_s"] >= bang_bang
    assert Path("fit.png").stat().st_size > 0 and Path("sweep.png").stat().st_size > 0
    _check_robust_seek(plant)
    html = Path("design/report.html").read_text(encoding="utf-8")
    assert "Example stage design" in html and "book" not in html.lower()
    assert "sample 20" in html  # each Monte-Carlo plant named in the margins table
    # the exported seek input is the validated one; the controller step clamps at 40 V
    header = Path("firmware/stage_ff.h").read_text()
    n = len(json.loads(Path("seek.json").read_text())["input"])
    assert f"#define STAGE_FF_U_LEN {n}" in header
    assert "#define STAGE_CTRL_SS_U_MAX 4.0e+01f" in Path("firmware/stage_ctrl.h").read_text()


def _check_robust_seek(plant) -> None:
    """The validated worst case holds on a fresh Monte-Carlo sample of the box (another
    seed than the command's), simulated by the plain simulator, within one read-out step."""
    from types import SimpleNamespace

    import numpy as np

    from servokit.models import read_variations
    from servokit.simulate import seek_time

    res = json.loads(Path("seek.json").read_text())
    assert res["peak_input"] <= 40 * (1 + 1e-9)
    assert res["n_validation"] == 2000
    vset = read_variations(ROOT / "examples" / "data" / "stage.variations.toml", plant)
    fresh = vset.monte_carlo(300, seed=12345)
    ff = SimpleNamespace(u=np.asarray(res["input"], dtype=float), dt=res["dt_s"])
    worst = float(np.max(seek_time(fresh, ff, 1000.0, band=0.1)))
    assert worst <= res["seek_time_s"] + res["dt_s"] / 10 * (1 + 1e-9)
    assert res["seek_time_s"] >= res["guaranteed_seek_time_s"] - 1e-12
