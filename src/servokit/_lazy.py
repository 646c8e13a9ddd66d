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
from typing import Any

__all__ = ["LazyModule", "control", "scipy_integrate", "scipy_signal", "scipy_sparse"]


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
