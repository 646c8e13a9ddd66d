"""``servokit limits`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.errors import ServokitError

_discover()
runner = CliRunner()


def test_waterbed_json_and_plot(tmp_path):
    png = tmp_path / "w.png"
    out = runner.invoke(app, ["limits", "waterbed", "--json", "--plot", str(png)])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["bound_db"] == pytest.approx(40 * (2 / 25) / (1 - 2 / 25), rel=1e-12)
    assert data["phi1_rad"] == pytest.approx(2 * np.pi / 25)
    assert png.stat().st_size > 5000


def test_bode_integral_text_and_json(tmp_path):
    args = [
        "limits",
        "bode-integral",
        "--num",
        "0.3,0.1,0.02",
        "--den",
        "1,-0.5,0.1",
        "--dt",
        "1e-4",
    ]
    out = runner.invoke(app, [*args, "--json", "--plot", str(tmp_path / "b.png")])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["limit_gain"] == pytest.approx(0.3)
    assert data["integral"] == pytest.approx(-2 * np.pi * np.log(1.3), rel=1e-9)
    assert "Corollary 3" in data["corollary"]
    cont = runner.invoke(app, ["limits", "bode-integral", "--num", "3", "--den", "1,2"])
    assert cont.exit_code == 0 and "Theorem 1" in cont.stdout


def test_variance_and_dynamic_range(tmp_path):
    png = tmp_path / "v.png"
    out = runner.invoke(
        app,
        [
            "limits",
            "variance",
            "--num",
            "40000",
            "--den",
            "1,300,0",
            "--dist-num",
            "1",
            "--dist-den",
            "0.01,1",
            "--json",
            "--plot",
            str(png),
        ],
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["bound_out2"] <= data["variance_out2"] <= data["printed_bound_out2"]
    assert data["bound_out2"] == pytest.approx(data["bound_low_out2"] + data["bound_high_out2"])
    assert png.stat().st_size > 5000
    out = runner.invoke(
        app, ["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "3e-9", "--json"]
    )
    assert json.loads(out.stdout)["dynamic_range"] == pytest.approx(1e-7)


@pytest.mark.parametrize(
    "args, flag",
    [
        (["waterbed", "--alpha-db", "3"], "--alpha-db"),
        (["waterbed", "--freq", "20000"], "Nyquist"),
        (["bode-integral", "--num", "a", "--den", "1,2"], "--num"),
        (["bode-integral", "--num", "1", "--den", "1,2", "--dt", "-1"], "--dt"),
        (["waterbed", "--plot", "x.pdf"], "--plot"),
    ],
)
def test_bad_input_names_the_flag(args, flag):
    out = runner.invoke(app, ["limits", *args])
    assert isinstance(out.exception, ServokitError), out.output
    assert flag in str(out.exception)
