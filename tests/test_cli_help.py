"""Every ``--help`` renders its units and ends with an example; ``--version``; fast help."""

from __future__ import annotations

import subprocess
import sys

import pytest
import typer
from typer.testing import CliRunner

import servokit
from servokit.cli import _discover
from servokit.cli._app import app

_discover()
runner = CliRunner()


def _commands() -> list[list[str]]:
    """Every leaf command as its argv path, walking the click tree of the app."""
    root = typer.main.get_command(app)
    out: list[list[str]] = []

    def walk(cmd, path: list[str]) -> None:  # noqa: ANN001 - typer may vendor click
        if hasattr(cmd, "commands"):
            for name, sub in cmd.commands.items():
                walk(sub, [*path, name])
        else:
            out.append(path)

    walk(root, [])
    return out


COMMANDS = _commands()
# units each command's help must show (rich markup used to eat "[s]" and "[hdd-seek]")
UNITS = {
    "simulate": ["[s]", "[count]", "[MB]"],
    "seek": ["[s]", "[count]", "[Hz:Hz:1:count]"],
    "sensitivity": ["[Hz]", "[count]"],
    "srs": ["[s]", "[Hz]", "[count]"],
    "plant bode": ["[Hz]", "[count]"],
    "feedforward polynomial": ["[s]", "[count]"],
    "feedforward minimum-jerk": ["[s]"],
    "unobservable magnitude": ["[Hz]", "[s]", "[count]"],
    "unobservable sampling": ["[Hz]", "[count]"],
    "unobservable time": ["[Hz]", "[s]", "[count]"],
}


def _help(path: list[str]) -> str:
    res = runner.invoke(app, [*path, "--help"], terminal_width=100)
    assert res.exit_code == 0, res.output
    return res.stdout


def test_every_command_is_walked() -> None:
    names = {" ".join(p) for p in COMMANDS}
    assert set(UNITS) <= names and "reproduce" in names and "plant show" in names


@pytest.mark.parametrize("path", COMMANDS, ids=[" ".join(p) for p in COMMANDS])
def test_help_ends_with_an_example(path: list[str]) -> None:
    text = _help(path)
    assert "Example: servokit " + path[0] in text, text
    assert text.rstrip().splitlines()[-1].strip(), text


@pytest.mark.parametrize("name", UNITS)
def test_help_shows_units(name: str) -> None:
    text = _help(name.split())
    for unit in UNITS[name]:
        assert unit in text, f"{unit} missing from `servokit {name} --help`"


def test_reproduce_help_lists_the_registered_cases() -> None:
    from servokit.cases import registry

    text = "".join(_help(["reproduce"]).split())  # undo line wrapping (also at hyphens)
    for name in registry():
        assert name in text, name


def test_root_help_lists_commands_in_a_learning_order() -> None:
    text = _help([])
    order = [text.index(f"  {c} ") for c in ("plant", "simulate", "seek", "reproduce")]
    assert order == sorted(order)


def test_version() -> None:
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.stdout.strip() == f"servokit {servokit.__version__}"


def test_help_imports_no_heavy_library() -> None:
    """``servokit --help`` stays fast: python-control, scipy.signal, matplotlib are lazy."""
    code = (
        "import sys; sys.argv = ['servokit', '--help']\n"
        "from servokit.cli import main\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "heavy = [m for m in ('control', 'scipy.signal', 'matplotlib.pyplot', 'sympy')"
        " if m in sys.modules]\n"
        "print('HEAVY', heavy)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=True
    )
    assert "HEAVY []" in out.stdout, out.stdout[-300:]
