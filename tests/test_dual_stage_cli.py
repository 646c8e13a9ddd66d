"""``servokit dual-stage`` through typer's CliRunner, and the ``dual-stage`` case."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

import servokit.cli
from servokit.cli._app import app
from servokit.feedback.dual_stage_design import evaluate_design

servokit.cli._discover()
runner = CliRunner()


def test_json_row_equals_library(tmp_path) -> None:
    from servokit.cases.dual_stage import fitted_unknowns

    png = tmp_path / "ds.png"
    res = runner.invoke(app, ["dual-stage", "--method", "inverse", "--json", "--plot", str(png)])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    row = evaluate_design("inverse", fitted_unknowns("inverse")).as_dict()
    assert math.isnan(row.pop("second_phase_margin_deg"))  # no second crossover
    assert data["row"].pop("second_phase_margin_deg") is None  # JSON null, never NaN
    assert data["row"] == pytest.approx(row)
    assert data["book"]["handoff_hz"] == 371.0
    assert png.stat().st_size > 10_000


def test_overrides_change_the_row() -> None:
    res = runner.invoke(
        app,
        [
            "dual-stage",
            "--method",
            "gain",
            "--notch-damping",
            "0.5",
            "--delay-vcm",
            "0",
            "--delay-pzt",
            "0",
            "--json",
        ],
    )
    assert res.exit_code == 0, res.output
    # the naive reading: 1.48 kHz
    assert json.loads(res.stdout)["row"]["crossover_hz"] == pytest.approx(1478, rel=0.01)


def test_table_output() -> None:
    res = runner.invoke(app, ["dual-stage", "--method", "phase", "--structure", "parallel"])
    assert res.exit_code == 0, res.output
    assert "Table 5.4" in res.stdout and "crossover_hz" in res.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (["dual-stage", "--method", "notches"], "--method"),
        (["dual-stage", "--structure", "serial"], "--structure"),
        (["dual-stage", "--notch-damping", "-1"], "--notch-damping"),
        (["dual-stage", "--delay-pzt", "1"], "--delay-pzt"),
        (["dual-stage", "--plot", "x.pdf"], "--plot"),
        (["dual-stage", "--maxiter", "0"], "--maxiter"),
    ],
)
def test_user_errors_exit_2(args, message, capsys, monkeypatch) -> None:
    monkeypatch.setattr("sys.argv", ["servokit", *args])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_case_rows_and_figures(tmp_path) -> None:
    from servokit.cases.dual_stage import run

    res = run(tmp_path)
    assert res.chapter == 5 and len(res.figures) == 4
    assert all(p.exists() for p in res.figures)
    by_name = {c.quantity: c for c in res.comparisons}
    assert by_name["order of CM (phase stabilisation)"].ok
    inverse = [c for c in res.comparisons if "inverse" in c.quantity]
    assert all(c.ok for c in inverse), [c for c in inverse if not c.ok]
