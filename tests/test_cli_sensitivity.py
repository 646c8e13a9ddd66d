"""``servokit sensitivity`` command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.errors import ServokitError
from servokit.models import HDD_SAMPLED_DATA_TS, controller_eq_4_69, hdd_sampled_data
from servokit.sampled import sampled_data_sensitivity

_discover()
runner = CliRunner()


def test_json_matches_library():
    out = runner.invoke(
        app,
        ["sensitivity", "--no-multirate", "--fmin", "100", "--fmax", "3000", "--n", "4", "--json"],
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    ref = sampled_data_sensitivity(
        hdd_sampled_data(), controller_eq_4_69(), HDD_SAMPLED_DATA_TS, np.linspace(100, 3000, 4)
    )
    np.testing.assert_allclose(data["Ssd"], ref.Ssd, rtol=1e-12)
    np.testing.assert_allclose(data["Sd_mag"], np.abs(ref.Sd), rtol=1e-12)
    assert data["m"] == 1 and data["dt"] == pytest.approx(HDD_SAMPLED_DATA_TS)


def test_multirate_table_and_plot(tmp_path):
    png = tmp_path / "s.png"
    out = runner.invoke(app, ["sensitivity", "--n", "60", "--plot", str(png)])
    assert out.exit_code == 0, out.output
    assert "m = 4" in out.stdout and "peak |Ssd|" in out.stdout
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "args, msg",
    [
        (["--fmin", "0"], "--fmin"),
        (["--n", "1"], "--n"),
        (["--plant", "no-such-plant"], "unknown plant"),
        (["--m", "0"], "--m"),
    ],
)
def test_user_errors_raise_servokit_errors(args, msg):
    out = runner.invoke(app, ["sensitivity", *args])
    assert isinstance(out.exception, ServokitError), out.output
    assert msg in str(out.exception)


def test_entry_point_prints_one_line_and_exits_2():
    exe = Path(sys.executable).with_name("servokit")
    proc = subprocess.run(
        [str(exe), "sensitivity", "--controller", "missing.toml"], capture_output=True, text=True
    )
    assert proc.returncode == 2
    assert "missing.toml" in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
