"""The typer application shared by every ``servokit`` sub-command module.

Each module of :mod:`servokit.cli` registers its commands on :data:`app` (or adds a
sub-typer to it); :func:`main` discovers them, runs the command and turns user
mistakes into one line on stderr with exit status 2.
"""

from __future__ import annotations

import json
import re
import sys
import warnings
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer
from rich.console import Console
from typer.core import TyperGroup

from servokit.errors import ServokitError

#: Commands listed first in ``servokit --help``, in the order a new user meets them;
#: commands not named here follow alphabetically.
COMMAND_ORDER = (
    # models and simulation, then the book's chapters 2-6, then output
    "plant", "fit", "simulate",
    "feedforward", "seek", "sweep",
    "switching",
    "sensitivity", "unobservable", "srs", "identify",
    "filter", "margins", "dual-stage", "ssa",
    "limits", "settle",
    "export", "reproduce",
)  # fmt: skip


class _OrderedGroup(TyperGroup):
    def list_commands(self, ctx: Any) -> list[str]:
        names = super().list_commands(ctx)
        rank = {name: i for i, name in enumerate(COMMAND_ORDER)}
        return sorted(names, key=lambda n: (rank.get(n, len(rank)), n))


app = typer.Typer(
    name="servokit",
    cls=_OrderedGroup,
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
DtOpt = Annotated[float, typer.Option("--dt", help="sampling (hold) period [s]")]
NSamplesOpt = Annotated[int, typer.Option("--n-samples", help="number of samples [count]")]
NFreqOpt = Annotated[int, typer.Option("--n-freq", help="number of frequency points [count]")]
FminOpt = Annotated[float, typer.Option("--fmin", help="lowest frequency [Hz]")]
FmaxOpt = Annotated[float, typer.Option("--fmax", help="highest frequency [Hz]")]
FreqOpt = Annotated[float, typer.Option("--freq", help="oscillation frequency [Hz]")]
DampingOpt = Annotated[float, typer.Option("--damping", help="damping ratio [1]")]
DurationOpt = Annotated[float, typer.Option("--duration", help="simulated time [s]")]
SettleBandOpt = Annotated[
    float,
    typer.Option("--settle-band", help="settling band half-width around the target [output unit]"),
]
VariationsOpt = Annotated[
    Path | None,
    typer.Option(
        "--variations",
        help='variation file (TOML, kind = "variations"): the plant set; its nominal is '
        "the file's plant, else --plant",
        metavar="FILE",
    ),
]
PlantOpt = Annotated[
    str, typer.Option("--plant", help="catalogue name or .toml plant file", metavar="NAME_OR_TOML")
]


def _print_version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            v = version("servokit")
        except PackageNotFoundError:  # run from a source tree without installing
            from servokit import __version__ as v
        typer.echo(f"servokit {v}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_print_version, is_eager=True, help="print the version and exit"
        ),
    ] = False,
) -> None:
    """Design and analyse high-speed, high-precision motion control."""


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


def load_plant(value: str, flag: str = "--plant") -> Any:
    """A catalogue plant or plant file named on the command line; errors name ``flag``."""
    from servokit.errors import ServokitValueError

    if value.strip() in ("", "."):
        raise ServokitValueError(f"{flag} {value!r}: give a catalogue name or a .toml plant file")
    from servokit.models import get_plant

    if Path(value).is_dir():
        raise ServokitValueError(f"{flag} {value} is a directory; give a .toml plant file")
    with flag_names({}, prefix=f"{flag}: "):
        return get_plant(value)


def load_controller(value: str, dt: float | None = None, flag: str = "--controller") -> Any:
    """A book controller or controller file named on the command line; errors name ``flag``."""
    from servokit.errors import ServokitValueError

    if value.strip() in ("", ".") or Path(value).is_dir():
        raise ServokitValueError(f"{flag} {value!r}: give a book name or a .toml controller file")
    from servokit.models import get_discrete_controller

    with flag_names({}, prefix=f"{flag}: "):
        return get_discrete_controller(value, dt)


#: Most corner plants a command builds from ``--variations`` (3^7: seven ranges, 3 levels).
MAX_CORNERS = 2187


def variation_corners(vset: Any, flag: str = "--variations") -> list:
    """Every corner of a variation set (nominal first), refused above :data:`MAX_CORNERS`."""
    from servokit.errors import ServokitValueError

    if vset.n_corners > MAX_CORNERS:
        raise ServokitValueError(
            f"{flag}: {vset.n_corners} corner plants, above {MAX_CORNERS}; give fewer ranges "
            "(or use servokit sweep for Monte-Carlo sets)"
        )
    return [p.replace(name=f"{vset.name} corner {i}") for i, p in enumerate(vset.corners())]


def load_variations(value: Path | str, fallback: Any = None, flag: str = "--variations") -> Any:
    """A variation file named on the command line (:func:`~servokit.models.read_variations`);
    ``fallback`` is the nominal plant when the file names none.  Errors name ``flag``."""
    from servokit.errors import check_input_file

    path = check_input_file(value, flag)
    from servokit.models import read_variations

    with flag_names({}, prefix=f"{flag} "):
        return read_variations(path, fallback=fallback)


@contextmanager
def flag_names(mapping: Mapping[str, str], prefix: str = "") -> Iterator[None]:
    """Re-raise library errors with Python parameter names replaced by the CLI flags.

    ``mapping`` maps a parameter name (``"n_samples"``) to the flag the user typed
    (``"--n-samples"``); ``prefix`` is put before the message (e.g. the flag and value).
    Filesystem errors become a :class:`~servokit.errors.ServokitValueError` as well.
    """
    from servokit.errors import ServokitError, ServokitTypeError, ServokitValueError

    try:
        yield
    except ServokitError as exc:
        msg = str(exc)
        for name, flag in mapping.items():
            msg = re.sub(rf"(?<![\w-]){re.escape(name)}(?![\w-])", flag, msg)
        cls = ServokitTypeError if isinstance(exc, TypeError) else ServokitValueError
        raise cls(prefix + msg) from None
    except OSError as exc:
        where = exc.filename if exc.filename is not None else ""
        raise ServokitValueError(f"{prefix}{where}: {exc.strerror or exc}") from None


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
    # numpy/matplotlib warnings are held back: on an error only the one error line shows
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        code = _run(usage)
    if code == 0:
        for w in caught:
            warn(str(w.message).splitlines()[0])
    sys.exit(code)


def _run(usage: tuple[type[BaseException], ...]) -> int:
    """Run the app; return the exit status (errors printed as one line)."""
    try:
        app(standalone_mode=False)
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except typer.Abort:
        return 1
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename is not None else ""
        typer.echo(f"servokit: error: {where}{exc.strerror or exc}", err=True)
        return 2
    except (ServokitError, ValueError, TypeError, OverflowError, MemoryError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        typer.echo(f"servokit: error: {msg}", err=True)
        return 2
    except usage as exc:
        text = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        if type(exc).__name__ == "NoArgsIsHelpError":  # bare `servokit` / group: show help
            typer.echo(text)
            return 0
        typer.echo(
            f"servokit: error: {text.strip().splitlines()[0] if text.strip() else exc}", err=True
        )
        return 2
    return 0
