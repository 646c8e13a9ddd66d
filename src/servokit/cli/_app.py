"""The typer application shared by every ``servokit`` sub-command module.

Each module of :mod:`servokit.cli` registers its commands on :data:`app` (or adds a
sub-typer to it); :func:`main` discovers them, runs the command and turns user
mistakes into one line on stderr with exit status 2.
"""

from __future__ import annotations

import sys
import warnings
from typing import Annotated, Any

import numpy as np
import typer
from typer.core import TyperGroup

from servokit.cli._options import (  # noqa: F401  (re-exported: one import for commands)
    MAX_CORNERS,
    ControllerOpt,
    DampingOpt,
    DtOpt,
    DurationOpt,
    FmaxOpt,
    FminOpt,
    FreqOpt,
    JsonOpt,
    MaxMemoryOpt,
    NFreqOpt,
    NSamplesOpt,
    OutDirOpt,
    PlantOpt,
    PlotOpt,
    SeedOpt,
    SettleBandOpt,
    VariationsOpt,
    flag_names,
    harden,
    load_controller,
    load_plant,
    load_variations,
    plot_target,
    variation_corners,
)
from servokit.cli._render import (  # noqa: F401
    console,
    emit_json,
    fail,
    progress,
    progress_line,
    progress_wanted,
    started,
    warn,
    wrote,
)
from servokit.cli._signals import (  # noqa: F401
    EXIT_INTERRUPTED,
    announce_interrupt,
    quiet_children,
)
from servokit.cli._signals import install as _install_interrupt_handling
from servokit.errors import ServokitError

#: Commands listed first in ``servokit --help``, in the order a new user meets them;
#: commands not named here follow alphabetically.
COMMAND_ORDER = (
    # models and simulation, then the book's chapters 2-6, then output
    "plant", "fit", "simulate",
    "feedforward", "seek", "sweep",
    "switching",
    "sensitivity", "unobservable", "srs", "identify",
    "filter", "margins", "loopshape", "dual-stage", "ssa",
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


def build_command() -> Any:
    """The click command tree of :data:`app` with the number-flag rules applied."""
    import typer.main

    return harden(typer.main.get_command(app))


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
    _install_interrupt_handling()
    try:  # Ctrl-C may land anywhere: the command's imports, the run, the last warning
        code = _interruptible(_main)
    except KeyboardInterrupt:
        announce_interrupt()
        code = EXIT_INTERRUPTED
    sys.exit(code)


def _main() -> int:
    """Import the command's module, run it; the exit status."""
    from servokit.cli import _discover

    _discover(sys.argv[1:])
    usage = _usage_errors()
    # numpy/matplotlib warnings are held back: on an error only the one error line shows
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        code = _run(usage)
    if code == 0:
        for w in caught:
            warn(str(w.message).splitlines()[0])
    sys.stdout.flush()
    return code


def _memory_message(argv: list[str]) -> str:
    flag = "--max-memory-mb"
    has = any(a == flag or a.startswith(flag + "=") for a in argv)
    return "the request needs more memory than this machine (or the limit) allows; reduce the " + (
        "sizes or lower the request" if has else f"sizes (the limit is {flag})"
    )


def _run(usage: tuple[type[BaseException], ...]) -> int:
    """Run the app; return the exit status (errors printed as one line)."""
    try:
        # typer returns (not raises) the status of typer.Exit, and turns Ctrl-C into 130
        code = _interruptible(build_command().main, prog_name="servokit", standalone_mode=False)
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
        from servokit.cli._hints import with_input_hint

        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        msg = with_input_hint(internal_names_to_flags(msg), sys.argv[1:])
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


def _interruptible(func: Any, *args: Any, **kwargs: Any) -> Any:
    """``func(*args, **kwargs)``; an exception caused by Ctrl-C is raised as the interrupt.

    Python wraps an exception raised by ``__set_name__`` while a class is made (3.11:
    ``RuntimeError: Error calling __set_name__``), so a Ctrl-C landing while matplotlib
    imports arrived as a RuntimeError: a traceback and exit 1 instead of 130.
    """
    try:
        return func(*args, **kwargs)
    except Exception as exc:
        if from_interrupt(exc):
            raise KeyboardInterrupt from exc
        raise


def from_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` was caused by a ``KeyboardInterrupt`` (in the chain of causes and
    contexts a traceback would show).

    Parameters
    ----------
    exc : BaseException

    Returns
    -------
    bool
    """
    seen: set[int] = set()
    link: BaseException | None = exc
    while link is not None and id(link) not in seen:
        if isinstance(link, KeyboardInterrupt):
            return True
        seen.add(id(link))
        # the chain a traceback shows: the cause, else the context unless suppressed
        if link.__cause__ is not None:
            link = link.__cause__
        else:
            link = None if link.__suppress_context__ else link.__context__
    return False


def internal_names_to_flags(message: str) -> str:
    """Rewrite library parameter names that escaped a command's own translation.

    Only names that cannot be English words are replaced (those with an underscore or a
    capital, e.g. ``n_samples``, ``N_range``); a plain word such as "target" is left alone,
    and so is a quoted name: ``'freq_hz'`` is a column of the user's file, not a parameter.
    """
    import re

    from servokit.cli._options import PARAM_FLAGS

    for name in sorted(PARAM_FLAGS, key=len, reverse=True):
        if "_" in name or name != name.lower() or name in ("workers", "substeps"):
            # not after a dot: "qM.N" or "modes[0].freq_hz" name a format or a file's field
            pattern = rf"(?<![\w'.-]){re.escape(name)}(?![\w'-])"
            message = re.sub(pattern, PARAM_FLAGS[name], message)
    return message


def os_error_message(exc: OSError) -> str:
    """One line for a filesystem error, always naming the path (ENOSPC included)."""
    import errno

    where = exc.filename if exc.filename is not None else getattr(exc, "servokit_path", None)
    text = exc.strerror or str(exc)
    if exc.errno == errno.ENOSPC:
        text += "; free space or choose another --out"
    return f"{where}: {text}" if where else text
