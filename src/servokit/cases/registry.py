"""Which cases exist and in which order: an explicit list plus a registration decorator.

Discovery is explicit: :data:`CASES` lists every case (name, run order, module), so the
CLI can list and select cases without importing them (importing pulls in scipy,
python-control and matplotlib).  Each case module registers its entry point with the
:func:`register` decorator when imported; tests/test_layering.py checks the two agree.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from servokit.errors import ServokitValueError

if TYPE_CHECKING:
    from servokit.report import CaseResult

__all__ = ["CASES", "case_chapter", "case_names", "register", "registry", "run_all"]

CaseFn = Callable[[Path], "CaseResult"]

#: Every case: name -> (run order, module in servokit.cases).  Cases run by ascending
#: order, then name; the order range gives the book chapter (docs/CONVENTIONS.md:
#: chapter 2 orders 0-19, chapter 4 20-99, chapter 3 100-199, chapter 5 300-399,
#: chapter 6 400-499, beyond the book 500+).  A new case module adds its row here and
#: registers its function with :func:`register` (tests/test_layering.py checks both).
CASES: dict[str, tuple[int, str]] = {
    "hdd-seek": (0, "hdd_seek"),
    "galvano": (10, "galvano"),
    "hdd-sensitivity": (20, "hdd_sensitivity"),
    "sampled-oscillations": (30, "oscillations"),
    "hdd-residual": (40, "hdd_residual"),
    "switching-ivc": (100, "switching_ivc"),
    "switching-h2": (105, "switching_h2"),
    "switching-admissible": (110, "switching_admissible"),
    "switching-acoustic": (115, "switching_acoustic"),
    "switching-optical": (120, "switching_optical"),
    "switching-pmr": (125, "switching_pmr"),
    "switching-galvano": (130, "switching_galvano"),
    "resonance-filters": (300, "resonance"),
    "peak-filter-12khz": (310, "peak_filters"),
    "ltv-peak-filter-locus": (320, "peak_filters"),
    "ltv-peak-filter-transient": (321, "ltv"),
    "identification-vcm": (330, "identification"),
    "identification-pzt": (331, "identification"),
    "dual-stage": (350, "dual_stage"),
    "ssa": (360, "dual_stage"),
    "svm-settling": (410, "svm_settling"),
    "limits": (420, "limits"),
    "hdd-pes": (430, "hdd_pes"),
    "hdd-robust-seek": (500, "robust_seek"),
}
_REGISTRY: dict[str, tuple[int, CaseFn]] = {}
#: Registration ``order`` ranges per book chapter (docs/CONVENTIONS.md); 0 = beyond the book.
_CHAPTER_ORDERS = ((0, 20, 2), (20, 100, 4), (100, 200, 3), (300, 400, 5), (400, 500, 6))


def register(name: str, order: int = 100) -> Callable[[CaseFn], CaseFn]:
    """Register ``fn(outdir) -> CaseResult`` under ``name`` for ``servokit reproduce``.

    Cases run by ascending ``order``, then name (the HDD benchmark seek, the main job,
    comes first).

    Parameters
    ----------
    name : str
        Case name, as given to ``servokit reproduce --case``; a later registration under
        the same name replaces the earlier one.  Listed in :data:`CASES` for the
        built-in cases.
    order : int
        Run-order key; its range also gives the book chapter (see :func:`case_chapter`).

    Returns
    -------
    callable
        Decorator that records ``fn`` and returns it unchanged.
    """

    def deco(fn: CaseFn) -> CaseFn:
        _REGISTRY[name] = (order, fn)
        return fn

    return deco


def _ranked() -> list[tuple[str, int]]:
    """(name, order) of the listed and the registered cases, in run order."""
    orders = {name: order for name, (order, _) in CASES.items()}
    orders |= {name: order for name, (order, _) in _REGISTRY.items()}
    return sorted(orders.items(), key=lambda item: (item[1], item[0]))


def case_names() -> list[str]:
    """Case names in run order, without importing any case module.

    Returns
    -------
    list of str
        The names of :data:`CASES` and of any case registered at run time.
    """
    return [name for name, _ in _ranked()]


def registry() -> dict[str, CaseFn]:
    """All cases in run order, importing the modules of :data:`CASES` first.

    Returns
    -------
    dict of str to callable
        Case name to ``fn(outdir) -> CaseResult``, ordered by ascending ``order``, then
        name.
    """
    for module in sorted({module for _, module in CASES.values()}):
        importlib.import_module(f"servokit.cases.{module}")
    ranked = sorted(_REGISTRY.items(), key=lambda item: (item[1][0], item[0]))
    return {name: fn for name, (_, fn) in ranked}


def run_all(outdir: Path, only: list[str] | None = None) -> list[CaseResult]:
    """Run the registered cases (all, or those named in ``only``) writing figures to ``outdir``.

    Parameters
    ----------
    outdir : pathlib.Path
        Directory for the figures; created (with parents) if missing.
    only : list of str, optional
        Names of the cases to run, in that order; every registered case in run order if
        omitted or empty.

    Returns
    -------
    list of CaseResult
        One result per case run, in run order.

    Raises
    ------
    ServokitValueError
        If a name in ``only`` is not registered (checked before any case runs).
    """
    outdir.mkdir(parents=True, exist_ok=True)
    cases = registry()
    names = only or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise ServokitValueError(
            f"case {unknown[0]!r} is unknown; choose one of {', '.join(cases)}"
        )
    return [cases[n](outdir) for n in names]


def case_chapter(name: str) -> int:
    """Book chapter of the case ``name``, from its run ``order``.

    Parameters
    ----------
    name : str
        A listed or registered case.

    Returns
    -------
    int
        Chapter 2-6, or 0 for a case beyond the book (order 500+).
    """
    order = dict(_ranked())[name]
    return next((ch for lo, hi, ch in _CHAPTER_ORDERS if lo <= order < hi), 0)
