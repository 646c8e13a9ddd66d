"""Name the user's inputs in an error message that names none.

Most errors are raised with the flag in their text (``--dt must be > 0``). A failure deep in
a numerical library (``Eigenvalues did not converge``, ``array must not contain infs or
NaNs``) carries no flag. The runner then adds the numbers the user typed that lie far
outside any physical range (non-finite, above 1e12 or below 1e-12 in magnitude), since
those are almost always the cause; failing that, the number flags given. A user always sees
which input to change (issue 23: "errors always name the flag or file").
"""

from __future__ import annotations

import math
import os
import re

__all__ = ["EXTREME_ABOVE", "EXTREME_BELOW", "with_input_hint"]

#: magnitudes outside [EXTREME_BELOW, EXTREME_ABOVE] (or non-finite) are flagged as the cause
EXTREME_ABOVE = 1e12
EXTREME_BELOW = 1e-12
_SPLIT = re.compile(r"[:,]")


def _numbers(value: str) -> list[float] | None:
    """The numbers of a flag value (``5461:2:10`` -> three), or None if it is not numeric."""
    try:
        return [float(part) for part in _SPLIT.split(value)]
    except ValueError:
        return None


def _extreme(x: float) -> bool:
    return not math.isfinite(x) or abs(x) > EXTREME_ABOVE or 0.0 < abs(x) < EXTREME_BELOW


def _numeric_flags(argv: list[str]) -> list[tuple[str, str, bool]]:
    """``(flag, value, extreme)`` for every ``--flag VALUE`` / ``--flag=VALUE`` with numbers."""
    found = []
    for i, word in enumerate(argv):
        if not word.startswith("--"):
            continue
        flag, _, value = word.partition("=")
        if not value and i + 1 < len(argv) and not argv[i + 1].startswith("--"):
            value = argv[i + 1]
        numbers = _numbers(value) if value else None
        if numbers:
            found.append((flag, value, any(_extreme(x) for x in numbers)))
    return found


def _names(message: str, arg: str) -> bool:
    """Whether ``message`` names the argument ``arg`` as typed: an existing path anywhere,
    any other word quoted (``unknown plant 'nosuch'``) or before a colon (``x.csv: no such
    file``), as the errors of a missing file or an unknown name put it."""
    for form in {arg, os.path.normpath(arg)}:  # "./x.toml" is shown as "x.toml"
        if form in message and (
            os.path.exists(form) or f"'{form}'" in message or f"{form}:" in message
        ):
            return True
    return False


def with_input_hint(message: str, argv: list[str]) -> str:
    """``message``, followed by the inputs that likely caused it if it names no flag.

    Parameters
    ----------
    message : str
        The one-line error text.
    argv : list of str
        The command line after the program name.

    Returns
    -------
    str
        The message unchanged if it names a flag (``--``) or one of the arguments as typed,
        else with ``(at --flag VALUE: ...)`` naming the extreme numbers, or the number
        flags given, appended.
    """
    if "--" in message or any(_names(message, a) for a in argv if len(a) > 2):
        return message
    flags = _numeric_flags(argv)
    extreme = [f"{flag} {value}" for flag, value, bad in flags if bad]
    if extreme:
        return f"{message} (at {', '.join(extreme)}: far outside the range such inputs take)"
    if flags:
        return f"{message} (from the numbers given to {', '.join(f for f, _, _ in flags)})"
    return f"{message} (with the default inputs of this command)"
