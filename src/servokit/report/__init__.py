"""The reproduction report: book value vs servokit value, side by side.

A case study (:mod:`servokit.cases`) returns a :class:`CaseResult` holding
:class:`Comparison` rows and the paths of the figures it wrote.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Comparison", "CaseResult", "nearest"]


@dataclass(frozen=True)
class Comparison:
    """One published number of the book against the value servokit computes.

    ``rel_tol`` is the tolerance the issue states; ``ok`` compares the ratio with it.
    ``kind`` says what the row is: ``"reproduced"`` (an independent reproduction),
    ``"fitted"`` (rests on a parameter fitted to the book; name it in ``note``),
    ``"assumed"`` (rests on a value the book omits), ``"spec"`` (a specification the book
    states for its design) or ``"consistency"`` (a check that cannot fail independently).
    ``note`` says what was read, fitted or assumed.
    """

    quantity: str
    book: float
    servokit: float
    unit: str = ""
    rel_tol: float = 0.05
    source: str = ""
    kind: str = "reproduced"
    note: str = ""

    @property
    def ratio(self) -> float:
        return self.servokit / self.book if self.book != 0 else float("nan")

    @property
    def ok(self) -> bool:
        if self.book == 0:
            return abs(self.servokit) <= self.rel_tol
        return abs(self.ratio - 1.0) <= self.rel_tol


@dataclass
class CaseResult:
    """Numbers and figures of one case study."""

    name: str
    title: str
    comparisons: list[Comparison] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    extra: dict = field(default_factory=dict)
    chapter: int = 0


def nearest(found: object, value: float) -> float:
    """The entry of ``found`` closest to ``value`` (NaN if empty): pairs a computed peak,
    root or frequency with the book's value for a :class:`Comparison`."""
    arr = np.asarray(found, dtype=float).ravel()
    return float(arr[np.argmin(np.abs(arr - value))]) if arr.size else float("nan")
