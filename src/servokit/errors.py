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
]

import numpy as np


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
