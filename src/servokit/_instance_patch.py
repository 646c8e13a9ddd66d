"""An attribute put on some objects for the duration of a block (the memos of save_figure)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["on_instances"]


@contextmanager
def on_instances(
    objects: Iterable[Any], name: str, make: Callable[[Any], Any]
) -> Iterator[list[Any]]:
    """While active, each of ``objects`` has the instance attribute ``name`` = ``make(obj)``.

    An object that already has its own ``name`` (its owner's patch, or a nested block)
    is left alone; the attribute is deleted from the others when the block ends, so the
    class's own method answers again.

    Parameters
    ----------
    objects : iterable
        The objects (axes' axis objects, legends).
    name : str
        The attribute (a method name of their class).
    make : callable
        Makes the attribute's value for one object.

    Yields
    ------
    list
        The objects that got the attribute.
    """
    installed: list[Any] = []
    try:
        for obj in objects:
            if name not in vars(obj):
                setattr(obj, name, make(obj))
                installed.append(obj)
        yield installed
    finally:
        for obj in installed:
            delattr(obj, name)
