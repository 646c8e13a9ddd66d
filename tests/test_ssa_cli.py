"""``servokit ssa ...`` through typer's CliRunner."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import servokit.cli
from servokit.cli._app import app

servokit.cli._discover()
runner = CliRunner()


def run_json(*args: str) -> dict:
    res = runner.invoke(app, ["ssa", *args, "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_ddssa_balanced_and_not() -> None:
    assert run_json("ddssa") == pytest.approx(
        {"balanced": True, "freq_hz": 1000.0, "um_gain": 0.0, "vm_gain": 0.5}
    )
    d = run_json("ddssa", "--c1", "1e-9")  # CPZT/(C1+CPZT) = 2/3, C2/(C2+C3) = 1/2
    assert not d["balanced"]
    assert d["um_gain"] == pytest.approx(2 / 3 - 1 / 2)
    assert d["vm_gain"] == pytest.approx(2 / 3)


def test_idssa_fc_and_damping() -> None:
    d = run_json("idssa", "--c", "1e-9", "--r", "10e3", "--k", "2")
    assert d["fc_hz"] == pytest.approx(1 / (2 * 3.141592653589793 * 1e-9 * 10e3))
    assert d["damping"] == pytest.approx(1.5)  # 3 C sqrt(C^2 R^2) / (2 C^2 R)
    assert d["gain"] == pytest.approx(2.0) and d["um_leak_at_fc"] == pytest.approx(0.0, abs=1e-9)


def test_amd_and_adaptive() -> None:
    d = run_json("amd", "--mode", "9103:2:10")
    assert d["stable"] and d["attenuation_db"][0] > 5
    a = run_json("adaptive", "--duration", "1e-3", "--n-modes", "2")
    assert a["max_relative_increase"] < 1e-9 and a["lyapunov_end"] < a["lyapunov_start"]


def test_amd_unstable_loop_reports_no_damped_response() -> None:
    """Two modes 0.5 Hz apart destabilise the damping loop: no attenuation is invented."""
    d = run_json("amd", "--mode", "5461:2:10", "--mode", "5461.5:2:10")
    assert d["stable"] is False
    assert d["damped_db"] is None and d["attenuation_db"] is None and d["estimate_db"] is None
    assert "unstable" in d["reason"]
    assert len(d["open_db"]) == 2  # the open-loop response exists and is reported


@pytest.mark.parametrize(
    "args, message",
    [
        (["ssa", "amd", "--mode", "5461:2:10", "--mode", "5461:2:10"], "given twice"),
        (["ssa", "amd", "--mode", "1e300:2:10"], "FREQ_HZ"),
        (["ssa", "amd", "--mode", "5461:1e-300:10"], "EPS"),
        (["ssa", "ddssa", "--c1", "-1"], "--c1"),
        (["ssa", "ddssa", "--r1", "1e3"], "--r1 and --r3"),
        (["ssa", "idssa", "--k", "0"], "--k"),
        (["ssa", "amd", "--mode", "x"], "--mode"),
        (["ssa", "amd", "--mode", "9103:3:2"], "kappa"),
        (["ssa", "adaptive", "--duration", "1"], "--duration"),
        (["ssa", "adaptive", "--n-modes", "7"], "--n-modes"),
    ],
)
def test_user_errors_exit_2(args, message, capsys, monkeypatch) -> None:
    monkeypatch.setattr("sys.argv", ["servokit", *args])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
