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
    "check_memory",
    "check_plot_path",
    "DEFAULT_MAX_MEMORY_MB",
]

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
    """Return ``value`` as a float array, or raise naming ``name`` if it holds NaN/inf."""
    arr = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ServokitValueError(f"{name} must be finite (got NaN or inf); pass finite numbers")
    return arr


def check_positive(name: str, value: object, unit: str = "") -> float:
    """Return ``value`` as a float, or raise naming ``name`` unless it is finite and > 0."""
    v = float(check_finite(name, value))
    if v <= 0:
        raise ServokitValueError(f"{name} must be > 0{' ' + unit if unit else ''} (got {v})")
    return v


def check_count(name: str, value: object, *, lo: int = 1, hi: int | None = None) -> int:
    """Return ``value`` as an int in ``[lo, hi]``, or raise naming ``name`` and the range."""
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


def check_plot_path(path: str | Path, flag: str = "--plot") -> Path:
    """Return ``path`` if it names a new or existing .png/.svg file in an existing directory."""
    p = Path(path)
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
    return p
