"""The options layer of the ``servokit`` command line.

Each shared flag is defined here once (name, help text with unit, metavar); the one
table :data:`PARAM_FLAGS` translates the library's parameter names into the flags a user
types (the library raises errors naming its parameters, the CLI re-raises them naming
flags); :func:`harden` applies the rules every number flag obeys (finite, within the
physical range of its unit); the file arguments (plants, controllers) are checked here
before the library reads them.
"""

from __future__ import annotations

import dataclasses
import os
import re
import typing
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

#: The metavar of each kind of argument (one spelling per kind, docs/CONVENTIONS.md).
METAVAR = {"file": "FILE", "dir": "DIR", "plant": "NAME_OR_TOML", "controller": "NAME_OR_TOML"}

#: Library parameter name -> the flag a user types. The library's errors name parameters;
#: :func:`flag_names` rewrites them with this table (a command adds its own few).
PARAM_FLAGS: dict[str, str] = {
    "N_range": "--n-samples range",
    "N_max": "--n-samples-max",
    "max_terms": "the alias-sum term limit",
    "t_max": "--t-max",
    "dt": "--dt",
    "ts": "--dt",
    "Ts": "--dt",
    "n_samples": "--n-samples",
    "N": "--n-samples",
    "n_samples_max": "--n-samples-max",
    "n_freq": "--n-freq",
    "fmin": "--fmin",
    "fmax": "--fmax",
    "freq_hz": "--freq",
    "damping": "--damping",
    "settle_band": "--settle-band",
    "stroke_m": "--stroke-m",
    "accuracy_m": "--accuracy-m",
    "target": "--target",
    "duration": "--duration",
    "max_memory_mb": "--max-memory-mb",
    "seed": "--seed",
    "u_max": "--u-max",
    "slew_max": "--slew-max",
    "margin": "--margin",
    "n_variants": "--n-variants",
    "chunk_size": "--chunk-size",
    "workers": "--workers",
    "substeps": "--substeps",
}

#: Physical range of a number flag, by name: (lowest, highest, unit). A value outside is
#: refused before any work (a 1e-300 s period or a 1e300 Hz frequency is never meant).
FLAG_RANGES: dict[str, tuple[float, float, str]] = {
    "--dt": (1e-9, 1e3, "s"),
    "--duration": (0.0, 1e6, "s"),
    "--freq": (1e-6, 1e9, "Hz"),
    "--fmin": (1e-6, 1e9, "Hz"),
    "--fmax": (1e-6, 1e9, "Hz"),
    "--fs": (1e-3, 1e9, "Hz"),
    "--dt-min": (1e-9, 1e3, "s"),
    "--dt-max": (1e-9, 1e3, "s"),
    "--loop-delay": (0.0, 1e3, "s"),
    "--max-memory-mb": (1.0, 1e12, "MB"),
    "--damping": (1e-12, 1e3, "1"),
    "--zero-damping": (1e-12, 1e3, "1"),
    "--pole-damping": (1e-12, 1e3, "1"),
    "--filter-damping": (1e-12, 1e3, "1"),
    "--notch-damping": (1e-12, 1e3, "1"),
    "--notch-depth-damping": (1e-12, 1e3, "1"),
    "--settle-band": (1e-12, 1e12, "output unit"),
    "--target": (1e-12, 1e12, "output unit"),
    "--tol": (1e-15, 1.0, "1"),
    # circuit components of the self-sensing bridges (ssa): physical part values
    **{f: (1e-15, 1.0, "F") for f in ("--c", "--c1", "--c2", "--c3", "--c-pzt")},
    **{f: (1e-3, 1e12, "ohm") for f in ("--r", "--r1", "--r3")},
    "--k": (1e-6, 1e6, "1"),
    "--fs-min": (1e-6, 1e9, "Hz"),
    "--fs-max": (1e-6, 1e9, "Hz"),
    "--zero-freq": (1e-6, 1e9, "Hz"),
    "--pole-freq": (1e-6, 1e9, "Hz"),
    "--filter-freq": (1e-6, 1e9, "Hz"),
    "--band-limit": (1e-6, 1e9, "Hz"),
    "--freq-step": (1e-6, 1e9, "Hz"),
}

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
ControllerOpt = Annotated[
    str,
    typer.Option(
        "--controller", help="book controller (e.g. eq-4.69) or .toml file", metavar="NAME_OR_TOML"
    ),
]
OutDirOpt = Annotated[str, typer.Option("--out", help="output directory", metavar="DIR")]
# the seek family (seek, sweep): one definition of each flag they share
TargetOpt = Annotated[
    float,
    typer.Option("--target", "--tracks", help="seek distance [output unit; track for HDDs]"),
]
DelayOpt = Annotated[
    bool,
    typer.Option(
        "--delay/--no-delay",
        help="simulate the plant's input delay (--no-delay: the book's §2.4 convention)",
    ),
]
SlewMaxOpt = Annotated[
    float | None,
    typer.Option(
        "--slew-max",
        help="slew limit |u[k]-u[k-1]| [plant input unit per sample] (seek: of the robust "
        "design; simulate, sweep: the actuator's)",
    ),
]
NSamplesMaxOpt = Annotated[
    int, typer.Option("--n-samples-max", help="largest N tried by --n-samples auto [count]")
]


def u_max_option(use: str) -> Any:
    """The ``--u-max`` option (input limit |u| [plant input unit]); ``use`` says what the
    command does with it (a design constraint, a clip of the applied input).

    Parameters
    ----------
    use : str
        The command's use of the limit, appended to the help text.

    Returns
    -------
    typing.Annotated
        The annotated option type, default ``None`` (no limit).
    """
    return Annotated[
        float | None,
        typer.Option("--u-max", help=f"input limit |u| [plant input unit, A for hdd-benchmark]"
                     f"; {use}"),
    ]  # fmt: skip


@dataclass(frozen=True)
class Output:
    """The output flags every computing command shares: ``--plot FILE`` and ``--json``."""

    plot: Path | None
    json_out: bool

    @classmethod
    def checked(cls, plot: Path | None, json_out: bool) -> Output:
        """The flags with ``--plot`` checked before any work (directory/extension refused).

        Parameters
        ----------
        plot : Path or None
            ``--plot``.
        json_out : bool
            ``--json``.

        Returns
        -------
        Output
        """
        return cls(plot_target(plot), json_out)


def plot_target(path: Path | None) -> Path | None:
    """Validate a ``--plot`` path before any work (directory/extension refused)."""
    from servokit.errors import check_plot_path

    return None if path is None else check_plot_path(path)


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


def load_controller_data(value: str, dt: float | None = None, flag: str = "--controller") -> Any:
    """:func:`load_controller` as a numpy-only
    :class:`~servokit.models.rational.RationalTF` (python-control left unloaded)."""
    _check_named_file(value, flag, "book name or a .toml controller file")
    from servokit.models import get_discrete_rational

    with flag_names({}, prefix=f"{flag}: "):
        return get_discrete_rational(value, dt)


@contextmanager
def flag_names(mapping: Mapping[str, str] | None = None, prefix: str = "") -> Iterator[None]:
    """Re-raise library errors with Python parameter names replaced by the CLI flags.

    ``mapping`` maps a parameter name (``"n_samples"``) to the flag the user typed
    (``"--n-samples"``); without one the shared table :data:`PARAM_FLAGS` is used; ``prefix`` is put
    before the message (e.g. the flag and value). Filesystem errors become a
    :class:`~servokit.errors.ServokitValueError` as well.
    """
    from servokit.errors import ServokitError, ServokitTypeError, ServokitValueError

    # the shared table only when the command gives none: a given mapping is exact (a
    # plant-file error such as "field 'modes[0].damping'" must keep its words)
    table = PARAM_FLAGS if mapping is None else dict(mapping)
    try:
        yield
    except ServokitError as exc:
        msg = str(exc)
        for name in sorted(table, key=len, reverse=True):
            msg = re.sub(rf"(?<![\w-]){re.escape(name)}(?![\w-])", table[name], msg)
        cls = ServokitTypeError if isinstance(exc, TypeError) else ServokitValueError
        raise cls(prefix + msg) from None
    except OSError as exc:
        where = exc.filename if exc.filename is not None else ""
        raise ServokitValueError(f"{prefix}{where}: {exc.strerror or exc}") from None


def _numeric_kind(param: Any) -> type | None:
    """``float`` or ``int`` if the option's annotation is that number (or ``| None``)."""
    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    kinds = set(typing.get_args(ann) or (ann,)) - {type(None)}
    return kinds.pop() if len(kinds) == 1 and kinds <= {int, float} else None


def _physical_mb() -> float:
    """Physical memory of this machine [MB] (a ``--max-memory-mb`` above it is refused)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (ValueError, OSError, AttributeError):
        return float("inf")


def _number_callback(original: Any) -> Any:
    """Wrap an option callback: refuse NaN and +-inf for a number flag, and a value outside
    :data:`FLAG_RANGES` (zero passes where it means "automatic", below a lowest of 1)."""

    def check(ctx: Any, param: Any, value: Any) -> Any:
        values = value if isinstance(value, list | tuple) else (value,)
        for v in values:
            if isinstance(v, float) and not np.isfinite(v):
                raise typer.BadParameter(f"must be a finite number (got {v})")
            flag = max(param.opts, key=len)
            lo, hi, unit = FLAG_RANGES.get(flag, (-np.inf, np.inf, ""))
            zero_ok = v == 0 and lo < 1
            if isinstance(v, int | float) and not lo <= abs(v) <= hi and not zero_ok:
                raise typer.BadParameter(f"|{v:g}| is outside {lo:g}..{hi:g} {unit}")
            if param.name == "max_memory_mb" and v is not None and v > _physical_mb():
                raise typer.BadParameter(
                    f"{v:g} MB is more than this machine's {_physical_mb():.0f} MB of memory"
                )
        return original(ctx, param, value) if original is not None else value

    return check


def harden(root: Any) -> Any:
    """Apply the number-flag rules to every option of the click command tree ``root``.

    One rule for every command, present and future (docs/CONVENTIONS.md): a flag that
    takes a number takes a finite one, within :data:`FLAG_RANGES` where its name is listed;
    a command needing "no limit" offers a switch.
    """
    stack = [root]
    while stack:
        cmd = stack.pop()
        stack += list(getattr(cmd, "commands", {}).values())
        for param in cmd.params:
            _metavar(param)
            _plain_help(param)
            kind = _numeric_kind(param)
            if kind is None:
                continue
            param.callback = _number_callback(param.callback)
            _plain_numbers(param, kind)
    return root


def _plain_numbers(param: Any, kind: type) -> None:
    """One spelling rule for every number flag, before typer converts the text: an integer
    flag takes ``40``, ``40.0`` or ``4e1`` (:func:`~servokit.errors.parse_int`), and a
    number that does not parse is refused in plain words, naming the flag."""
    original = param.process_value

    def process_value(ctx: Any, value: Any) -> Any:
        from servokit.errors import ServokitValueError, parse_int

        if isinstance(value, str):
            flag = max(param.opts, key=len)
            try:
                value = str(parse_int(flag, value)) if kind is int else _plain_float(value)
            except (ServokitValueError, ValueError):
                what = "an integer" if kind is int else "a number"
                raise typer.BadParameter(f"must be {what} (got {value!r})", ctx, param) from None
        return original(ctx, value)

    param.process_value = process_value


def _plain_float(text: str) -> str:
    """``text`` as Python reads a float (``1e-3``, ``nan``, ``1_0``), else ValueError."""
    return repr(float(text))


def _plain_help(param: Any) -> None:
    """Keep typer's internals out of the help: ``<int range>``/``x>=1.0`` become ``<int>``,
    ``<list[str]>`` becomes ``<str>`` (the option is repeatable; its help says so)."""
    kind = _numeric_kind(param)
    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    inner = [a for a in typing.get_args(ann) if a is not type(None)]
    if kind is not None:
        param.display_type = lambda ctx, _k=kind.__name__: f"<{_k}>"
        param.display_type_rich = param.display_type
        param._get_number_range_help_str = lambda: None
    elif typing.get_origin(ann) is list and inner:
        name = getattr(inner[0], "__name__", "str")
        param.display_type = lambda ctx, _k=name: f"<{_k}>"
        param.display_type_rich = param.display_type


def _metavar(param: Any) -> None:
    """One metavar per kind of argument (:data:`METAVAR`): files, directories, names."""
    if getattr(param, "metavar", None) or not getattr(param, "opts", None):
        return
    ann = getattr(getattr(param, "type_descriptor", None), "annotation", None)
    if param.name in ("plant", "controller", "loop_plant"):
        param.metavar = METAVAR["plant"]
    elif ann is not None and "Path" in str(ann):
        param.metavar = METAVAR["dir"] if param.name == "out" else METAVAR["file"]


def old_name(flag: str, annotation: Any = float) -> Any:
    """A hidden option keeping a renamed flag working (deprecated; see :func:`renamed`).

    Parameters
    ----------
    flag : str
        The old flag.
    annotation : type
        Its value type.

    Returns
    -------
    typing.Annotated
        The annotated option type, default ``None``.
    """
    return Annotated[annotation | None, typer.Option(flag, hidden=True)]


def renamed(value: Any, old: Any, *, new_flag: str, old_flag: str, default: Any = None) -> Any:
    """The value of a renamed flag: the new flag's, else the deprecated old flag's (warned).

    Parameters
    ----------
    value : object
        The new flag's value.
    old : object
        The old (hidden) flag's value, ``None`` if not given.
    new_flag, old_flag : str
        The two names.
    default : object
        The new flag's default (both given -> refused).

    Returns
    -------
    object
    """
    import warnings

    from servokit.errors import ServokitValueError

    if old is None:
        return value
    if value != default:
        raise ServokitValueError(f"give {new_flag} only ({old_flag} is its deprecated old name)")
    # shown as one "servokit: warning:" line after a successful run (never before an error)
    warnings.warn(f"{old_flag} is deprecated; use {new_flag}", FutureWarning, stacklevel=2)
    return old


def given_on_command_line(name: str) -> bool:
    """Whether the user typed the option whose Python parameter is ``name`` (not a default).

    Parameters
    ----------
    name : str
        The command function's parameter name.

    Returns
    -------
    bool
    """
    import typer._click.core as click_core
    from typer._click.globals import get_current_context

    ctx = get_current_context(silent=True)
    if ctx is None:
        return False
    return ctx.get_parameter_source(name) == click_core.ParameterSource.COMMANDLINE


def refuse_inapplicable(
    choice_flag: str, choice: str, applies: Mapping[str, tuple[str, tuple[str, ...]]]
) -> None:
    """Refuse flags the user gave that the chosen method ignores (never silently drop them).

    Parameters
    ----------
    choice_flag : str
        The flag that chose (``"--method"``).
    choice : str
        Its value.
    applies : mapping
        Parameter name -> (its flag, the choices it applies to).
    """
    from servokit.errors import ServokitValueError

    for name, (flag, choices) in applies.items():
        if choice not in choices and given_on_command_line(name):
            raise ServokitValueError(
                f"{flag} applies only to {choice_flag} {'/'.join(choices)}, not {choice}; "
                f"drop {flag}"
            )


VariationsOpt = Annotated[
    Path | None,
    typer.Option(
        "--variations",
        help='variation file (TOML, kind = "variations"): the plant set; its nominal is '
        "the file's plant, else --plant",
        metavar="FILE",
    ),
]

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
    ``fallback`` is the nominal plant when the file names none.  Errors name ``flag``.

    A file that names its plant and a ``--plant`` typed on the command line must agree
    (gain, modes and delay; names aside): otherwise one of the two would be silently
    ignored and the results labelled with the other.
    """
    from servokit.errors import ServokitValueError, check_input_file

    path = check_input_file(value, flag)
    from servokit.models import read_variations

    with flag_names({}, prefix=f"{flag} "):
        vset = read_variations(path, fallback=fallback)
    # the reader returns ``fallback`` itself when the file names no plant
    if fallback is not None and vset.nominal is not fallback and given_on_command_line("plant"):
        if _physics(vset.nominal) != _physics(fallback):
            raise ServokitValueError(
                f"--plant {_typed('plant', fallback.name)} and the plant named in {flag} "
                f"{value} ({vset.nominal.name}) differ; give the same plant to both, or "
                "remove the file's plant = line"
            )
    return vset


def _physics(plant: Any) -> Any:
    """A plant's gain, delay and modes (in frequency order), without its name and source:
    the same plant whatever its file calls it or in which order it lists its modes."""
    modes = tuple(sorted(plant.modes, key=lambda m: (m.freq_hz, m.damping, m.residue)))
    return dataclasses.replace(plant, name="", source="", modes=modes)


def _typed(name: str, default: str) -> str:
    """The value of the command's parameter ``name`` as the user typed it (``default``
    outside a command)."""
    from typer._click.globals import get_current_context

    ctx = get_current_context(silent=True)
    value = None if ctx is None else ctx.params.get(name)
    return default if value is None else str(value)


# ---- size of a plant's discrete state-space model, estimated before it is built ----
#: N x N work arrays a dense state-space step holds at once (the ZOH exponential, the
#: closed-loop matrices, a Lyapunov or Schur solve).
DENSE_COPIES = 16
#: Largest N^3 of one dense state-space step: LAPACK at ~1e9 flop/s, about a minute.
MAX_DENSE_WORK = 6e10


def discrete_states(plant: Any, dt: float, controller_states: int = 0) -> int:
    """States of ``plant`` discretised at ``dt`` (modes, delay states) plus a controller's.

    Parameters
    ----------
    plant : ModalPlant
        The plant (its ``order`` and ``delay`` [s]).
    dt : float
        Sampling period [s].
    controller_states : int
        States the controller adds.

    Returns
    -------
    int
        Estimated state count, known before anything is built.
    """
    order = int(getattr(plant, "order", 0) or 0)
    delay = float(getattr(plant, "delay", 0.0) or 0.0)
    delay_states = int(np.ceil(delay / dt)) + 1 if delay > 0 and dt > 0 else 0
    return order + delay_states + int(controller_states)


def controller_states(controller: Any) -> int:
    """State count of a python-control controller (transfer function or state space)."""
    n = getattr(controller, "nstates", None)
    if n is not None:
        return int(n)
    den = getattr(controller, "den", None)
    return max(len(np.atleast_1d(den[0][0])) - 1, 0) if den is not None else 0


def check_state_size(n_states: int, *, what: str, max_memory_mb: float) -> None:
    """Refuse a loop of ``n_states`` whose dense N x N steps exceed the memory or work limit.

    Parameters
    ----------
    n_states : int
        States of the discrete loop (:func:`discrete_states`).
    what : str
        The argument that sets the size, as typed (``"--plant big.toml"``).
    max_memory_mb : float
        The ``--max-memory-mb`` limit [MB].
    """
    from servokit.errors import check_memory, check_work

    n = float(n_states)
    check_memory(
        DENSE_COPIES * 8.0 * n * n,
        what=f"{what} ({n_states} states)",
        max_memory_mb=max_memory_mb,
    )
    check_work(
        n**3, what=f"{what} ({n_states} states)", limit=MAX_DENSE_WORK, about="about a minute"
    )
