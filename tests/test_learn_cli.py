"""``servokit settle`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from servokit.cli import _discover
from servokit.cli._app import app
from servokit.errors import ServokitError
from servokit.learn import SettlingJudge, conventional_judgement, simulate_seeks

_discover()
runner = CliRunner()


@pytest.fixture(scope="module")
def judge_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("judge") / "j.skops"
    out = runner.invoke(
        app,
        ["settle", "train", "--out", str(path), "--n-distances", "3", "--n-lengths", "4", "--json"],
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["n_states"] == data["n_class1"] + data["n_class2"] > 0
    return path


def test_evaluate_json_and_plot(judge_file, tmp_path):
    png = tmp_path / "h.png"
    out = runner.invoke(
        app,
        [
            "settle",
            "evaluate",
            "--judge",
            str(judge_file),
            "--n-seeks",
            "5",
            "--json",
            "--plot",
            str(png),
        ],
    )
    assert out.exit_code == 0, out.output
    methods = json.loads(out.stdout)["methods"]
    assert [m["method"] for m in methods][0].startswith("conventional")
    assert all(len(m["delays_samples"]) + m["never_judged"] == 5 for m in methods)
    assert png.stat().st_size > 5000


def test_judge_recorded_sequence_matches_library(judge_file, tmp_path):
    (r,) = simulate_seeks([(120.0, 60)], horizon=300)
    csv = tmp_path / "rec.csv"
    np.savetxt(csv, np.column_stack([r.states, r.output]), delimiter=",")
    out = runner.invoke(
        app, ["settle", "judge", "--judge", str(judge_file), "--record", str(csv), "--json"]
    )
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    judge = SettlingJudge.load(judge_file)
    assert data["n_judge"] == judge.judge(r.states, r.output, 0.0)
    assert data["n_conventional"] == conventional_judgement(r.output, 0.03)
    assert data["n0"] == r.n0()


@pytest.mark.parametrize(
    "args, flag",
    [
        (["judge", "--judge", "missing.skops"], "--judge"),
        (["train", "--out", "judge.pkl"], "--out"),
        (["evaluate", "--judge", "missing.skops"], "--judge"),
    ],
)
def test_bad_input_names_the_flag(args, flag):
    out = runner.invoke(app, ["settle", *args])
    assert isinstance(out.exception, ServokitError), out.output
    assert flag in str(out.exception)


def test_bad_record(judge_file, tmp_path):
    csv = tmp_path / "bad.csv"
    csv.write_text("1,2,3\n")
    out = runner.invoke(app, ["settle", "judge", "--judge", str(judge_file), "--record", str(csv)])
    assert isinstance(out.exception, ServokitError) and "--record" in str(out.exception)


def test_evaluate_text_never_prints_nan(judge_file):
    """A method with no seek judged without a failure has no mean delay: JSON null, and
    words in the table -- never "nan samples" (issue 23)."""
    args = ["settle", "evaluate", "--judge", str(judge_file), "--n-seeks", "2"]
    data = json.loads(runner.invoke(app, [*args, "--json"]).stdout)
    text = runner.invoke(app, args).stdout
    assert "nan" not in text
    for m in data["methods"]:
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(m["method"]))
        assert ("n/a" in line) == (m["mean_delay_samples"] is None), line
