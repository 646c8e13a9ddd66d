"""Every command against a table of bad inputs: exit 2, one stderr line naming the flag.

Each row is a regression test for issue 7 ("Hardening as a user meets it"): non-finite,
zero, negative, huge and wrong-type values, missing/unwritable paths and directories.
The checks: exit status 2, exactly one line on stderr that names the flag, no
traceback, nothing on stdout, nothing written, and done within a few seconds.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

import servokit.cli

HUGE = "1000000000"  # a count that must be refused before anything is allocated

SIM = ["simulate", "--dt", "1e-4", "--duration", "0.01"]
POLY = ["feedforward", "polynomial"]
MJ = ["feedforward", "minimum-jerk"]
MAG = ["unobservable", "magnitude", "--freq", "4000"]
SAMP = ["unobservable", "sampling", "--freq", "4000"]
TIME = ["unobservable", "time", "--freq", "4000", "--dt", "25e-6"]

CASES: list[tuple[list[str], str]] = [
    # ---- plant
    (["plant", "show", ""], "PLANT"),
    (["plant", "show", "."], "PLANT"),
    (["plant", "show", "no-such-plant"], "PLANT"),
    (["plant", "show", "missing.toml"], "PLANT"),
    (["plant", "show", "DIR"], "PLANT"),
    (["plant", "show", "GARBAGE.toml"], "PLANT"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "0"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "nan"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--fmax", "inf"], "--fmax"),
    (["plant", "bode", "hdd-benchmark", "--fmin", "100", "--fmax", "10"], "--fmin"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "1"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "-5"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "abc"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", "1e9"], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--n-freq", HUGE], "--n-freq"),
    (["plant", "bode", "hdd-benchmark", "--plot", "DIR"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "DIR/"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "noext"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "fig.pdf"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--plot", "missing/fig.png"], "--plot"),
    (["plant", "bode", "hdd-benchmark", "--max-memory-mb", "0"], "--max-memory-mb"),
    # ---- simulate
    (["simulate", "--dt", "0", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "-1e-4", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "nan", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "inf", "--duration", "1", "--step", "1"], "--dt"),
    (["simulate", "--dt", "1e-4", "--duration", "0", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "inf", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "1e-9", "--step", "1"], "--duration"),
    (["simulate", "--dt", "1e-4", "--duration", "1e6", "--step", "1"], "--duration"),
    ([*SIM, "--step", "1", "--substeps", "0"], "--substeps"),
    ([*SIM, "--step", "1", "--substeps", "10000000"], "--substeps"),
    ([*SIM, "--step", "nan"], "--step"),
    (SIM, "--step"),
    ([*SIM, "--step", "1", "--input", "u.txt"], "--input"),
    ([*SIM, "--input", "missing.txt"], "--input"),
    ([*SIM, "--input", "DIR"], "--input"),
    ([*SIM, "--input", "GARBAGE.toml"], "--input"),
    ([*SIM, "--input", "EMPTY.txt"], "--input"),
    ([*SIM, "--step", "1", "--controller", "no-such"], "--controller"),
    ([*SIM, "--step", "1", "--controller", "eq-4.69"], "--controller"),
    ([*SIM, "--step", "1", "--plant", "no-such"], "--plant"),
    ([*SIM, "--step", "1", "--plant", "galvano-scanner", "--variants"], "--variants"),
    ([*SIM, "--step", "1", "--settle-band", "0"], "--settle-band"),
    ([*SIM, "--step", "1", "--plot", "DIR"], "--plot"),
    # ---- feedforward polynomial / minimum-jerk
    ([*POLY, "--n-samples", "0", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "-3", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "1e12", "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", HUGE, "--dt", "1e-4"], "--n-samples"),
    ([*POLY, "--n-samples", "40", "--dt", "0"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "nan"], "--dt"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--order", "9"], "--order"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--order", "2"], "--order"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--target", "nan"], "--target"),
    ([*POLY, "--n-samples", "40", "--dt", "1e-4", "--plot", "noext"], "--plot"),
    ([*MJ, "--dt", "0"], "--dt"),
    ([*MJ, "--dt", "2", "--move-time", "1"], "--dt"),
    ([*MJ, "--dt", "1e-12", "--move-time", "1"], "--max-memory-mb"),
    ([*MJ, "--dt", "0.1", "--move-time", "0"], "--move-time"),
    ([*MJ, "--dt", "0.1", "--move-time", "inf"], "--move-time"),
    ([*MJ, "--dt", "0.1", "--target", "nan"], "--target"),
    # ---- seek
    (["seek", "--n-samples", "0"], "--n-samples"),
    (["seek", "--n-samples", "abc"], "--n-samples"),
    (["seek", "--n-samples", "10000000"], "--n-samples"),
    (["seek", "--n-samples-max", "100000"], "--n-samples-max"),
    (["seek", "--n-samples-max", "2"], "--n-samples-max"),
    (["seek", "--dt", "0"], "--dt"),
    (["seek", "--dt", "nan"], "--dt"),
    (["seek", "--target", "0"], "--target"),
    (["seek", "--target", "nan"], "--target"),
    (["seek", "--method", "lqr"], "--method"),
    (["seek", "--model", "full"], "--model"),
    (["seek", "--method", "ffsc", "--band-weight", "1:2:3"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "a:b:c:d"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "2000:1000:1:5"], "--band-weight"),
    (["seek", "--method", "ffsc", "--band-weight", "1000:nan:1:5"], "--band-weight"),
    (["seek", "--method", "fsc", "--band-weight", "1000:2000:1:5"], "--band-weight"),
    (["seek", "--settle-band", "0"], "--settle-band"),
    (["seek", "--settle-band", "-1"], "--settle-band"),
    (["seek", "--plant", "no-such"], "--plant"),
    (["seek", "--plant", "galvano-scanner"], "--dt"),
    (["seek", "--plot", "noext"], "--plot"),
    # ---- sensitivity
    (["sensitivity", "--fmin", "0"], "--fmin"),
    (["sensitivity", "--fmin", "100", "--fmax", "10"], "--fmin"),
    (["sensitivity", "--fmax", "nan"], "--fmax"),
    (["sensitivity", "--n-freq", "1"], "--n-freq"),
    (["sensitivity", "--n-freq", HUGE], "--n-freq"),
    (["sensitivity", "--tol", "0"], "--tol"),
    (["sensitivity", "--tol", "2"], "--tol"),
    (["sensitivity", "--tol", "nan"], "--tol"),
    (["sensitivity", "--band-limit", "0"], "--band-limit"),
    (["sensitivity", "--band-limit", "-1"], "--band-limit"),
    (["sensitivity", "--m", "0"], "--m"),
    (["sensitivity", "--controller", "no-such"], "--controller"),
    (["sensitivity", "--plant", "no-such"], "--plant"),
    (["sensitivity", "--plot", "DIR"], "--plot"),
    # ---- unobservable
    (["unobservable", "magnitude", "--freq", "0", "--dt", "25e-6"], "--freq"),
    (["unobservable", "magnitude", "--freq", "nan", "--dt", "25e-6"], "--freq"),
    ([*MAG, "--dt", "0"], "--dt"),
    ([*MAG, "--dt", "-1"], "--dt"),
    ([*MAG, "--dt", "25e-6", "--damping", "1"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "-0.1"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "nan"], "--damping"),
    ([*MAG, "--dt", "25e-6", "--damping", "0.1"], "--n-samples"),
    ([*MAG, "--dt", "25e-6", "--n-samples", "0"], "--n-samples"),
    ([*MAG, "--dt", "25e-6", "--n-samples", HUGE], "--n-samples"),
    ([*SAMP, "--level", "0"], "--level"),
    ([*SAMP, "--level", "nan"], "--level"),
    ([*SAMP, "--n-samples", "0"], "--n-samples"),
    ([*SAMP, "--n-samples", "10000000"], "--n-samples"),
    ([*SAMP, "--fs-min", "10", "--fs-max", "5"], "--fs-min"),
    ([*SAMP, "--fs-min", "nan"], "--fs-min"),
    ([*TIME, "--n-samples-max", "0"], "--n-samples-max"),
    ([*TIME, "--n-samples-max", "10000000"], "--n-samples-max"),
    ([*TIME, "--n-samples-max", "10000"], "--n-samples-max"),
    ([*TIME, "--level", "-1"], "--level"),
    (["unobservable", "time", "--freq", "4000", "--dt", "0"], "--dt"),
    # ---- srs
    (["srs", "--input", "missing.txt", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "DIR", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "GARBAGE.toml", "--dt", "25e-6"], "--input"),
    (["srs", "--input", "polynomial"], "--dt"),
    (["srs", "--dt", "0"], "--dt"),
    (["srs", "--dt", "nan"], "--dt"),
    (["srs", "--duration", "0"], "--duration"),
    (["srs", "--n-freq", "1"], "--n-freq"),
    (["srs", "--n-freq", HUGE], "--n-freq"),
    (["srs", "--fmin", "0"], "--fmin"),
    (["srs", "--fmin", "10", "--fmax", "5"], "--fmin"),
    (["srs", "--input", "polynomial", "--dt", "25e-6", "--n-samples", "0"], "--n-samples"),
    (["srs", "--input", "polynomial", "--dt", "1e-6", "--n-samples", "10000000"], "--n-samples"),
    (["srs", "--freq", "0"], "--freq"),
    (["srs", "--freq", "nan"], "--freq"),
    (["srs", "--kind", "peak"], "--kind"),
    (["srs", "--damping", "1"], "--damping"),
    (["srs", "--plot", "DIR"], "--plot"),
    # ---- reproduce
    (["reproduce", "--out", "u.txt"], "--out"),
    (["reproduce", "--out", "u.txt/sub"], "--out"),
    (["reproduce", "--case", "no-such", "--out", "fresh"], "--case"),
]


def _materialise(args: list[str], where: Path) -> list[str]:
    """Placeholders: DIR an existing directory, GARBAGE.toml an unreadable plant file, ..."""
    (where / "DIR").mkdir(exist_ok=True)
    (where / "GARBAGE.toml").write_text("this is = = not toml [\n")
    (where / "EMPTY.txt").write_text("")
    (where / "u.txt").write_text("1e-3\n-1e-3\n")
    return args


def _snapshot(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


@pytest.mark.parametrize(("args", "flag"), CASES, ids=[" ".join(a) for a, _ in CASES])
def test_bad_input_is_one_line_exit_2(args, flag, tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.chdir(tmp_path)
    _materialise(args, tmp_path)
    before = _snapshot(tmp_path)
    monkeypatch.setattr("sys.argv", ["servokit", *args])
    start = time.perf_counter()
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    elapsed = time.perf_counter() - start
    out, err = capsys.readouterr()
    assert exc.value.code == 2, (out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("servokit: error: ") or lines[0].startswith("Error")
    assert flag in lines[0], lines[0]
    assert "Traceback" not in err and out == ""
    assert _snapshot(tmp_path) == before, "a refused request wrote files"
    assert elapsed < 5.0, f"refusal took {elapsed:.1f} s"


def test_the_table_covers_every_command() -> None:
    commands = {
        a[0] if a[0] not in ("plant", "feedforward", "unobservable") else " ".join(a[:2])
        for a, _ in CASES
    }
    assert commands >= {
        "plant show",
        "plant bode",
        "simulate",
        "feedforward polynomial",
        "feedforward minimum-jerk",
        "seek",
        "sensitivity",
        "unobservable magnitude",
        "unobservable sampling",
        "unobservable time",
        "srs",
        "reproduce",
    }
    assert len(CASES) >= 90
