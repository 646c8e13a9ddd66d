"""``servokit feedforward`` commands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.feedforward.polynomial import sampled_polynomial

_discover()
runner = CliRunner()


def test_polynomial_json_matches_library(tmp_path: Path) -> None:
    png = tmp_path / "u.png"
    res = runner.invoke(
        app,
        [
            "feedforward",
            "polynomial",
            "--order",
            "5",
            "--N",
            "20",
            "--dt",
            "1e-3",
            "--target",
            "2",
            "--json",
            "--plot",
            str(png),
        ],
    )
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    np.testing.assert_allclose(data["u"], sampled_polynomial(5, 20, 1e-3, 2.0), rtol=1e-14)
    assert "420" in data["formula"]
    assert png.stat().st_size > 5000


def test_minimum_jerk_json_fig_2_10() -> None:
    res = runner.invoke(app, ["feedforward", "minimum-jerk", "--tau", "0.1", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    # T = 10 tau: r (1 - 1/100)(1 - 4/100) - r
    assert abs(data["final_error"] - (0.99 * 0.96 - 1)) < 1e-12
    assert data["n_samples"] == 10


def test_bad_order_is_one_line_exit_2() -> None:
    import subprocess
    import sys

    exe = Path(sys.executable).with_name("servokit")
    out = subprocess.run(
        [str(exe), "feedforward", "polynomial", "--order", "9", "--N", "10", "--dt", "0.1"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "order" in out.stderr
