"""The book's case studies, each a function returning a :class:`CaseResult`.

A case module registers its entry point with :func:`register`; ``servokit
reproduce`` (and ``make demo``) runs every registered case.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable
from pathlib import Path

from servokit.report import CaseResult

__all__ = ["case_chapter", "register", "registry", "run_all"]

CaseFn = Callable[[Path], CaseResult]
_REGISTRY: dict[str, tuple[int, CaseFn]] = {}


def register(name: str, order: int = 100) -> Callable[[CaseFn], CaseFn]:
    """Register ``fn(outdir) -> CaseResult`` under ``name`` for ``servokit reproduce``.

    Cases run by ascending ``order``, then name (the HDD benchmark seek, the main job,
    comes first).
    """

    def deco(fn: CaseFn) -> CaseFn:
        _REGISTRY[name] = (order, fn)
        return fn

    return deco


def registry() -> dict[str, CaseFn]:
    """All registered cases in run order, importing every case module first."""
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
    ranked = sorted(_REGISTRY.items(), key=lambda item: (item[1][0], item[0]))
    return {name: fn for name, (_, fn) in ranked}


def run_all(outdir: Path, only: list[str] | None = None) -> list[CaseResult]:
    """Run the registered cases (all, or those named in ``only``) writing figures to ``outdir``."""
    outdir.mkdir(parents=True, exist_ok=True)
    cases = registry()
    names = only or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        from servokit.errors import ServokitValueError

        raise ServokitValueError(
            f"case {unknown[0]!r} is unknown; choose one of {', '.join(cases)}"
        )
    return [cases[n](outdir) for n in names]


#: Registration ``order`` ranges per book chapter (docs/CONVENTIONS.md); 0 = beyond the book.
_CHAPTER_ORDERS = ((0, 20, 2), (20, 100, 4), (100, 200, 3), (300, 400, 5), (400, 500, 6))


def case_chapter(name: str) -> int:
    """Book chapter of the registered case ``name``, from its registration ``order``.

    Parameters
    ----------
    name : str
        A registered case.

    Returns
    -------
    int
        Chapter 2-6, or 0 for a case beyond the book (order 500+).
    """
    registry()
    order = _REGISTRY[name][0]
    return next((ch for lo, hi, ch in _CHAPTER_ORDERS if lo <= order < hi), 0)
