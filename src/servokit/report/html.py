"""``report.html``: one self-contained page of the reproduction (jinja2 template).

The page renders any :func:`~servokit.report.results.results_document` generically: a
summary table per chapter (counts equal those of ``results.json``), then per chapter a
section per case with its rows (quantity, source, book, servokit, ratio, tolerance,
within tolerance?, note; non-"reproduced" kinds are labelled in the quantity) and its
figures. The summary counts rows by kind and misses by class; each chapter opens with
its misses, ``open`` ones first, each with its class and evidence. PNG figures are
embedded as data URIs, so the page opens without network or the files beside it; an SVG
copy beside a PNG is linked. Captions come from the title
:func:`servokit._figures.save_figure` stores in the PNG (the book's figure number is in
every figure title), else from the file name.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jinja2

__all__ = [
    "CHAPTER_TITLES",
    "chapter_misses",
    "environment",
    "figure_caption",
    "png_data_uri",
    "render_html",
]

#: Short titles of the book's chapters for the report's section headings.
CHAPTER_TITLES = {
    2: "Chapter 2 · Feedforward: fast seeking",
    3: "Chapter 3 · Mode switching: settling",
    4: "Chapter 4 · Sampled-data analysis",
    5: "Chapter 5 · Resonance compensation and dual-stage feedback",
    6: "Chapter 6 · Limits of positioning accuracy",
}
_COUNT_KEYS = (
    "rows",
    "judged",
    "within_tolerance",
    "missed",
    "not_comparable",
    "reproduced",
    "reproduced_kind",
    "fitted",
    "assumed",
    "spec",
    "consistency",
    "informational",
    "miss_open",
    "miss_book_misprint",
    "miss_book_inconsistent",
    "miss_under_determined",
    "miss_figure_read",
)
#: Column headings of the summary table.
_COUNT_LABELS = {
    "reproduced": "reproduced (within tol.)",
    "reproduced_kind": "kind: reproduced",
    "fitted": "kind: fitted",
    "assumed": "kind: assumed",
    "spec": "kind: spec",
    "consistency": "kind: consistency",
    "informational": "kind: informational",
    "miss_open": "miss: open",
    "miss_book_misprint": "miss: book misprint",
    "miss_book_inconsistent": "miss: book inconsistent",
    "miss_under_determined": "miss: under-determined",
    "miss_figure_read": "miss: figure read",
}


def _chapter_label(ch: int | str) -> str:
    ch = int(ch)
    return CHAPTER_TITLES.get(ch, f"Chapter {ch}" if ch else "Other cases")


def _fmt(value: float | str | None, digits: int = 7) -> str:
    if isinstance(value, str):  # "Infinity", "-Infinity", "NaN" (results.json encoding)
        return {"Infinity": "∞", "-Infinity": "−∞"}.get(value, "–")
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value:.{digits}g}"


def _pct(value: float | str | None) -> str:
    return "–" if value is None or isinstance(value, str) else f"{100.0 * value:.3g} %"


def _row_class(row: dict[str, Any]) -> str:
    if row["within_tolerance"] is None:
        return "none"
    return "ok" if row["within_tolerance"] else "miss"


def figure_caption(path: Path) -> str:
    """Caption of a figure file: the title stored in a PNG's metadata, else its stem.

    Parameters
    ----------
    path : Path
        Figure file.

    Returns
    -------
    str
        The caption.
    """
    if path.suffix.lower() == ".png" and path.exists():
        from PIL import Image

        # the text chunks before the image data (where savefig writes its metadata) are
        # in ``info`` once the header is read; ``img.text`` would decode the whole image
        # to find chunks after it (0.5 s over the report's 78 figures)
        with Image.open(path) as img:
            title = img.info.get("Title", "")
        if title:
            return title
    return path.stem.replace("_", " ")


def png_data_uri(png: bytes) -> str:
    """A PNG as a ``data:`` URI, so that a page shows it without the file beside it.

    Parameters
    ----------
    png : bytes
        PNG file contents.

    Returns
    -------
    str
        ``data:image/png;base64,...``.
    """
    return "data:image/png;base64," + base64.b64encode(png).decode("ascii")


def _figure_entry(rel: str, outdir: Path) -> dict[str, str]:
    path = outdir / rel
    src = rel
    if path.suffix.lower() == ".png" and path.exists():
        src = png_data_uri(path.read_bytes())
    svg = path.with_suffix(".svg")
    return {
        "src": src,
        "caption": figure_caption(path),
        "svg": Path(rel).with_suffix(".svg").as_posix() if svg.exists() else "",
    }


def chapter_misses(doc: dict[str, Any], chapter: int) -> list[dict[str, Any]]:
    """The judged rows of ``chapter`` that miss, ``open`` ones first, then by class.

    Parameters
    ----------
    doc : dict
        A ``results.json`` document.
    chapter : int
        Book chapter.

    Returns
    -------
    list of dict
        Row records in report order (class order of ``MISS_CLASSES``, then row order).
    """
    from servokit.report import MISS_CLASSES

    rows = [r for r in doc["rows"] if int(r["chapter"]) == int(chapter) and r["miss_class"]]
    return sorted(rows, key=lambda r: MISS_CLASSES.index(r["miss_class"]))


def _chapters(doc: dict[str, Any], outdir: Path) -> list[tuple[int, list[dict[str, Any]]]]:
    grouped: dict[int, list[dict[str, Any]]] = {}
    for case in doc["cases"]:
        entry = dict(case)
        entry["rows"] = [r for r in doc["rows"] if r["case"] == case["name"]]
        entry["figures"] = [_figure_entry(f, outdir) for f in case["figures"]]
        grouped.setdefault(int(case["chapter"]), []).append(entry)
    return sorted(grouped.items())


def environment() -> jinja2.Environment:
    """The jinja2 environment of servokit's HTML reports (templates, number helpers).

    Returns
    -------
    jinja2.Environment
        Package templates (``report.html.j2``, ``design.html.j2`` and the shared
        ``_style.html.j2``), autoescaped, strict about undefined names.
    """
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("servokit.report", "templates"),
        autoescape=jinja2.select_autoescape(["html", "j2"]),
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    helpers: dict[str, Callable[..., Any]] = {
        "fmt": _fmt,
        "pct": _pct,
        "row_class": _row_class,
        "chapter_label": _chapter_label,
        "chapter_misses": chapter_misses,
        "count_label": lambda key: _COUNT_LABELS.get(key, key.replace("_", " ")),
    }
    env.globals.update(helpers)
    return env


def render_html(doc: dict[str, Any], outdir: Path) -> str:
    """Render ``report.html`` for a ``results.json`` document.

    Parameters
    ----------
    doc : dict
        From :func:`servokit.report.results.results_document`.
    outdir : Path
        Directory the document's figure paths are relative to.

    Returns
    -------
    str
        The HTML page.
    """
    template = environment().get_template("report.html.j2")
    return template.render(doc=doc, chapters=_chapters(doc, Path(outdir)), count_keys=_COUNT_KEYS)
