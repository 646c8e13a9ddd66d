"""Sphinx configuration of the servokit API reference (``make docs``)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import servokit  # noqa: E402

project = "servokit"
author = "servokit contributors"
release = version = servokit.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc"]
autosummary_generate = True
autosummary_imported_members = False
numpydoc_show_class_members = False  # autosummary lists members; avoid duplicates
numpydoc_class_members_toctree = False
autodoc_typehints = "none"  # numpydoc sections carry the types
exclude_patterns = ["_build", "CONVENTIONS.md"]
html_theme = "alabaster"
html_title = f"servokit {release}"
