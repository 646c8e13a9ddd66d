"""The reproduction report: book value vs servokit value, side by side.

A case study (:mod:`servokit.cases`) returns a :class:`CaseResult` holding
:class:`Comparison` rows and the paths of the figures it wrote.

* :mod:`servokit.report.results` — ``results.json`` (rows, summary, shipped JSON schema);
* :mod:`servokit.report.html` — ``report.html`` (jinja2 template, embedded figures);
* :mod:`servokit.report.files` — writing both atomically (running the cases is
  :mod:`servokit.cases.runner`'s job);
* :mod:`servokit.report.pairing` — one-to-one pairing of computed lists with the book's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = [
    "KINDS",
    "MISS_CLASSES",
    "Comparison",
    "CaseResult",
    "nearest",
    "printed_tolerance",
    "printed_unit",
]

#: What a row is (docs/CONVENTIONS.md), in the order the report lists them.
KINDS = ("reproduced", "fitted", "assumed", "spec", "consistency", "informational")
#: Why a judged row misses, the unexplained class ``"open"`` first (the report's order):
#: ``book_misprint`` (a corrected derivation matches the book's intent),
#: ``book_inconsistent`` (the book's own data give another number),
#: ``under_determined`` (the book omits data; a stated search cannot reach the number),
#: ``figure_read`` (the book value is read off a figure or printed as "around").
MISS_CLASSES = ("open", "book_misprint", "book_inconsistent", "under_determined", "figure_read")


@dataclass(frozen=True)
class Comparison:
    """One published number of the book against the value servokit computes.

    ``rel_tol`` is the tolerance the issue states; ``ok`` compares the ratio with it.
    ``kind`` says what the row is: ``"reproduced"`` (an independent reproduction),
    ``"fitted"`` (rests on a parameter fitted to the book; name it in ``note``),
    ``"assumed"`` (rests on a value the book omits), ``"spec"`` (a specification the book
    states for its design) or ``"consistency"`` (a check that cannot fail independently).
    ``note`` says what was read, fitted or assumed.  ``bound`` makes the book value a
    limit instead of a value to match: ``"min"`` (the book asks for more than it, e.g.
    "gain margin greater than 4.5 dB") or ``"max"`` (less than it); ``rel_tol`` then
    loosens the limit by that fraction of it.  ``"informational"`` rows (a sensitivity
    study, a value the book prints no number for) are shown but never judged.

    A judged row that misses names why in ``miss_class`` (one of :data:`MISS_CLASSES`)
    and gives the evidence in one sentence in ``miss_note`` (the corrected derivation,
    the search range and its best value); a miss without a class is ``"open"``.
    """

    quantity: str
    book: float
    servokit: float
    unit: str = ""
    rel_tol: float = 0.05
    source: str = ""
    kind: str = "reproduced"
    note: str = ""
    book_text: str = ""
    bound: str = ""
    miss_class: str = ""
    miss_note: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind {self.kind!r} is not one of {KINDS}")
        if self.miss_class and self.miss_class not in MISS_CLASSES:
            raise ValueError(f"miss_class {self.miss_class!r} is not one of {MISS_CLASSES}")

    @property
    def judged(self) -> bool:
        """Whether the row is judged: a finite book value and not informational."""
        return self.kind != "informational" and bool(np.isfinite(float(self.book)))

    @classmethod
    def printed(
        cls, quantity: str, book_text: str, servokit: float, *, floor: float = 0.0, **kwargs
    ) -> Comparison:
        """A row whose tolerance is the book's printed precision.

        ``book_text`` is the number exactly as printed (``"0.26"``, ``"3.5"``, ``"1.51e3"``);
        the tolerance is half a unit of its last printed digit relative to the value,
        but at least ``floor``.
        """
        return cls(
            quantity,
            float(book_text),
            servokit,
            rel_tol=printed_tolerance(book_text, floor=floor),
            book_text=book_text,
            **kwargs,
        )

    @property
    def ratio(self) -> float:
        return self.servokit / self.book if self.book != 0 else float("nan")

    @property
    def ok(self) -> bool:
        if self.bound:
            slack = self.rel_tol * abs(self.book)
            if self.bound == "min":
                return bool(self.servokit >= self.book - slack)
            return bool(self.servokit <= self.book + slack)
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


def printed_tolerance(book_text: str, *, floor: float = 0.0) -> float:
    """Relative half-unit of the last printed digit of ``book_text`` (at least ``floor``).

    ``"0.26"`` -> 0.005 / 0.26; ``"3"`` -> 0.5 / 3; ``"1.51e3"`` -> 5 / 1510.

    Parameters
    ----------
    book_text : str
        The number exactly as the book prints it.
    floor : float
        Smallest tolerance returned.

    Returns
    -------
    float
        Relative tolerance (absolute for a printed zero).
    """
    half_unit = 0.5 * printed_unit(book_text)
    value = abs(float(book_text))
    if value == 0:
        return max(half_unit, floor)
    return max(half_unit / value, floor)


def printed_unit(book_text: str) -> float:
    """One unit of the last printed digit of ``book_text``.

    Parameters
    ----------
    book_text : str
        The number exactly as printed (``"0.26"`` -> 0.01, ``"1.51e3"`` -> 10).

    Returns
    -------
    float
        The absolute size of one unit in the last place.
    """
    mantissa, _, exponent = book_text.strip().lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 10.0 ** (-decimals + (int(exponent) if exponent else 0))


def nearest(found: object, value: float) -> float:
    """The entry of ``found`` closest to ``value`` (NaN if empty).

    Pairs one computed peak, root or frequency with one book value; to pair whole lists
    without dropping unmatched items use :func:`servokit.report.pairing.pair_rows`.

    Parameters
    ----------
    found : array_like
        Computed items.
    value : float
        The book's value.

    Returns
    -------
    float
        The closest item, NaN when ``found`` is empty.
    """
    arr = np.asarray(found, dtype=float).ravel()
    return float(arr[np.argmin(np.abs(arr - value))]) if arr.size else float("nan")


def _old_output_module() -> None:
    """Keep ``servokit.report.output`` (moved: report.files + cases.runner) importable.

    The old module ran the cases, which made report import cases; the alias resolves its
    names on attribute access, with a DeprecationWarning, so report imports no case.
    """
    import sys
    import types
    import warnings

    moved = {
        "REPORT_FILES": "servokit.report.files",
        "clear_report": "servokit.report.files",
        "write_report": "servokit.report.files",
        "run_cases": "servokit.cases.runner",
        "select_cases": "servokit.cases.runner",
    }

    def __getattr__(name: str) -> object:  # noqa: N807
        if name not in moved:
            raise AttributeError(f"module 'servokit.report.output' has no attribute {name!r}")
        warnings.warn(
            f"servokit.report.output.{name} is deprecated; use {moved[name]}.{name}",
            DeprecationWarning,
            stacklevel=2,
        )
        from importlib import import_module

        return getattr(import_module(moved[name]), name)

    module = types.ModuleType(f"{__name__}.output", "Deprecated alias (see servokit.report).")
    module.__getattr__ = __getattr__  # type: ignore[method-assign]
    sys.modules.setdefault(module.__name__, module)


_old_output_module()
