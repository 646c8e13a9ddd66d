"""Fuzz every numeric flag of every command, driven by the CLI's own parameter metadata.

Each command's first ``--help`` example is the base invocation; every option whose click
type is a number is set to each hostile value in turn.  The run must end with exit 0 (an
answer) or exit 2 with one stderr line naming a flag, never a traceback, never a hang.
A command born tomorrow is covered the day it is registered (its help must carry an
example: ``tests/test_cli_help.py``).

Composite flags whose example value is numbers joined by ``:`` or ``,`` (``--mode
5461:2:10``, ``--num 0.5,0.1``) are fuzzed one number at a time.

The full matrix is ``slow``; the default suite runs a deterministic sample of it.
"""

from __future__ import annotations

import random
import re
import shlex
import shutil
import typing
from pathlib import Path

import click
import pytest
from _cli_run import run_cli

import servokit.cli

VALUES = ("nan", "inf", "-inf", "0", "-1", "1e300", "1e-300", "1" + "0" * 30)
TIME_LIMIT_S = 30  # in-process, per case: a case still running is a hang
#: flags whose huge value legitimately means "no budget": the command then does its full,
#: bounded work (loopshape's steps end at convergence), which takes longer than a refusal
LONGER_S = {"--time-limit": 150}
#: examples that cannot serve as a base (they pipe one command into another, or run the
#: book's case studies for minutes); their flags are fuzzed from an empty base instead.
_PIPED = (";", ">", "|")
SAMPLE = 60  # cases in the default suite
#: extra arguments that make a slow example quick (the fuzzed flag still overrides them)
QUICK = {
    "identify": ["--fmin", "20000", "--fmax", "21000", "--freq-step", "500"],
    "sweep": ["--n-variants", "200"],
    "settle train": ["--n-distances", "2", "--n-lengths", "2"],
    "loopshape": ["--time-limit", "2"],
}
EXAMPLE_DATA = Path(__file__).resolve().parents[1] / "examples" / "data"


def _leaf_commands() -> list[tuple[str, click.Command]]:
    import typer.main

    servokit.cli._discover()
    root = typer.main.get_command(servokit.cli.app)
    found: list[tuple[str, click.Command]] = []
    for name, cmd in root.commands.items():  # type: ignore[attr-defined]
        subs = getattr(cmd, "commands", None)
        if subs:
            found += [(f"{name} {s}", c) for s, c in subs.items()]
        else:
            found.append((name, cmd))
    return found


def _base_args(path: str, cmd: click.Command) -> list[str]:
    """The first runnable example of the command's help (``--plot`` dropped)."""
    epilog = (cmd.epilog or "").split("Example: ", 1)[-1]
    # a paragraph ("JSON: ...") may follow the examples
    first = epilog.split("\n\n")[0].split("  |  ")[0].split("  ")[0].strip()
    if not first.startswith("servokit ") or any(c in first for c in _PIPED):
        return path.split()
    words = shlex.split(first)[1:]
    out: list[str] = []
    skip = False
    for w in words:
        if skip:
            skip = False
            continue
        if w == "--plot":
            skip = True
            continue
        out.append(w)
    return out


def _numeric(param: click.Parameter) -> bool:
    """An option whose annotation is ``int`` or ``float`` (optionally ``| None``)."""
    if not param.opts or not param.opts[0].startswith("-"):
        return False
    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    kinds = set(typing.get_args(ann)) - {type(None)} if typing.get_args(ann) else {ann}
    return bool(kinds) and kinds <= {int, float}


def _with(args: list[str], flag: str, value: str) -> list[str]:
    args = list(args)
    if flag in args:
        i = args.index(flag)
        if i + 1 < len(args):
            args[i + 1] = value
            return args
    return [*args, flag, value]


def _cases() -> list[tuple[str, list[str], str]]:
    cases = []
    for path, cmd in _leaf_commands():
        if path == "reproduce":  # runs the book's cases: its flags are not numbers
            continue
        base = _base_args(path, cmd)
        for i in range(0, len(QUICK.get(path, [])), 2):
            base = _with(base, *QUICK[path][i : i + 2])
        for param in cmd.params:
            if _numeric(param):
                flag = max(param.opts, key=len)
                cases += [(path, _with(base, flag, v), flag) for v in VALUES]
    return cases


#: a value of numbers joined by ``:`` or ``,`` (``--mode 5461:2:10``, ``--num 0.5,0.1``)
_FIELDS = re.compile(r"[-+0-9.eE]+(?:[:,][-+0-9.eE]+)+")


def _composite_cases() -> list[tuple[str, list[str], str]]:
    """Each number inside a composite flag of a help example, set to each hostile value."""
    cases = []
    for path, cmd in _leaf_commands():
        base = _base_args(path, cmd)
        for param in cmd.params:
            flag = max(param.opts, key=len) if param.opts else ""
            if not flag.startswith("-") or _numeric(param) or flag not in base[:-1]:
                continue
            value = base[base.index(flag) + 1]
            if not _FIELDS.fullmatch(value):
                continue
            fields = re.split(r"([:,])", value)  # numbers at even indices, separators between
            for i in range(0, len(fields), 2):
                for v in VALUES:
                    hostile = "".join(v if j == i else w for j, w in enumerate(fields))
                    cases.append((path, _with(base, flag, hostile), flag))
    return cases


ALL = _cases()
COMPOSITE = _composite_cases()
_rng = random.Random(23)
DEFAULT = _rng.sample(ALL, min(SAMPLE, len(ALL))) + _rng.sample(COMPOSITE, min(30, len(COMPOSITE)))


def _run(
    args: list[str], tmp_path: Path, monkeypatch, capsys, seconds: int = TIME_LIMIT_S
) -> tuple[int, str, str, float]:
    # the help examples name the shipped example files (fit, loopshape) from the repo root
    shutil.copytree(EXAMPLE_DATA, tmp_path / "examples" / "data", dirs_exist_ok=True)
    monkeypatch.chdir(tmp_path)
    return run_cli(args, seconds, monkeypatch, capsys)


def _check(path: str, args: list[str], flag: str, tmp_path, monkeypatch, capsys) -> None:
    seconds = LONGER_S.get(flag, TIME_LIMIT_S)
    code, out, err, _ = _run(args, tmp_path, monkeypatch, capsys, seconds)
    assert "Traceback" not in err, err
    assert code in (0, 2), (args, code, err)
    if code == 2:
        lines = err.strip().splitlines()
        assert len(lines) == 1, err
        assert "--" in lines[0] or "Missing" in lines[0], lines[0]  # names a flag
        assert "nan" not in out.lower()


@pytest.mark.parametrize(("path", "args", "flag"), DEFAULT, ids=[shlex.join(c[1]) for c in DEFAULT])
def test_numeric_flag_fuzz_sample(path, args, flag, tmp_path, monkeypatch, capsys) -> None:
    _check(path, args, flag, tmp_path, monkeypatch, capsys)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("path", "args", "flag"), ALL + COMPOSITE, ids=[shlex.join(c[1]) for c in ALL + COMPOSITE]
)
def test_numeric_flag_fuzz_full(path, args, flag, tmp_path, monkeypatch, capsys) -> None:
    _check(path, args, flag, tmp_path, monkeypatch, capsys)


def test_the_fuzz_covers_every_command_with_a_numeric_flag() -> None:
    """Metadata-driven: every registered command with a number flag is in the matrix."""
    with_numbers = {p for p, c in _leaf_commands() if any(_numeric(q) for q in c.params)}
    assert with_numbers - {"reproduce"} <= {p for p, _, _ in ALL}
    assert len(ALL) > 500


def test_the_fuzz_reaches_inside_composite_flags() -> None:
    """The numbers of ``--mode F:Z:K``-style flags are fuzzed one field at a time."""
    flags = {(p, f) for p, _, f in COMPOSITE}
    assert {("ssa amd", "--mode"), ("pes", "--peak-filter"), ("limits variance", "--den")} <= flags
    assert len(COMPOSITE) >= 8 * len(flags) * 2
