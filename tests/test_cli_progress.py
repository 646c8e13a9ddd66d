"""Start lines of long commands (issue 23 item 6, "long work shows progress").

A long command says on stderr what it is about to do once its arguments are valid and
before the slow part, so that its first output comes at once. The line is printed on a
terminal (or with ``SERVOKIT_PROGRESS=1``): never for a refused request (one error line
only), never on stdout (``--json`` stays pure), and not into a pipe by default.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from _cli_run import run_cli
from test_cli_bad_input import CASES, HANG_S, _materialise, _param

from servokit.cli._render import PROGRESS_ENV, progress_wanted

SRC = Path(__file__).resolve().parents[1] / "src"


def _commands_with_start_lines() -> set[tuple[str, ...]]:
    """Every command whose CLI module calls ``started("command words", ...)``, read from
    the sources, so that a command given a start line is covered the day it gets one."""
    import re

    found = set()
    for path in (SRC / "servokit" / "cli").glob("*.py"):
        for words in re.findall(r'started\(\s*"([a-z -]+)"', path.read_text()):
            found.add(tuple(words.split()))
    return found


LONG = _commands_with_start_lines()
#: The bad-input rows of the commands that print a start line.
LONG_CASES = [(a, f) for a, f in CASES if any(tuple(a[: len(w)]) == w for w in LONG)]
_ENTRY = "import sys; from servokit.cli import main; sys.argv[0] = 'servokit'; main()"


@pytest.fixture(scope="module")
def judge_dir(tmp_path_factory) -> Path:
    """A directory holding a small trained judge.skops."""
    where = tmp_path_factory.mktemp("judge")
    proc = subprocess.run(
        [sys.executable, "-c", _ENTRY, "settle", "train", "--judge",
         str(where / "judge.skops"), "--n-distances", "2", "--n-lengths", "3"],
        capture_output=True, text=True, env=_env(PROGRESS_ENV, "0"), timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == f"wrote {where / 'judge.skops'}\n", "a start line went into a pipe"
    return where


def _env(*pairs: str) -> dict[str, str]:
    env = dict(os.environ, PYTHONPATH=str(SRC), MPLBACKEND="Agg")
    env.update(dict(zip(pairs[::2], pairs[1::2], strict=True)))
    return env


def test_the_switch_reads_the_environment_then_the_terminal(monkeypatch) -> None:
    monkeypatch.setenv(PROGRESS_ENV, "1")
    assert progress_wanted()
    monkeypatch.setenv(PROGRESS_ENV, "0")
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    assert not progress_wanted()
    monkeypatch.delenv(PROGRESS_ENV)
    assert progress_wanted()  # a terminal
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False, raising=False)
    assert not progress_wanted()  # a pipe or a file


#: Records, when the start line is printed, which heavy libraries are already imported.
_PROBE = r"""
import sys
import servokit.cli._render as r
seen = []
def wanted():
    seen.append([m for m in ("sklearn", "skops.io", "control") if m in sys.modules])
    return True
r.progress_wanted = wanted
from servokit.cli import main
sys.argv = ["servokit", *sys.argv[1:]]
try:
    main()
finally:
    print("PROBE", seen, file=sys.stderr)
"""


@pytest.mark.parametrize("command", ["judge", "evaluate"])
def test_the_start_line_comes_before_the_slow_imports_and_json_stays_pure(
    command, judge_dir
) -> None:
    args = ["--judge", "judge.skops", "--json"]
    args += ["--n-seeks", "3"] if command == "evaluate" else ["--target", "300"]
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE, "settle", command, *args],
        capture_output=True, text=True, cwd=judge_dir, env=_env(), timeout=300,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    json.loads(proc.stdout)  # nothing but the JSON on stdout
    lines = proc.stderr.splitlines()
    assert lines[0].startswith(f"settle {command}: loading judge.skops"), lines
    assert lines[-1] == "PROBE [[]]", "the start line came after sklearn or skops was imported"


def test_a_pipe_gets_no_start_line_unless_asked(judge_dir, monkeypatch, capsys) -> None:
    monkeypatch.chdir(judge_dir)
    monkeypatch.delenv(PROGRESS_ENV, raising=False)
    args = ["settle", "judge", "--target", "300", "--json"]
    code, out, err, _ = run_cli(args, HANG_S, monkeypatch, capsys)
    assert (code, err) == (0, "")
    monkeypatch.setenv(PROGRESS_ENV, "1")
    code, out, err, _ = run_cli(args, HANG_S, monkeypatch, capsys)
    assert code == 0 and err == "settle judge: loading judge.skops, judging a 300-track seek\n"
    assert json.loads(out)["n0"] is not None


@pytest.mark.parametrize(("args", "flag"), [_param(a, f) for a, f in LONG_CASES])
def test_a_refused_request_prints_no_start_line(args, flag, tmp_path, monkeypatch, capsys):
    """With the start lines forced on, every bad-input row of a long command still ends in
    exactly one error line: all checks come before the start line."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(PROGRESS_ENV, "1")
    _materialise(args, tmp_path, monkeypatch)
    code, out, err, _ = run_cli(args, HANG_S, monkeypatch, capsys)
    assert code == 2, (out, err)
    lines = err.strip().splitlines()
    if tuple(args) in FOUND_BY_THE_WORK:  # the start line, then the one error line
        assert len(lines) == 2 and lines[0].startswith(args[0]) and flag in lines[1], err
        return
    assert len(lines) == 1 and flag in lines[0], err


#: Refusals that are findings of the slow part itself, not checks of the arguments: the
#: fit finds fewer resonances than ``--modes`` (or none at all) only from its candidates
#: (AAA), the step the start line announces.
FOUND_BY_THE_WORK = {
    ("fit", "FRF.csv", "--out", "o", "--modes", "9"),
    ("fit", "FLAT.csv", "--out", "o"),
}


@pytest.mark.slow
def test_report_says_what_it_builds_and_stdout_keeps_its_answer(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv(PROGRESS_ENV, "1")
    args = ["report", "--plant", "hdd-sampled-data", "--controller", "eq-4.69", "--out", "d"]
    code, out, err, _ = run_cli(args, HANG_S, monkeypatch, capsys)
    assert code == 0, err
    assert err.splitlines()[0] == "report: 2 section(s) -> d/report.html"
    assert out == "2 section(s)\n"


def test_loopshape_step_lines_are_throttled(monkeypatch, capsys) -> None:
    from servokit.cli.loopshape import _step_lines

    monkeypatch.setenv(PROGRESS_ENV, "1")
    entry = {"iteration": 2, "phase": 2, "min_crossover_hz": 812.44, "worst_s_peak_db": 5.991}
    _step_lines(every_s=0.0)(entry)
    quiet = _step_lines(every_s=3600.0)
    quiet(entry)
    quiet(entry)
    assert capsys.readouterr().err == (
        "loopshape: step 3 (phase 2): lowest crossover 812.4 Hz, worst |S| 5.99 dB\n"
    )


@pytest.mark.slow
def test_reproduce_start_line_and_pure_json(tmp_path) -> None:
    proc = subprocess.run(
        [sys.executable, "-c", _ENTRY, "reproduce", "--case", "resonance-filters", "--out",
         "o", "--json"],
        capture_output=True, text=True, cwd=tmp_path, env=_env(PROGRESS_ENV, "1"), timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["rows"]
    lines = proc.stderr.splitlines()
    assert lines[0] == "reproduce: 1 case(s) on up to 1 process(es) -> o/", lines
    assert lines[1].startswith("[1/1] resonance-filters done")


def test_admissible_set_says_what_it_computes_and_stdout_keeps_its_json(monkeypatch, capsys):
    monkeypatch.setenv(PROGRESS_ENV, "1")
    args = ["switching", "admissible-set", "--plant", "hdd-benchmark", "--controller",
            "lead-lag", "--dt", "3.7879e-5", "--t-max", "100", "--json"]  # fmt: skip
    code, out, err, _ = run_cli(args, HANG_S, monkeypatch, capsys)
    assert code == 0, err
    assert err == "switching admissible-set: O_inf of 17 states, horizons up to 100 samples\n"
    assert json.loads(out)["t_star"] == 82
