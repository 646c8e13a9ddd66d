"""The ``servokit`` command line.

Every module in this package registers its sub-commands on the shared typer
``app`` of :mod:`servokit.cli._app`; :func:`main` imports them all first.
"""

from __future__ import annotations

import importlib
import pkgutil

from servokit.cli._app import app, main

__all__ = ["app", "main"]


def _discover() -> None:
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
