"""Exception types for user mistakes.

Every error a user can cause derives from :class:`ServokitError` and from the
built-in ``ValueError`` or ``TypeError``, so callers may catch either.  The
message names the offending argument and says how to fix it; the CLI prints it
as one line and exits with status 2.
"""

from __future__ import annotations

__all__ = [
    "ServokitError",
    "ServokitValueError",
    "ServokitTypeError",
    "check_finite",
    "check_positive",
    "check_count",
    "parse_int",
    "check_memory",
    "check_plot_path",
    "check_range",
    "check_work",
    "check_out_dir",
    "check_input_file",
    "path_errors",
    "DEFAULT_MAX_MEMORY_MB",
]

import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

#: Memory one request may allocate unless the user raises it (``--max-memory-mb``).
DEFAULT_MAX_MEMORY_MB = 2000.0


class ServokitError(Exception):
    """Base class of every error servokit raises for bad input."""


class ServokitValueError(ServokitError, ValueError):
    """An argument has the right type but an unusable value."""


class ServokitTypeError(ServokitError, TypeError):
    """An argument has the wrong type."""


def check_finite(name: str, value: object) -> np.ndarray:
    """Return ``value`` as a float array, or raise naming ``name`` if it holds NaN/inf.

    Parameters
    ----------
    name : str
        The argument's name as the user knows it (a flag such as ``"--ts"``), used in the
        error message.
    value : array_like
        Scalar or array convertible to float.

    Returns
    -------
    numpy.ndarray
        ``value`` as a float array (0-d for a scalar).

    Raises
    ------
    ServokitValueError
        If any element is NaN or infinite.
    """
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ServokitValueError(f"{name} must be finite (got NaN or inf); pass finite numbers")
    return arr


def check_positive(name: str, value: object, unit: str = "") -> float:
    """Return ``value`` as a float, or raise naming ``name`` unless it is finite and > 0.

    Parameters
    ----------
    name : str
        The argument's name (flag), used in the error message.
    value : float
        Scalar to check.
    unit : str
        Unit appended to the "> 0" requirement in the message (``"s"``, ``"Hz"``); empty
        for none.

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    ServokitValueError
        If ``value`` is NaN, infinite or not > 0.
    """
    v = float(check_finite(name, value))
    if v <= 0:
        raise ServokitValueError(f"{name} must be > 0{' ' + unit if unit else ''} (got {v})")
    return v


def check_count(name: str, value: object, *, lo: int = 1, hi: int | None = None) -> int:
    """Return ``value`` as an int in ``[lo, hi]``, or raise naming ``name`` and the range.

    Parameters
    ----------
    name : str
        The argument's name (flag), used in the error message.
    value : int or float
        A number with an integral value (``3`` or ``3.0``; not ``3.5``, NaN or inf).
    lo : int
        Smallest accepted value (inclusive).
    hi : int, optional
        Largest accepted value (inclusive); no upper bound if omitted.

    Returns
    -------
    int
        ``value`` as an int.

    Raises
    ------
    ServokitTypeError
        If ``value`` cannot be converted to a number.
    ServokitValueError
        If it is not finite, not integral or outside ``[lo, hi]``.
    """
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ServokitTypeError(f"{name} must be an integer (got {value!r})") from None
    if not np.isfinite(v) or v != int(v):
        raise ServokitValueError(f"{name} must be an integer (got {value!r})")
    n = int(v)
    if n < lo or (hi is not None and n > hi):
        rng = f"{lo}..{hi}" if hi is not None else f">= {lo}"
        raise ServokitValueError(f"{name} must be {rng} (got {n})")
    return n


def parse_int(name: str, text: str) -> int:
    """An integer typed on the command line: ``40``, ``+40``, ``1_000``, ``40.0`` or ``4e1``.

    One rule for every integer flag: a number with an integral value is that integer
    (``1e5`` variants is 100000 variants); a fraction, NaN, inf, hex or a word is refused.

    Parameters
    ----------
    name : str
        The flag (named in the error).
    text : str
        The text as typed.

    Returns
    -------
    int
    """
    s = str(text).strip()
    try:
        return int(s)
    except ValueError:
        pass
    try:
        v = float(s)
    except ValueError:
        raise ServokitValueError(f"{name} must be an integer (got {text!r})") from None
    if not np.isfinite(v) or v != int(v):
        raise ServokitValueError(f"{name} must be an integer (got {text!r})")
    return int(v)


def check_memory(
    n_bytes: float,
    *,
    what: str,
    flag: str = "--max-memory-mb",
    max_memory_mb: float | None = None,
) -> None:
    """Refuse a request whose estimated memory exceeds the limit, before allocating.

    Parameters
    ----------
    n_bytes : float
        Estimated bytes the request allocates (samples x variants x states x 8, say).
    what : str
        The arguments that set the size, as the user typed them (``"--n-samples 1e7"``).
    flag : str
        The flag that raises the limit.
    max_memory_mb : float, optional
        The limit in MB; :data:`DEFAULT_MAX_MEMORY_MB` if omitted.
    """
    limit = DEFAULT_MAX_MEMORY_MB if max_memory_mb is None else float(max_memory_mb)
    need = float(n_bytes) / 1e6
    if not np.isfinite(need) or need > limit:
        raise ServokitValueError(
            f"{what} needs about {need:.4g} MB, above the {limit:g} MB limit; "
            f"reduce it or raise {flag}"
        )


def check_range(
    lo: float, hi: float, flags: tuple[str, str] = ("--fmin", "--fmax"), unit: str = "Hz"
) -> tuple[float, float]:
    """Return ``(lo, hi)`` if both are finite and ``0 < lo < hi``, else raise naming ``flags``.

    Parameters
    ----------
    lo, hi : float
        The range's ends, as typed.
    flags : (str, str)
        The flags that set them (named in the error).
    unit : str
        Their unit (named in the error).

    Returns
    -------
    (float, float)
    """
    check_finite(f"{flags[0]}/{flags[1]}", [lo, hi])
    if not 0 < lo < hi:
        raise ServokitValueError(
            f"need 0 < {flags[0]} < {flags[1]} [{unit}] (got {float(lo):g}, {float(hi):g})"
        )
    return float(lo), float(hi)


def check_work(n_ops: float, *, what: str, limit: float, about: str) -> None:
    """Refuse a request whose estimated operation count exceeds ``limit``, before starting.

    Parameters
    ----------
    n_ops : float
        Estimated elementary evaluations (cells) the request costs.
    what : str
        The arguments that set the work, as the user typed them.
    limit : float
        Largest accepted count.
    about : str
        What ``limit`` means in wall time (``"about half a minute"``).
    """
    if not np.isfinite(float(n_ops)) or n_ops > limit:
        raise ServokitValueError(
            f"{what} needs about {float(n_ops):.3g} evaluations, above the {limit:.3g} limit "
            f"({about}); reduce it"
        )


def check_plot_path(path: str | Path, flag: str = "--plot") -> Path:
    """Return ``path`` if it names a new or existing .png/.svg file in an existing directory.

    Parameters
    ----------
    path : str or Path
        The image file as typed.
    flag : str
        The flag that set it (named in the error).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    ServokitValueError
        If ``path`` is a directory, does not end ``.png``/``.svg`` (case-insensitive), lies
        in a missing directory, or the file (or its directory) is not writable.
    """
    with path_errors(flag, path):
        return _check_plot_path(Path(path), path, flag)


def _check_plot_path(p: Path, path: str | Path, flag: str) -> Path:
    """:func:`check_plot_path` once the path can be looked at."""
    if str(path).endswith(("/", "\\")) or p.is_dir():
        raise ServokitValueError(
            f"{flag} {path} is a directory; give a file name ending .png or .svg"
        )
    if p.suffix.lower() not in (".png", ".svg"):
        raise ServokitValueError(f"{flag} {path}: use a file name ending .png or .svg")
    if not p.parent.exists() and str(p.parent) not in ("", "."):
        raise ServokitValueError(
            f"{flag} {path}: directory {p.parent} does not exist; create it first"
        )
    _check_writable(flag, p)
    return p


@contextmanager
def path_errors(flag: str, path: str | Path) -> Iterator[None]:
    """Refuse a path the system cannot even look at (a name over 255 bytes, a loop of
    symlinks, /proc) naming the flag, instead of a bare OS error.

    Parameters
    ----------
    flag : str
        The flag that named the path.
    path : str or Path
        The path as typed.

    Yields
    ------
    None
    """
    try:
        yield
    except OSError as exc:
        raise ServokitValueError(f"{flag} {path}: {exc.strerror or exc}") from None


def _check_writable(flag: str, p: Path) -> None:
    """Refuse a path the user cannot write (read-only file or directory), before any work."""
    target = p if p.exists() else p.parent if str(p.parent) else Path(".")
    if not os.access(target, os.W_OK):
        raise ServokitValueError(f"{flag} {p}: {target} is not writable; choose another path")


def check_out_dir(path: str | Path, flag: str = "--out") -> Path:
    """Return ``path`` if it is (or can be created as) a writable directory.

    Parameters
    ----------
    path : str or Path
        The directory as typed.
    flag : str
        The flag that set it (named in the error).

    Returns
    -------
    Path
    """
    if str(path) == "":
        raise ServokitValueError(f"{flag} is empty; give a directory name")
    with path_errors(flag, path):
        return _check_out_dir(Path(path), path, flag)


def _check_out_dir(p: Path, path: str | Path, flag: str) -> Path:
    """:func:`check_out_dir` once the path can be looked at."""
    if p.exists() and not p.is_dir():
        raise ServokitValueError(f"{flag} {path} is an existing file; give a directory")
    existing = p
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        raise ServokitValueError(f"{flag} {path}: {existing} is a file, not a directory")
    _check_writable(flag, existing)
    return p


def check_input_file(path: str | Path, flag: str) -> Path:
    """Return ``path`` if it names an existing readable file (not a directory, not empty).

    Parameters
    ----------
    path : str or Path
        The file as typed.
    flag : str
        The flag that set it (named in the error).

    Returns
    -------
    Path
    """
    # a FIFO, device or /dev/zero symlink is refused before it is opened; size is capped
    return check_regular_file(path, flag)


#: Largest input file read (plants, controllers, designs, records) [bytes].
MAX_INPUT_BYTES = 50 * 1024 * 1024


def check_regular_file(path: str | Path, flag: str, max_bytes: int = MAX_INPUT_BYTES) -> Path:
    """Return ``path`` if it is a readable regular file no larger than ``max_bytes``.

    Checked with ``stat`` before anything is opened, so a FIFO (which would block the open),
    a device such as ``/dev/zero`` (endless) or a symlink to one is refused, not read.

    Parameters
    ----------
    path : str or Path
        The file as typed.
    flag : str
        The flag that named it (in the error).
    max_bytes : int
        Size cap.

    Returns
    -------
    Path
    """
    if str(path).strip() == "":
        raise ServokitValueError(f"{flag} is empty; give a file name")
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise ServokitValueError(f"{flag} {path}: no such file") from None
    except OSError as exc:
        raise ServokitValueError(f"{flag} {path}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise ServokitValueError(f"{flag} {path} is a directory, not a regular file; give a file")
    if not stat.S_ISREG(st.st_mode):
        raise ServokitValueError(
            f"{flag} {path} is not a regular file (a pipe, socket or device); give a file"
        )
    if st.st_size > max_bytes:
        raise ServokitValueError(
            f"{flag} {path} is {st.st_size / 1e6:.4g} MB, above the {max_bytes / 1e6:g} MB "
            "input limit; give a smaller file"
        )
    if not os.access(p, os.R_OK):
        raise ServokitValueError(f"{flag} {path}: not readable (permissions)")
    return p
