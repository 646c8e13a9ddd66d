"""Deprecated: moved to :mod:`servokit.seek` (removed in the next release).

``servokit.robust.robust_minimum_time`` and the other names still resolve, with a
:class:`DeprecationWarning` naming the new home (SciPy's deprecated-namespace pattern);
the old submodule paths ``servokit.robust.sweep``, ``servokit.robust.feedforward`` and
``servokit.robust._matrices`` are aliases of their :mod:`servokit.seek` modules.
"""

import sys
import warnings
from typing import Any

import servokit.seek._matrices
import servokit.seek.robust
import servokit.seek.sweep  # noqa: F401  (the modules the old paths alias)

#: old submodule -> its module in servokit.seek
_MODULES = {
    "feedforward": "servokit.seek.robust",
    "sweep": "servokit.seek.sweep",
    "_matrices": "servokit.seek._matrices",
}
#: old name -> where it lives now
_MOVED = {
    "NoFeasibleSeekError": "servokit.seek.NoFeasibleSeekError",
    "RobustFeedforwardInput": "servokit.seek.RobustFeedforwardInput",
    "robust_minimum_time": "servokit.seek.robust_minimum_time",
    **_MODULES,
}
__all__ = ["NoFeasibleSeekError", "RobustFeedforwardInput", "robust_minimum_time"]

# `from servokit.robust.sweep import X` keeps working: the old module paths are aliases
for _old, _new in _MODULES.items():
    sys.modules[f"{__name__}.{_old}"] = sys.modules[_new]


def __getattr__(name: str) -> Any:
    if name not in _MOVED:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        f"servokit.robust.{name} is deprecated and will be removed in the next release; "
        f"use {_MOVED[name]}",
        DeprecationWarning,
        stacklevel=2,
    )
    if name in _MODULES:
        return sys.modules[_MODULES[name]]
    return getattr(sys.modules["servokit.seek"], name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_MOVED))
