"""Sphinx configuration of the servokit docs (``make docs``): the guide and book pages
(Markdown through MyST), the command-line reference generated from the CLI itself, and the
API reference from the numpydoc docstrings."""

from __future__ import annotations

import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS.parents[0] / "src"))
sys.path.insert(0, str(DOCS))

import servokit  # noqa: E402
from sphinx.ext import autosummary  # noqa: E402
from _cli_reference import write_cli_reference  # noqa: E402

project = "servokit"
author = "servokit contributors"
release = version = servokit.__version__
extensions = ["sphinx.ext.autodoc", "sphinx.ext.autosummary", "numpydoc", "myst_parser"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
autosummary_generate = True
autosummary_imported_members = False
autosummary_ignore_module_all = False  # document what each module exports
numpydoc_show_class_members = False  # autosummary lists members; avoid duplicates
numpydoc_class_members_toctree = False
autodoc_typehints = "none"  # numpydoc sections carry the types
exclude_patterns = ["_build"]
myst_heading_anchors = 3
# links from the Markdown pages to repository files outside docs/ (README, CHANGELOG, the
# examples) are plain links, not cross-references
suppress_warnings = ["myst.xref_missing"]
html_theme = "alabaster"
html_title = f"servokit {release}"

# the CLI reference is generated from the command tree at every build, so it never drifts
write_cli_reference(DOCS / "reference" / "cli.md")


def _escape_bar(line: str) -> str:
    """Docstrings write |x| for magnitudes; reST would read it as a substitution, so the
    bars are escaped (table rows and line blocks, a bar followed by a space, stay)."""
    if "|" not in line or line.lstrip().startswith(("| ", "+-", "+=")):
        return line
    return line.replace("\\|", "|").replace("|", "\\|")


def _escape_bars(app, what, name, obj, options, lines: list[str]) -> None:
    lines[:] = [_escape_bar(line) for line in lines]


_extract_summary = autosummary.extract_summary


def _extract_escaped_summary(doc: list[str], document) -> str:
    # autosummary parses each member's docstring for its one-line summary without the
    # autodoc events, so the same escaping is applied here
    return _extract_summary([_escape_bar(line) for line in doc], document)


autosummary.extract_summary = _extract_escaped_summary


def setup(app) -> None:
    app.connect("autodoc-process-docstring", _escape_bars)
