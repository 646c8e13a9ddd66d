"""The typer application shared by every ``servokit`` sub-command module.

Each module of :mod:`servokit.cli` registers its commands on :data:`app` (or adds a
sub-typer to it); :func:`main` discovers them, runs the command and turns user
mistakes into one line on stderr with exit status 2.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import signal
import sys
import threading
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
    "plant", "simulate",
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
    context_settings={"help_option_names": ["-h", "--help"]},
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
PlantOpt = Annotated[
    str, typer.Option("--plant", help="catalogue name or .toml plant file", metavar="NAME_OR_TOML")
]


def _numeric_kind(param: Any) -> type | None:
    """``float`` or ``int`` if the option's annotation is that number (or ``| None``)."""
    import typing

    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    kinds = set(typing.get_args(ann) or (ann,)) - {type(None)}
    return kinds.pop() if len(kinds) == 1 and kinds <= {int, float} else None


def _physical_mb() -> float:
    """Physical memory of this machine [MB] (a ``--max-memory-mb`` above it is refused)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (ValueError, OSError, AttributeError):
        return float("inf")


def _finite_callback(original: Any) -> Any:
    """Wrap an option callback: refuse NaN and +-inf for a number flag, naming it."""

    def check(ctx: Any, param: Any, value: Any) -> Any:
        values = value if isinstance(value, list | tuple) else (value,)
        for v in values:
            if isinstance(v, float) and not np.isfinite(v):
                raise typer.BadParameter(f"must be a finite number (got {v})")
            if param.name == "max_memory_mb" and v is not None and v > _physical_mb():
                raise typer.BadParameter(
                    f"{v:g} MB is more than this machine's {_physical_mb():.0f} MB of memory"
                )
        return original(ctx, param, value) if original is not None else value

    return check


def build_command() -> Any:
    """The click command tree of :data:`app`, every number flag refusing NaN and inf.

    One rule for every command, present and future (docs/CONVENTIONS.md): a flag that
    takes a number takes a finite one; a command needing "no limit" offers a switch.
    """
    import typer.main

    root = typer.main.get_command(app)
    stack = [root]
    while stack:
        cmd = stack.pop()
        stack += list(getattr(cmd, "commands", {}).values())
        for param in cmd.params:
            if _numeric_kind(param) is float:
                param.callback = _finite_callback(param.callback)
    return root


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


def _check_named_file(value: str, flag: str, kind: str) -> None:
    """Refuse an empty name; check a file argument before the library reads it.

    A name that is a path (exists, or ends ``.toml``/``.json``) must be a regular text file
    of bounded size, encoding and nesting (:func:`servokit._io.read_input_text`), so a FIFO,
    a device or a 1000-deep file fails here with one line naming ``flag`` and the file.
    """
    from servokit._io import read_input_text
    from servokit.errors import ServokitValueError

    if value.strip() in ("", "."):
        raise ServokitValueError(f"{flag} {value!r}: give a {kind}")
    path = Path(value)
    if os.path.lexists(path) or path.suffix.lower() in (".toml", ".json"):
        read_input_text(path, flag, plain_utf8=True)  # the model reader decodes UTF-8


def load_plant(value: str, flag: str = "--plant") -> Any:
    """A catalogue plant or plant file named on the command line; errors name ``flag``."""
    _check_named_file(value, flag, "catalogue name or a .toml plant file")
    from servokit.models import get_plant

    with flag_names({}, prefix=f"{flag}: "):
        return get_plant(value)


def load_controller(value: str, dt: float | None = None, flag: str = "--controller") -> Any:
    """A book controller or controller file named on the command line; errors name ``flag``."""
    _check_named_file(value, flag, "book name or a .toml controller file")
    from servokit.models import get_discrete_controller

    with flag_names({}, prefix=f"{flag}: "):
        return get_discrete_controller(value, dt)


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


#: Exit status of an interrupted run (128 + SIGINT), as a shell reports Ctrl-C.
EXIT_INTERRUPTED = 130
#: Seconds an interrupted run may spend unwinding (closing a Dask cluster, removing a
#: staging directory) before the process is ended outright.
INTERRUPT_GRACE_S = 0.5
_announced = threading.Lock()


def announce_interrupt() -> None:
    """Print the one interrupt line (once per process, whoever notices the interrupt first)
    and ignore further Ctrl-C so the unwinding is not cut short."""
    with contextlib.suppress(ValueError):  # not on the main thread: already ignored
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    if _announced.acquire(blocking=False):
        sys.stderr.write("servokit: interrupted\n")
        sys.stderr.flush()


def _kill_children() -> None:
    """SIGKILL the worker processes this process started (a local Dask cluster) and the
    multiprocessing resource tracker, so none outlives the run or prints after it."""
    import multiprocessing
    from multiprocessing import resource_tracker

    for child in multiprocessing.active_children():
        with contextlib.suppress(OSError, ValueError):
            child.kill()
    pid = getattr(getattr(resource_tracker, "_resource_tracker", None), "_pid", None)
    if pid:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def _interrupted_exit() -> None:
    """End the process now as interrupted (no cleanup, no traceback)."""
    try:
        announce_interrupt()
        _kill_children()
        _remove_stages()
    finally:
        os._exit(EXIT_INTERRUPTED)


def _remove_stages() -> None:
    """Remove the staging directories of unfinished output (the previous results stay)."""
    import shutil

    from servokit._io import ACTIVE_STAGES

    for stage in list(ACTIVE_STAGES):
        shutil.rmtree(stage, ignore_errors=True)


@contextmanager
def quiet_children() -> Iterator[None]:
    """Start worker processes (a local Dask cluster) that ignore Ctrl-C and log only errors.

    Ctrl-C in a terminal reaches the whole process group; the workers must leave the
    interrupt to this process (which closes them) instead of each printing a traceback.
    An ignored SIGINT is inherited by the children across ``exec``.
    """
    on_main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGINT) if on_main else None
    os.environ.setdefault("DASK_LOGGING__DISTRIBUTED", "error")
    try:
        import dask

        dask.config.refresh()
    except ImportError:
        pass
    if on_main:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        if on_main:
            signal.signal(signal.SIGINT, before)


def _on_sigint(signum: int, frame: Any) -> None:
    """First Ctrl-C: unwind through ``KeyboardInterrupt``; a watchdog ends the process if the
    unwinding (or a swallowed interrupt) takes longer than :data:`INTERRUPT_GRACE_S`."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not cut the cleanup
    timer = threading.Timer(INTERRUPT_GRACE_S, _interrupted_exit)
    timer.daemon = True
    timer.start()
    raise KeyboardInterrupt


def _unraisable(info: Any) -> None:
    """A ``KeyboardInterrupt`` raised inside a weakref callback or ``__del__`` is swallowed
    by Python (printed as "Exception ignored"); end the run as interrupted instead."""
    if isinstance(info.exc_value, KeyboardInterrupt):
        _interrupted_exit()
    sys.__unraisablehook__(info)


def _install_interrupt_handling() -> None:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _on_sigint)
    sys.unraisablehook = _unraisable


def main() -> None:
    """Entry point of the ``servokit`` command."""
    _install_interrupt_handling()
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
    sys.stdout.flush()
    sys.exit(code)


def _memory_message(argv: list[str]) -> str:
    flag = "--max-memory-mb"
    has = any(a == flag or a.startswith(flag + "=") for a in argv)
    return (
        "the request needs more memory than this machine (or the limit) allows; reduce the "
        + ("sizes or lower the request" if has else f"sizes (the limit is {flag})")
    )


def _run(usage: tuple[type[BaseException], ...]) -> int:
    """Run the app; return the exit status (errors printed as one line)."""
    try:
        # typer returns (not raises) the status of typer.Exit, and turns Ctrl-C into 130
        code = build_command().main(prog_name="servokit", standalone_mode=False)
        code = code if isinstance(code, int) else 0
        if code == EXIT_INTERRUPTED:
            announce_interrupt()
        return code
    except typer.Exit as exc:
        return int(exc.exit_code or 0)
    except (KeyboardInterrupt, typer.Abort):
        announce_interrupt()
        return EXIT_INTERRUPTED
    except OSError as exc:
        typer.echo(f"servokit: error: {os_error_message(exc)}", err=True)
        return 2
    except RecursionError:
        typer.echo("servokit: error: input nested too deeply to process", err=True)
        return 2
    except MemoryError:
        typer.echo(f"servokit: error: {_memory_message(sys.argv[1:])}", err=True)
        return 2
    except (ServokitError, ValueError, TypeError, OverflowError, ZeroDivisionError,
            FloatingPointError, np.linalg.LinAlgError) as exc:  # fmt: skip
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


def os_error_message(exc: OSError) -> str:
    """One line for a filesystem error, always naming the path (ENOSPC included)."""
    import errno

    where = exc.filename if exc.filename is not None else getattr(exc, "servokit_path", None)
    text = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        text += "; free space or choose another --out"
    return f"{where}: {text}" if where else text
