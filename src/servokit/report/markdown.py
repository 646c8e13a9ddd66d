"""``docs/book/reproduction.md``: the reproduction per chapter, from a ``results.json``.

Per chapter: counts by kind and by miss class, the misses (``open`` first) with their
class and evidence, then every row grouped by kind.  Run
``python -m servokit.report.markdown RESULTS_JSON OUT_MD``.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from servokit.report import KINDS, MISS_CLASSES

__all__ = ["render_markdown"]


def _num(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return "–" if value is None else str(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _chapter(doc: dict[str, Any], ch: str, counts: dict[str, int]) -> list[str]:
    from servokit.report.html import _chapter_label, chapter_misses

    rows = [r for r in doc["rows"] if str(r["chapter"]) == ch]
    out = [f"## {_chapter_label(ch)}", ""]
    out.append(
        f"{counts['judged']} judged rows, {counts['within_tolerance']} within tolerance "
        f"({100.0 * counts['within_tolerance'] / max(counts['judged'], 1):.0f} %), "
        f"{counts['missed']} missed; {counts['not_comparable']} not judged."
    )
    out += ["", "| kind | rows |", "|---|---|"]
    out += [f"| {k} | {sum(r['kind'] == k for r in rows)} |" for k in KINDS]
    out += ["", "| miss class | rows |", "|---|---|"]
    out += [f"| {c} | {counts[f'miss_{c}']} |" for c in MISS_CLASSES]
    misses = chapter_misses(doc, int(ch))
    if misses:
        out += ["", "### Misses (open first)", "", "| class | case | quantity | book | servokit "
                "| evidence |", "|---|---|---|---|---|---|"]  # fmt: skip
        out += [
            f"| {r['miss_class']} | {r['case']} | {_cell(r['quantity'])} | "
            f"{r['book_text'] or _num(r['book'])} | {_num(r['servokit'])} | "
            f"{_cell(r['miss_note'])} |"
            for r in misses
        ]
    for kind in KINDS:
        sel = [r for r in rows if r["kind"] == kind]
        if not sel:
            continue
        out += ["", f"### Rows of kind {kind}", "", "| case | quantity | book | servokit | "
                "within tolerance |", "|---|---|---|---|---|"]  # fmt: skip
        out += [
            f"| {r['case']} | {_cell(r['quantity'])} | {r['book_text'] or _num(r['book'])} | "
            f"{_num(r['servokit'])} | "
            f"{ {True: 'yes', False: 'no', None: 'not judged'}[r['within_tolerance']] } |"
            for r in sel
        ]
    return out + [""]


def render_markdown(doc: dict[str, Any]) -> str:
    """The reproduction page for a ``results.json`` document.

    Parameters
    ----------
    doc : dict
        From :func:`servokit.report.results.results_document` (or the file).

    Returns
    -------
    str
        Markdown text.
    """
    corrections = [
        r for r in doc["rows"] if r["miss_class"] in ("book_misprint", "book_inconsistent")
    ]
    out = [
        "# Reproduction of the book's numbers",
        "",
        "Generated from `results.json` of `servokit reproduce --out DIR` by "
        "`python -m servokit.report.markdown DIR/results.json docs/book/reproduction.md` "
        f"(servokit {doc['servokit_version']}, {doc['generated_utc']}).",
        "",
        "Kinds: reproduced, fitted, assumed, spec, consistency, informational (not judged). "
        "Miss classes: open (unexplained), book_misprint, book_inconsistent, "
        "under_determined (the book omits data; the search is in the note), figure_read.",
        "",
    ]
    for ch, counts in doc["summary"]["chapters"].items():
        out += _chapter(doc, ch, counts)
    out += ["## Book corrections", ""]
    out += [f"- {r['case']}: {_cell(r['quantity'])}: {_cell(r['miss_note'])}" for r in corrections]
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Write the page: ``main([RESULTS_JSON, OUT_MD])``."""
    src, dst = (argv if argv is not None else sys.argv[1:])[:2]
    doc = json.loads(Path(src).read_text(encoding="utf-8"))
    Path(dst).write_text(render_markdown(doc), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
