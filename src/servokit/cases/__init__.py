"""The book's case studies, each a function returning a :class:`CaseResult`.

A case module registers its entry point with :func:`register`; the list
:data:`~servokit.cases.registry.CASES` names every case; :mod:`servokit.cases.runner` runs
them for ``servokit reproduce`` (and ``make demo``).  Only this package and the
reproduce command import ``servokit.cases``: library code lives elsewhere.
"""

from __future__ import annotations

from servokit.cases.registry import case_chapter, register, registry, run_all

__all__ = ["case_chapter", "register", "registry", "run_all"]
