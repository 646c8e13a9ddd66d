"""Thin commands (issue 19): a command body is flags -> request -> library call -> render.

Counted with ``ast``: the body of every function registered as a command (decorated
``@<app>.command(...)``), docstring excluded, is at most :data:`LIMIT` lines. Commands
written before the limit are listed in :data:`OVER` with their length today: they may
only shrink (and leave the list when they fit); a new command must fit.
"""

from __future__ import annotations

import ast
from pathlib import Path

CLI = Path(__file__).resolve().parents[1] / "src" / "servokit" / "cli"
LIMIT = 40
#: command function -> body lines today (to be split into options/request/render)
OVER: dict[str, int] = {}  # empty: every command fits


def _is_command(fn: ast.FunctionDef) -> bool:
    for dec in fn.decorator_list:
        call = dec.func if isinstance(dec, ast.Call) else dec
        if isinstance(call, ast.Attribute) and call.attr == "command":
            return True
    return False


def command_bodies() -> dict[str, int]:
    """Body length in lines of every command function of servokit.cli."""
    found = {}
    for path in sorted(CLI.glob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and _is_command(node):
                body = node.body
                if body and isinstance(body[0], ast.Expr) and isinstance(
                    getattr(body[0], "value", None), ast.Constant
                ):
                    body = body[1:]  # the docstring
                lines = body[-1].end_lineno - body[0].lineno + 1 if body else 0
                found[f"{path.stem}.{node.name}"] = lines
    return found


def test_command_bodies_are_short() -> None:
    bodies = command_bodies()
    assert len(bodies) >= 35  # every command is seen
    too_long = {
        name: n for name, n in bodies.items() if n > max(LIMIT, OVER.get(name, LIMIT))
    }
    assert not too_long, f"command bodies over {LIMIT} lines (split them): {too_long}"


def test_the_over_list_only_shrinks() -> None:
    bodies = command_bodies()
    stale = {name for name in OVER if bodies.get(name, 0) <= LIMIT}
    assert not stale, f"now within {LIMIT} lines: remove from OVER: {sorted(stale)}"
