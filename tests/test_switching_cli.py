"""``servokit switching ivc`` and ``servokit switching admissible-set``."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

import servokit.cli
from servokit.cli._app import app
from servokit.models import get_discrete_controller, get_plant
from servokit.switching import ivc_jmin, ivc_pole_zero, switched_loop

servokit.cli._discover()
runner = CliRunner()


def run_json(*args: str) -> dict:
    res = runner.invoke(app, ["switching", *args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def _book_loop():
    ctrl = get_discrete_controller("eq-4.69")
    return switched_loop(get_plant("hdd-sampled-data").discretize(float(ctrl.dt)), ctrl)


def test_ivc_jmin_json_matches_library(tmp_path):
    png = tmp_path / "ivc.png"
    out = run_json("ivc", "--method", "jmin", "--weight", "position", "--plot", str(png))
    loop = _book_loop()
    np.testing.assert_allclose(out["gain"], ivc_jmin(loop, None, output_weight=loop.C), rtol=1e-9)
    assert out["n_plant_states"] == loop.n and out["dt_s"] == pytest.approx(loop.dt)
    assert png.stat().st_size > 5000


def test_ivc_pole_zero_json_cancels():
    loop = _book_loop()
    lam = max((p for p in loop.poles() if abs(p.imag) < 1e-12), key=abs)
    out = run_json("ivc", "--method", "pole-zero", "--poles", f"{float(lam.real):.17g}")
    np.testing.assert_allclose(out["gain"], ivc_pole_zero(loop, None, [lam]), rtol=1e-9)
    zeros = [complex(z["re"], z["im"]) for z in out["zeros_position"]]
    assert min(abs(z - lam) for z in zeros) < 1e-6


def test_admissible_set_json_classifies():
    out = run_json("admissible-set", "--condition", "-1:3937", "--condition", "-16:39370")
    c1, c2 = out["conditions"]
    assert c1["admissible_ivc"] and c1["admissible_zero_reset"]
    assert c2["admissible_ivc"] and not c2["admissible_zero_reset"]
    assert c2["needed_u_zero_reset"] > 0.02 > c2["needed_u_ivc"]
    assert len(out["polygon_ivc"]) >= 3


def test_cost_map_json_optimum_beats_the_grid():
    out = run_json("cost-map", "--n-points", "21", "--vel-range", "0:60000")
    from servokit.switching import switching_cost_matrix

    ctrl_loop = _admissible_loop()
    K = ivc_jmin(ctrl_loop, None, output_weight=ctrl_loop.Cu)
    M = switching_cost_matrix(ctrl_loop, K, ctrl_loop.Cu)
    opt = out["optimal_state"]
    best = np.zeros(M.shape[0])
    best[:3] = [opt["position_out"], opt["velocity_out_per_s"], opt["acceleration_out_per_s2"]]
    assert best[0] == -60.0
    assert best @ M @ best <= min(out["ju"][0]) * (1 + 1e-9)


def _admissible_loop():
    from servokit.cases.switching_admissible import admissible_loop

    return admissible_loop()


@pytest.mark.parametrize(
    ("args", "flag"),
    [
        (["ivc", "--method", "foo"], "--method"),
        (["ivc", "--method", "pole-zero", "--poles", "a,b"], "--poles"),
        (["ivc", "--method", "pole-zero"], "--poles"),
        (["admissible-set", "--condition", "3"], "--condition"),
        (["ivc", "--plot", "/tmp"], "--plot"),
        (["cost-map", "--vel-range", "3"], "--vel-range"),
        (["cost-map", "--ivc", "foo"], "--ivc"),
        (["ivc", "--method", "input", "--order", "40"], "--order"),
        (["ivc", "--method", "input", "--pole", "1.5"], "--pole"),
    ],
)
def test_bad_input_one_line_exit_2(args, flag, monkeypatch, capsys):
    # in-process through main() (the real entry point), faster than a subprocess
    monkeypatch.setattr(sys, "argv", ["servokit", "switching", *args])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    assert err.count("\n") == 1 and err.startswith("servokit: error:")
    assert flag in err and "Traceback" not in err
