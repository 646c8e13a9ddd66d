"""Heavy third-party modules, imported on first use rather than when servokit loads.

``import control`` alone costs about a second (it pulls in scipy.signal, scipy.stats and
matplotlib.pyplot), which every command would pay before its first output (issue 23).
Library modules therefore write ``from servokit._lazy import control`` and use
``control.tf(...)`` as before: the proxy imports the real module on the first attribute
access and then holds its namespace, so later look-ups cost a plain attribute read.
Annotations stay strings (``from __future__ import annotations``), so naming
``control.TransferFunction`` in a signature imports nothing.

``tests/test_cli_startup.py`` checks that the cheap commands never touch these modules.
"""

from __future__ import annotations

import importlib
import types
from collections.abc import Callable
from typing import Any

__all__ = [
    "LazyModule",
    "control",
    "lazy_exports",
    "scipy_integrate",
    "scipy_signal",
    "scipy_sparse",
]


class LazyModule(types.ModuleType):
    """Stand-in for the module ``name`` that imports it on the first attribute access.

    Parameters
    ----------
    name : str
        Dotted module name, e.g. ``"scipy.signal"``.
    """

    def __init__(self, name: str) -> None:
        super().__init__(name)

    def __getattr__(self, attr: str) -> Any:
        module = importlib.import_module(self.__name__)
        # copy the namespace: every later look-up is found without __getattr__
        self.__dict__.update(vars(module))
        return getattr(module, attr)

    def __repr__(self) -> str:
        return f"<lazy module {self.__name__!r}>"


control = LazyModule("control")
scipy_signal = LazyModule("scipy.signal")
scipy_integrate = LazyModule("scipy.integrate")
scipy_sparse = LazyModule("scipy.sparse")


def lazy_exports(
    package: str, exports: dict[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``__getattr__`` and ``__dir__`` for a package that names what its modules define.

    A package ``__init__`` that imports every submodule makes a command pay for all of
    them (``servokit.feedback`` loads the margins, loop-shaping and dual-stage modules
    before ``filter inverse`` can run); with these, a name's module is imported on its first
    use (PEP 562) and the name then held in the package.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : dict of str to str
        Public name -> dotted name of the module that defines it.

    Returns
    -------
    getattr_, dir_ : callable
        The package's module-level ``__getattr__`` and ``__dir__``.
    """

    def getattr_(name: str) -> Any:
        module_name = exports.get(name)
        if module_name is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module_name), name)
        setattr(importlib.import_module(package), name, value)
        return value

    def dir_() -> list[str]:
        return sorted(set(vars(importlib.import_module(package))) | set(exports))

    return getattr_, dir_
