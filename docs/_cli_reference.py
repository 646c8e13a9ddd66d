"""Write the command-line reference page (every command's ``--help``) for the Sphinx build."""

from __future__ import annotations

from pathlib import Path


def _walk(cmd, path: list[str]):
    """Yield (path, command) for every leaf command of the click tree, in help order."""
    subs = getattr(cmd, "commands", None)
    if not subs:
        yield path, cmd
        return
    for name in sorted(subs):
        yield from _walk(subs[name], [*path, name])


def write_cli_reference(target: Path) -> None:
    """Render ``servokit ... --help`` of every command into one Markdown page."""
    import typer
    from typer.testing import CliRunner

    from servokit.cli import _discover
    from servokit.cli._app import app

    _discover()
    root = typer.main.get_command(app)
    runner = CliRunner()
    parts = [
        "# Command-line reference\n",
        "Generated from the command tree by `make docs`: every command's `--help`.\n",
    ]
    for path, _ in _walk(root, []):
        res = runner.invoke(app, [*path, "--help"], terminal_width=100)
        parts.append(f"## servokit {' '.join(path)}\n\n```text\n{res.stdout.rstrip()}\n```\n")
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text("\n".join(parts), encoding="utf-8")
