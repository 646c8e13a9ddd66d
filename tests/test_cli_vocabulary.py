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
    r"|out2|in|out_per_in_s2|per_s|s2|samples)$"
)
#: Quick arguments of every command with ``--json`` (its keys are checked, not its values;
#: ``--json`` is appended).  A command with ``--json`` missing here fails
#: :func:`test_every_json_command_is_checked`: a new command is covered the day it is born.
JSON_RUNS: dict[str, list[str]] = {
    "dual-stage": ["dual-stage", "--method", "inverse"],
    "fit": ["fit", "examples/data/stage_frf.csv", "--out", "fitted"],
    "loopshape": ["loopshape", "examples/data/stage_frf.csv", "--dt", "2.5e-5", "--order", "4",
                  "--out", "ctrl", "--time-limit", "2"],
    "pes": ["pes", "--peak-filter", "960:0.08:12"],
    "reproduce": ["reproduce", "--case", "limits", "--out", "rep"],
    "margins": ["margins", "--plant", "hdd-sampled-data", "--controller", "eq-4.69"],
    "identify": ["identify", "--plant", "vcm-dual-stage", "--controller", "table-5.2",
                 "--fmin", "20000", "--fmax", "21000", "--freq-step", "500"],
    "seek": ["seek", "--target", "1", "--method", "fsc", "--n-samples", "12"],
    "seek --method robust": ["seek", "--method", "robust", "--u-max", "1.5", "--n-samples", "12"],
    "sensitivity": ["sensitivity", "--plant", "hdd-sampled-data", "--controller", "eq-4.69",
                    "--multirate"],
    "simulate": ["simulate", "--plant", "hdd-sampled-data", "--dt", "153.5e-6", "--duration",
                 "0.005", "--step", "1", "--controller", "eq-4.69"],
    "srs": ["srs", "--input", "half-sine", "--duration", "0.5e-3", "--dt", "25e-6"],
    "sweep": ["sweep", "--method", "fsc", "--n-samples", "12", "--n-variants", "50"],
    "export feedforward": ["export", "feedforward", "--method", "ffsc", "--target", "10",
                           "--format", "c", "--out", "fw"],
    "export controller": ["export", "controller", "--controller", "eq-4.69", "--precision",
                          "q15", "--u-max", "2", "--input-max", "1"],
    "export ivc": ["export", "ivc", "--method", "pole-zero", "--precision", "q15"],
    "export table": ["export", "table", "--input", "gains.json", "--precision", "q15"],
    "feedforward polynomial": ["feedforward", "polynomial", "--order", "3", "--n-samples",
                               "20", "--dt", "1e-4"],
    "feedforward minimum-jerk": ["feedforward", "minimum-jerk", "--move-time", "1e-3", "--dt",
                                 "1e-4"],
    "limits waterbed": ["limits", "waterbed", "--alpha-db", "-40", "--freq", "1000", "--dt",
                        "4e-5"],
    "limits bode-integral": ["limits", "bode-integral", "--num", "0.5,0.1", "--den",
                             "1,-0.5,0.1", "--dt", "1e-4"],
    "limits variance": ["limits", "variance", "--num", "40000", "--den", "1,300,0",
                        "--dist-num", "1", "--dist-den", "0.01,1"],
    "limits dynamic-range": ["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m",
                             "3e-9"],
    "plant list": ["plant", "list"],
    "plant show": ["plant", "show", "hdd-benchmark"],
    "plant bode": ["plant", "bode", "hdd-benchmark", "--n-freq", "50"],
    "filter notch": ["filter", "notch", "--freq", "4449", "--damping", "0.09",
                     "--filter-damping", "0.7"],
    "filter peak": ["filter", "peak", "--freq", "4449", "--damping", "0.015", "--gain",
                    "0.1778", "--phi", "2.5414"],
    "filter lag": ["filter", "lag", "--freq", "6900", "--damping", "0.1", "--phase", "1.1519"],
    "filter inverse": ["filter", "inverse", "--zero-freq", "4449", "--pole-freq", "4775"],
    "settle train": ["settle", "train", "--judge", "new.skops", "--n-distances", "2",
                     "--n-lengths", "2"],
    "settle evaluate": ["settle", "evaluate", "--judge", "judge.skops", "--n-seeks", "3"],
    "settle judge": ["settle", "judge", "--judge", "judge.skops", "--target", "300",
                     "--n-samples", "50"],
    "ssa ddssa": ["ssa", "ddssa", "--c-pzt", "2e-9", "--c1", "2e-9", "--c2", "2e-9", "--c3",
                  "2e-9", "--freq", "1000"],
    "ssa idssa": ["ssa", "idssa", "--c", "1e-9", "--r", "10e3", "--k", "2"],
    "ssa amd": ["ssa", "amd", "--mode", "5461:2:10", "--mode", "9103:2:10"],
    "ssa adaptive": ["ssa", "adaptive", "--duration", "2e-3"],
    "switching ivc": ["switching", "ivc", "--plant", "hdd-sampled-data", "--controller",
                      "eq-4.69", "--method", "jmin"],
    "switching admissible-set": ["switching", "admissible-set", "--plant", "hdd-benchmark",
                                 "--controller", "lead-lag", "--freq", "500", "--dt",
                                 "3.7879e-5", "--u-max", "0.02", "--condition", "-16:3.9e4"],
    "switching cost-map": ["switching", "cost-map", "--plant", "hdd-benchmark", "--controller",
                           "lead-lag", "--freq", "500", "--dt", "3.7879e-5", "--position",
                           "-60", "--vel-range", "-1e5:1e5", "--acc-range", "-1e9:1e9"],
    "unobservable magnitude": ["unobservable", "magnitude", "--freq", "4000", "--dt", "25e-6"],
    "unobservable sampling": ["unobservable", "sampling", "--freq", "4000", "--damping",
                              "0.01", "--n-samples", "10"],
    "unobservable time": ["unobservable", "time", "--freq", "4000", "--dt", "25e-6",
                          "--damping", "0.01"],
}  # fmt: skip
#: runs over ~5 s (the book's cases): in the slow suite
_SLOW_JSON = {"reproduce"}
#: Commands whose JSON object is keyed by data (``plant list``: the catalogue's names),
#: not by documented fields.
_KEYED_BY_DATA = {"plant list"}
#: Keys still without a unit suffix, with a comment saying why (the test fails when a
#: listed key is gone, so the list only shrinks); empty: every dimensional key has one.
KNOWN_UNSUFFIXED: dict[str, set[str]] = {}


def _dimensionless() -> set[str]:
    text = CONVENTIONS.read_text(encoding="utf-8")
    block = text.split("<!-- dimensionless-keys -->")[1].split("<!-- /dimensionless-keys -->")[0]
    return set(re.findall(r"`([$a-z0-9_]+)`", block))


def _is_container(value) -> bool:
    return isinstance(value, dict) or (
        isinstance(value, list) and any(isinstance(v, dict | list) for v in value[:3])
    )


def leaf_keys(data, found: set[str] | None = None) -> set[str]:
    """The keys the unit rules judge (docs/CONVENTIONS.md, "JSON keys").

    A container (an object, or a list of objects or lists) is judged by its leaves; the
    children of a unit-suffixed key carry its unit (``percentiles_s: {p50: ...}``); an
    object with a ``unit`` key (a reproduce row) states its unit there; ``n_*`` keys are
    counts and numeric keys are indices.
    """
    found = set() if found is None else found
    if isinstance(data, list):
        for v in data[:3]:
            leaf_keys(v, found)
    if not isinstance(data, dict) or "unit" in data:
        return found
    for k, v in data.items():
        if _UNIT.search(k):
            continue  # its unit holds for everything under it
        if _is_container(v):
            leaf_keys(v, found)
        elif not (k.startswith("n_") or k.isdigit()):
            found.add(k)
    return found


def test_every_json_command_is_checked() -> None:
    with_json = {
        path for path, cmd in _commands() if any(q.opts == ["--json"] for q in cmd.params)
    }
    assert with_json == {name.split(" --")[0] for name in JSON_RUNS}


@pytest.fixture(scope="module")
def json_dir(tmp_path_factory):
    """A directory with the example data, a gain table and a small trained judge."""
    import shutil

    root = tmp_path_factory.mktemp("json_keys")
    shutil.copytree(CONVENTIONS.parents[1] / "examples" / "data", root / "examples" / "data")
    (root / "gains.json").write_text('{"K": [[1.0, 0.5], [0.25, 2.0]]}', encoding="utf-8")
    train = ["settle", "train", "--judge", "judge.skops", "--n-distances", "2", "--n-lengths", "2"]
    with pytest.MonkeyPatch.context() as m:
        m.chdir(root)
        m.setattr("sys.argv", ["servokit", *train])
        with pytest.raises(SystemExit) as exc:
            servokit.cli.main()
    assert exc.value.code == 0
    return root


def _json_cases():
    for name, args in JSON_RUNS.items():
        marks = [pytest.mark.slow] if name in _SLOW_JSON else []
        yield pytest.param(name, args, marks=marks, id=name)


@pytest.mark.parametrize(("name", "args"), list(_json_cases()))
def test_json_keys_carry_a_unit_or_are_listed_dimensionless(
    name, args, json_dir, capsys, monkeypatch
) -> None:
    import json

    from _cli_run import run_cli

    monkeypatch.chdir(json_dir)
    code, out, err, _ = run_cli([*args, "--json"], 300, monkeypatch, capsys)
    assert code == 0, err
    keys = leaf_keys(json.loads(out))
    known = KNOWN_UNSUFFIXED.get(name, set())
    bad = sorted(k for k in keys if not _UNIT.search(k) and k not in _dimensionless() | known)
    gone = sorted(known - keys)
    assert not bad and not gone, (
        f"{name}: keys without a unit suffix: {bad}; fixed (remove from KNOWN_UNSUFFIXED): {gone}"
    )
    # every top-level key is listed in the command's --help (README: "listed in each --help")
    command = name.split(" --")[0]
    if command in _KEYED_BY_DATA:
        return
    (cmd,) = [c for path, c in _commands() if path == command]
    listed = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", f"{cmd.help or ''} {cmd.epilog or ''}"))
    unlisted = sorted(set(json.loads(out)) - listed)
    assert not unlisted, f"{name}: JSON keys missing from --help: {unlisted}"
