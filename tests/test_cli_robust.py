"""`servokit seek --method robust` (issue 13): JSON, plot, bad input."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app, main
from servokit.models import ModalPlant, Mode, save_plant

_discover()
runner = CliRunner()


@pytest.fixture(scope="module")
def plant_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("robust") / "pair.toml"
    plant = ModalPlant(gain=100.0, modes=(Mode(0.0, 0.0, 1.0), Mode(20.0, 0.05, -0.3)), delay=0.0)
    save_plant(plant, path)
    return path


def _where(plant_file: Path) -> tuple[str, ...]:
    """The pair plant at dt = 0.01 s, a move of 1 unit."""
    return ("--plant", str(plant_file), "--dt", "0.01", "--tracks", "1")


def _base(plant_file: Path) -> tuple[str, ...]:
    """... with |u| <= 4 and the band 0.05."""
    return (*_where(plant_file), "--u-max", "4", "--settle-band", "0.05")


def _seek(*args: str):
    return runner.invoke(app, ["seek", "--method", "robust", *args])


def test_json_and_plot(plant_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "robust.png"
    res = _seek(
        *_base(plant_file),
        "--json",
        "--plot",
        str(out),
    )
    assert res.exit_code == 0, (res.output, res.exception)
    data = json.loads(res.stdout)
    assert data["method"] == "robust" and data["n_plants"] == 1
    assert data["seek_time_s"] <= data["guaranteed_seek_time_s"] + 1e-12
    assert data["design_band_out"] == pytest.approx(0.8 * 0.05)  # default margin 0.2
    u = np.array(data["input"])
    assert u.shape == (data["n_samples"],) and np.abs(u).max() <= 4.0 * (1 + 1e-9)
    assert abs(u.sum()) < 1e-8
    assert out.stat().st_size > 10_000


def test_human_output_fixed_n(plant_file: Path) -> None:
    res = _seek(
        *_base(plant_file),
        "--n-samples",
        "12",
        "--objective",
        "energy",
    )
    assert res.exit_code == 0, res.output
    assert "N = 12" in res.stdout and "LP guarantee" in res.stdout


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        ((), "--u-max"),
        (("--u-max", "0"), "--u-max must be > 0"),
        (("--u-max", "4", "--margin", "1.5"), "--margin"),
        (("--u-max", "4", "--objective", "time"), "--objective"),
        (("--u-max", "4", "--settle-band", "1e-6", "--n-samples-max", "10"), "widen --settle-band"),
        (("--u-max", "0.01", "--n-samples-max", "12"), "raise --n-samples-max or --u-max"),
    ],
)
def test_bad_input_one_line_exit_2(
    plant_file: Path, args: tuple[str, ...], flag: str, monkeypatch, capsys
) -> None:
    argv = ["servokit", "seek", "--method", "robust", *_where(plant_file), *args]
    monkeypatch.setattr(sys, "argv", argv)
    with pytest.raises(SystemExit) as exc:
        main()
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.count("\n") == 1 and err.startswith("servokit: error:") and flag in err


@pytest.mark.slow
def test_variations_reports_the_validated_worst(tmp_path):
    """``--variations``: seek_time_s is the validated worst, checked against the plain
    simulator on the validation sample and on a dense grid over the 2-D box."""
    from servokit.feedforward import FeedforwardInput
    from servokit.models import read_variations
    from servokit.simulate import seek_time

    save_plant(
        ModalPlant(gain=4e6, modes=(Mode(0, 0, 1.0), Mode(2000, 0.02, -0.3)), name="small"),
        tmp_path / "small.toml",
    )
    box = tmp_path / "box.toml"
    box.write_text(
        'kind = "variations"\nplant = "small.toml"\nseed = 3\n'
        "[[modes]]\nfreq_hz = 2000\nfreq_rel = 0.08\ndamping_rel = 0.5\n"
    )
    args = ["--variations", str(box), "--dt", "1e-4", "--target", "1", "--settle-band", "0.01"]
    args += ["--u-max", "1", "--n-validation", "300", "--margin", "0", "--json"]
    res = _seek(*args)
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert data["n_validation"] == 300 and data["converged"]
    assert data["plant"] == "small" and data["variations"] == str(box)  # the file's plant
    vset = read_variations(box)
    ff = FeedforwardInput(
        u=np.array(data["input"]), dt=1e-4, target=1.0, jerk=np.zeros(data["n_samples"])
    )
    mc = seek_time(vset.monte_carlo(300, seed=4), ff, 1.0, band=0.01)
    np.testing.assert_allclose(data["seek_times_s"], mc)
    g = np.linspace(-1, 1, 31)
    rel = np.array([(0.08 * a, 0.5 * b) for a in g for b in g])
    grid = seek_time(vset.from_draws(rel, np.zeros(len(rel))), ff, 1.0, band=0.01).max()
    assert data["seek_time_s"] >= mc.max()
    assert abs(data["seek_time_s"] - max(grid, mc.max())) <= 1e-5 + 1e-12
    assert data["seek_time_s"] <= data["guaranteed_seek_time_s"] + 1e-5 + 1e-12
