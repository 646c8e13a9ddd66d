"""The book's case studies, each a function returning a :class:`CaseResult`.

A case module registers its entry point with :func:`register`; the runner
(:mod:`servokit.cases.runner`) lists every case in :data:`~servokit.cases.runner.CASES`,
and ``servokit reproduce`` (and ``make demo``) runs them.  Only this package and the
reproduce command import ``servokit.cases``: library code lives elsewhere.
"""

from __future__ import annotations

from servokit.cases.runner import case_chapter, register, registry, run_all

__all__ = ["case_chapter", "register", "registry", "run_all"]
