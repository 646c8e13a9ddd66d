"""The typer application shared by every ``servokit`` sub-command module.

Each module of :mod:`servokit.cli` registers its commands on :data:`app` (or adds a
sub-typer to it); :func:`main` discovers them, runs the command and turns user
mistakes into one line on stderr with exit status 2.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console

from servokit.errors import ServokitError

app = typer.Typer(
    name="servokit",
    help="Design and analyse high-speed, high-precision motion control.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    # units are written "[s]"; rich markup would eat them (and strike the rest through)
    rich_markup_mode=None,
)
# piped output (make demo into a log) keeps the book-vs-servokit tables on one line each
console = Console(width=None if sys.stdout.isatty() else 120)


# ---- shared options: one name, one help text per concept (docs/CONVENTIONS.md) ----
JsonOpt = Annotated[
    bool, typer.Option("--json", help="machine-readable JSON on stdout (nothing else on stdout)")
]
PlotOpt = Annotated[
    Path | None,
    typer.Option("--plot", help="write the figure to this file (.png or .svg)", metavar="FILE"),
]
MaxMemoryOpt = Annotated[
    float,
    typer.Option(
        "--max-memory-mb", help="refuse requests estimated above this memory [MB]", min=1.0
    ),
]
SeedOpt = Annotated[int, typer.Option("--seed", help="random seed")]


def sub_app(name: str, help: str) -> typer.Typer:
    """Create a command group ``servokit <name> ...`` registered on :data:`app`."""
    group = typer.Typer(help=help, no_args_is_help=True, rich_markup_mode=None)
    app.add_typer(group, name=name)
    return group


def example(*lines: str) -> str:
    """Epilog text ending every ``--help`` with runnable example(s)."""
    return "Example: " + "  |  ".join(lines)


def plot_target(path: Path | None) -> Path | None:
    """Validate a ``--plot`` path before any work (directory/extension refused)."""
    from servokit.errors import check_plot_path

    return None if path is None else check_plot_path(path)


def wrote(path: Path | str) -> None:
    """Report a written file with its real path (on stderr when stdout carries JSON)."""
    typer.echo(f"wrote {Path(path)}", err=True)


def warn(message: str) -> None:
    """One warning line on stderr."""
    typer.echo(f"servokit: warning: {message}", err=True)


@contextmanager
def progress(total: int, description: str, *, enabled: bool = True) -> Iterator[Any]:
    """A rich progress bar on stderr; yields ``advance(n=1)``.

    Use it for work that may take more than a few seconds; it never writes to stdout, so
    ``--json`` output stays clean.
    """
    if not enabled or total <= 1:
        yield lambda n=1: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeRemainingColumn(),
        console=Console(stderr=True),
        transient=True,
    )
    with bar:
        task = bar.add_task(description, total=total)
        yield lambda n=1: bar.advance(task, n)


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, complex):
        return {"re": obj.real, "im": obj.imag}
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def emit_json(data: Any) -> None:
    """Print ``data`` as JSON on stdout (numpy arrays and scalars converted)."""
    typer.echo(json.dumps(_jsonable(data), indent=2))


def fail(message: str) -> None:
    """Print one line on stderr and exit with status 2."""
    typer.echo(f"servokit: error: {message}", err=True)
    raise typer.Exit(code=2)


def _usage_errors() -> tuple[type[BaseException], ...]:
    """Usage-error classes of the installed typer (own copy of click) or of click."""
    found: list[type[BaseException]] = []
    try:
        from typer.exceptions import TyperException

        found.append(TyperException)
    except ImportError:  # older typer builds on click
        pass
    try:
        import click

        found.append(click.exceptions.ClickException)
    except ImportError:
        pass
    return tuple(found)


def main() -> None:
    """Entry point of the ``servokit`` command."""
    from servokit.cli import _discover

    _discover()
    usage = _usage_errors()
    try:
        app(standalone_mode=False)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except typer.Abort:
        sys.exit(1)
    except (ServokitError, ValueError, TypeError, OSError, OverflowError, MemoryError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        typer.echo(f"servokit: error: {msg}", err=True)
        sys.exit(2)
    except usage as exc:
        text = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        if type(exc).__name__ == "NoArgsIsHelpError":  # bare `servokit` / group: show help
            typer.echo(text)
            sys.exit(0)
        typer.echo(
            f"servokit: error: {text.strip().splitlines()[0] if text.strip() else exc}", err=True
        )
        sys.exit(2)
