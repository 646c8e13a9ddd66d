"""One vocabulary for every command, enforced against docs/CONVENTIONS.md.

The flag table of the conventions page is the authority: every visible option of every
command (walked through the click metadata, so a new command is checked the day it is
registered) must be listed there, with the kind of value it takes; a flag name has one
meaning. File arguments share one metavar per kind, help shows no framework internals,
``-h`` is ``--help``, and the JSON keys of the commands carry unit suffixes.
"""

from __future__ import annotations

import re
import typing
from pathlib import Path

import pytest

import servokit.cli

CONVENTIONS = Path(__file__).resolve().parents[1] / "docs" / "CONVENTIONS.md"
_ROW = re.compile(r"^\| `(--[a-z0-9-]+)` \| ([a-z /,-]+) \|", re.M)


def visible_options(cmd) -> list:
    """The command's options a user sees (deprecated hidden aliases excluded)."""
    return [
        q
        for q in cmd.params
        if q.opts and q.opts[0].startswith("-") and not getattr(q, "hidden", False)
        and "--help" not in q.opts
    ]


def kind_of(param) -> str:
    """float, int, str, path, switch or list (a repeatable option)."""
    if getattr(param, "is_flag", False):
        return "switch"
    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    if typing.get_origin(ann) is list:
        return "list"
    args = [a for a in typing.get_args(ann) if a is not type(None)] or [ann]
    names = sorted({getattr(a, "__name__", str(a)) for a in args})
    if names == ["Path"] or names == ["PosixPath"]:
        return "path"
    return "/".join(names)


def _commands() -> list:
    import typer.main

    servokit.cli._discover()
    root = servokit.cli._app.build_command()
    found = []
    for name, cmd in root.commands.items():
        subs = getattr(cmd, "commands", None)
        found += [(f"{name} {s}", c) for s, c in subs.items()] if subs else [(name, cmd)]
    assert typer.main  # the tree is typer's
    return found


def _vocabulary() -> dict[str, set[str]]:
    text = CONVENTIONS.read_text(encoding="utf-8")
    return {flag: {k.strip() for k in kinds.split("/")} for flag, kinds in _ROW.findall(text)}


def test_every_flag_is_in_the_vocabulary_with_its_kind() -> None:
    vocab = _vocabulary()
    assert len(vocab) > 80
    problems = []
    for path, cmd in _commands():
        for q in visible_options(cmd):
            flag = max(q.opts, key=len)
            if flag not in vocab:
                problems.append(f"{path}: {flag} is not in docs/CONVENTIONS.md's flag table")
            elif not set(kind_of(q).split("/")) <= vocab[flag]:
                problems.append(
                    f"{path}: {flag} takes {kind_of(q)}; the table says {sorted(vocab[flag])}"
                )
    assert not problems, "\n".join(problems)


def test_the_table_lists_no_flag_twice() -> None:
    flags = _ROW.findall(CONVENTIONS.read_text(encoding="utf-8"))
    seen = [f for f, _ in flags]
    assert len(seen) == len(set(seen)), sorted({f for f in seen if seen.count(f) > 1})


def test_one_metavar_per_kind_of_argument() -> None:
    for path, cmd in _commands():
        for q in visible_options(cmd):
            if kind_of(q) == "path":
                assert q.metavar in ("FILE", "DIR"), (path, q.opts, q.metavar)
            if q.name in ("plant", "controller", "loop_plant"):
                assert q.metavar == "NAME_OR_TOML", (path, q.opts, q.metavar)
            if q.opts == ["--out"]:
                assert q.metavar == "DIR", (path, "--out is always a directory")


@pytest.mark.parametrize("word", ["range>", "x>=", "x<=", "<list[", "<path>", "<float range"])
def test_help_shows_no_framework_internals(word) -> None:
    for path, cmd in _commands():
        ctx = cmd.make_context(path, [], resilient_parsing=True)
        assert word not in cmd.get_help(ctx), (path, word)


def test_dash_h_is_help(capsys, monkeypatch) -> None:
    monkeypatch.setattr("sys.argv", ["servokit", "limits", "waterbed", "-h"])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    assert exc.value.code == 0
    assert "Usage:" in capsys.readouterr().out


# ---- JSON keys ------------------------------------------------------------------------
_UNIT = re.compile(
    r"_(s|ms|us|hz|track|db|deg|rad|a|v|w|m|j|f|ohm|mb|percent|out|out_per_s|out_per_s2"
    r"|per_s|s2)$"
)
_FAST_JSON = [
    ["limits", "waterbed", "--alpha-db", "-40", "--freq", "1000", "--dt", "4e-5"],
    ["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "3e-9"],
    ["filter", "notch", "--freq", "4449", "--damping", "0.09", "--dt", "1e-4"],
    ["plant", "bode", "hdd-benchmark", "--n-freq", "50"],
    ["feedforward", "polynomial", "--order", "3", "--n-samples", "20", "--dt", "1e-4"],
    ["feedforward", "minimum-jerk", "--move-time", "1e-3", "--dt", "1e-4"],
    ["simulate", "--plant", "hdd-sampled-data", "--dt", "153.5e-6", "--duration", "0.005",
     "--step", "1", "--controller", "eq-4.69"],
]  # fmt: skip


def _dimensionless() -> set[str]:
    text = CONVENTIONS.read_text(encoding="utf-8")
    block = text.split("<!-- dimensionless-keys -->")[1].split("<!-- /dimensionless-keys -->")[0]
    return set(re.findall(r"`([a-z0-9_]+)`", block))


def _keys(data, found: set[str]) -> set[str]:
    if isinstance(data, dict):
        for k, v in data.items():
            found.add(k)
            _keys(v, found)
    elif isinstance(data, list):
        for v in data[:3]:
            _keys(v, found)
    return found


@pytest.mark.parametrize("args", _FAST_JSON, ids=[" ".join(a[:2]) for a in _FAST_JSON])
def test_json_keys_carry_a_unit_or_are_listed_dimensionless(args, capsys, monkeypatch) -> None:
    import json

    monkeypatch.setattr("sys.argv", ["servokit", *args, "--json"])
    with pytest.raises(SystemExit) as exc:
        servokit.cli.main()
    out, err = capsys.readouterr()
    assert exc.value.code == 0, err
    keys = _keys(json.loads(out), set())
    bad = sorted(k for k in keys if not _UNIT.search(k) and k not in _dimensionless())
    assert not bad, f"{' '.join(args[:2])}: keys without a unit suffix: {bad}"
