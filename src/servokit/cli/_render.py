"""The render layer of the ``servokit`` command line: console, JSON, progress, messages.

Commands compute data and hand it here: :func:`emit_json` for ``--json`` (stdout, nothing
else on it), :data:`console` for tables, :func:`started` and :func:`progress` for long work
(stderr), :func:`wrote` / :func:`warn` / :func:`fail` for one-line messages (stderr).
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import typer
from rich.console import Console

# piped output (make demo into a log) keeps the book-vs-servokit tables on one line each;
# a printed result line is never broken inside a value ("1.645 ms"): the terminal wraps it
console = Console(width=None if sys.stdout.isatty() else 120, soft_wrap=True)


def wrote(path: Path | str) -> None:
    """Report a written file with its real path (on stderr when stdout carries JSON)."""
    typer.echo(f"wrote {Path(path)}", err=True)


def warn(message: str) -> None:
    """One warning line on stderr."""
    typer.echo(f"servokit: warning: {message}", err=True)


#: ``SERVOKIT_PROGRESS=1`` prints the start lines of :func:`started` also when stderr is not
#: a terminal (a CI log); ``0`` never prints them. Unset: only on a terminal.
PROGRESS_ENV = "SERVOKIT_PROGRESS"


def progress_wanted() -> bool:
    """Whether start lines go to stderr: on a terminal, or as ``SERVOKIT_PROGRESS`` says.

    Off for pipes by default, as git and pip do: a script reading stderr keeps the
    one-line contract of a failed command (an error or an interrupt after the work has
    started would otherwise follow the start line).
    """
    choice = os.environ.get(PROGRESS_ENV, "").strip()
    if choice in ("0", "1"):
        return choice == "1"
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # a replaced or closed stderr
        return False


def started(command: str, message: str) -> None:
    """Say on stderr what a long command is about to do, once its arguments are valid.

    Call it after every check a user's mistake can fail and before the slow part (imports
    of scikit-learn or python-control, simulation, optimisation), so that the first output
    comes within a fraction of a second; see :func:`progress_wanted` for when it prints.

    Parameters
    ----------
    command : str
        The command as typed, e.g. ``"settle evaluate"``.
    message : str
        What is being done, with the sizes and the output, e.g. ``"25 cases -> out/"``.
    """
    progress_line(command, message)


def progress_line(command: str, message: str) -> None:
    """One line of progress on stderr, as :func:`started` (same rule for when it prints).

    Parameters
    ----------
    command : str
        The command as typed, e.g. ``"loopshape"``.
    message : str
        Where the work is, e.g. ``"step 3: lowest crossover 812.4 Hz"``.
    """
    if progress_wanted():
        typer.echo(f"{command}: {message}", err=True)


@contextmanager
def progress(total: int, description: str, *, enabled: bool = True) -> Iterator[Any]:
    """A rich progress bar on stderr; yields ``advance(n=1)``.

    Use it for work that may take more than a few seconds; it never writes to stdout, so
    ``--json`` output stays clean.
    """
    err = Console(stderr=True)
    # not on a pipe: a transient bar draws nothing there but leaves an empty line behind
    if not enabled or total <= 1 or not err.is_terminal:
        yield lambda n=1: None
        return
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeRemainingColumn(),
        console=err,
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


def ms(seconds: float | None, digits: int = 6) -> str:
    """A settling or seek time for the console: ``"0.340909 ms"``, or ``"does not settle"``
    for an unsettled (infinite or null) one -- never ``inf ms`` or a last sample.

    Parameters
    ----------
    seconds : float or None
        The time [s]; inf, NaN or None when the response never settles.
    digits : int
        Significant digits.

    Returns
    -------
    str
    """
    if seconds is None or not np.isfinite(seconds):
        return "does not settle"
    return f"{seconds * 1e3:.{digits}g} ms"
