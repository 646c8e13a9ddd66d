"""``results.json``: every reproduce row as a flat, machine-readable record.

A document has a header (servokit version, UTC date), the cases that ran (name, title,
chapter, runtime, figures), every :class:`~servokit.report.Comparison` row of every
case as one object, and a summary that counts the rows per chapter.  The JSON schema
``results.schema.json`` ships with the package (:func:`load_schema`).

Counting is deliberately conservative: only rows of kind ``"reproduced"`` that are
within tolerance count as *reproduced*; a row resting on a fitted or assumed parameter,
a consistency check and a stated specification are counted in their own columns, never
as an independent reproduction.  A row whose book value is not a finite number (the
book prints no comparable value) and an ``"informational"`` row are present with
``within_tolerance`` null (not judged).  Every judged row that misses carries a
``miss_class`` (:data:`servokit.report.MISS_CLASSES`; ``"open"`` when the case gives
none) and a ``miss_note``; the summary counts the misses per class.

Number encoding (strict JSON, stated in the schema): a finite number is a JSON number;
+-infinity is the string ``"Infinity"`` / ``"-Infinity"`` (an infinite gain margin is a
value, not a gap); NaN is ``null`` in a row that is not judged (no book number) and the
string ``"NaN"`` in a judged row (a servokit computation that failed, or the ratio to a
book value of 0, whose tolerance is absolute), so a judged row never holds ``null``.
The document names its schema in ``$schema`` (the file written beside it).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
from collections.abc import Iterable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

from servokit._io import write_atomic
from servokit.report import KINDS, MISS_CLASSES, CaseResult, Comparison

__all__ = [
    "KINDS",
    "MISS_CLASSES",
    "SCHEMA_NAME",
    "results_document",
    "row_record",
    "summarize",
    "load_schema",
    "precision_remark",
    "write_atomic",
    "write_results",
]

#: File name of the JSON schema inside the package.
SCHEMA_NAME = "results.schema.json"


def _finite_or_none(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def encode_number(value: float, *, judged: bool) -> float | str | None:
    """``value`` as strict JSON: a number, ``"Infinity"``/``"-Infinity"``, or NaN as
    ``"NaN"`` in a judged row and ``null`` elsewhere (see the module docstring).

    Parameters
    ----------
    value : float
        The number.
    judged : bool
        Whether the row it belongs to is judged.

    Returns
    -------
    float, str or None
        The encoded value.
    """
    value = float(value)
    if math.isfinite(value):
        return value
    if math.isinf(value):
        return "Infinity" if value > 0 else "-Infinity"
    return "NaN" if judged else None


def within_tolerance(row: Comparison) -> bool | None:
    """``row.ok``, or None where the book gives no comparable (finite) number.

    Parameters
    ----------
    row : Comparison
        The reproduce row.

    Returns
    -------
    bool or None
        True / False as :attr:`Comparison.ok`; None for a non-finite book value.
    """
    if not row.judged:
        return None
    return bool(row.ok)


def precision_remark(row: Comparison) -> str:
    """A note for a row that misses only by the book's printed precision, else ``""``.

    A row "fails only by precision" when servokit's value, rounded to the printed
    digits, is one unit of the last digit away from the printed value (``"0.26"``
    against 0.2714, which reads 0.27).

    Parameters
    ----------
    row : Comparison
        The row (``book_text`` set, not a bound).

    Returns
    -------
    str
        The remark, or an empty string.
    """
    from servokit.report import printed_unit

    if row.bound or not row.book_text or row.ok or not math.isfinite(float(row.servokit)):
        return ""
    unit = printed_unit(row.book_text)
    if abs(row.servokit - row.book) >= 1.5 * unit:
        return ""
    return (
        f"outside the printed precision only: servokit {row.servokit:.6g} reads "
        f"{round(row.servokit / unit) * unit:.6g} at the printed digits, book {row.book_text}"
    )


def row_record(case: CaseResult, row: Comparison) -> dict[str, Any]:
    """One row of ``results.json`` (the keys of issue 14, plus ``kind`` and ``book_text``).

    Parameters
    ----------
    case : CaseResult
        The case the row belongs to (name, chapter).
    row : Comparison
        The row.

    Returns
    -------
    dict
        ``case, chapter, source, quantity, unit, book, book_text, servokit, ratio,
        tolerance, within_tolerance, kind, note, bound, miss_class, miss_note``;
        numbers encoded by :func:`encode_number`.  ``miss_class``/``miss_note`` are
        empty unless the row is judged and misses; an unexplained miss is ``"open"``.
    """
    judged = row.judged
    ratio = row.ratio if math.isfinite(float(row.book)) else float("nan")
    within = within_tolerance(row)
    missed = within is False
    remark = precision_remark(row)
    miss_class = (row.miss_class or "open") if missed else ""
    miss_note = (row.miss_note or remark or "no explanation found yet") if missed else ""
    return {
        "case": case.name,
        "chapter": int(case.chapter),
        "source": row.source,
        "quantity": row.quantity,
        "unit": row.unit,
        "book": encode_number(row.book, judged=judged),
        "book_text": row.book_text,
        "servokit": encode_number(row.servokit, judged=judged),
        "ratio": encode_number(ratio, judged=judged),
        "tolerance": encode_number(row.rel_tol, judged=judged),
        "within_tolerance": within,
        "kind": row.kind,
        "note": "; ".join(p for p in (row.note, remark) if p),
        "bound": row.bound,
        "miss_class": miss_class,
        "miss_note": miss_note,
    }


def _count(rows: Sequence[dict[str, Any]]) -> dict[str, int]:
    judged = [r for r in rows if r["within_tolerance"] is not None]
    within = [r for r in judged if r["within_tolerance"]]
    counts = {
        "rows": len(rows),
        "judged": len(judged),
        "within_tolerance": len(within),
        "missed": len(judged) - len(within),
        "not_comparable": len(rows) - len(judged),
        # the independent reproductions: reproduced-kind rows inside their tolerance
        "reproduced": sum(r["kind"] == "reproduced" for r in within),
        "reproduced_kind": sum(r["kind"] == "reproduced" for r in rows),
    }
    for kind in KINDS[1:]:
        counts[kind] = sum(r["kind"] == kind for r in rows)
    for cls in MISS_CLASSES:
        counts[f"miss_{cls}"] = sum(r["miss_class"] == cls for r in rows)
    return counts


def summarize(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Counts of all rows and per chapter (see the module docstring for what counts).

    Parameters
    ----------
    rows : sequence of dict
        Records from :func:`row_record`.

    Returns
    -------
    dict
        ``{"total": counts, "chapters": {"2": counts, ...}}``; ``counts`` holds ``rows,
        judged, within_tolerance, missed, not_comparable, reproduced`` (reproduced rows
        within tolerance), ``reproduced_kind`` (all rows of that kind), ``fitted,
        assumed, spec, consistency, informational`` and ``miss_<class>`` per miss class.
    """
    chapters = sorted({int(r["chapter"]) for r in rows})
    return {
        "total": _count(rows),
        "chapters": {
            str(ch): _count([r for r in rows if int(r["chapter"]) == ch]) for ch in chapters
        },
    }


def _relative(path: Path, base: Path) -> str:
    try:
        return Path(path).resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        return Path(path).as_posix()


def results_document(
    results: Iterable[CaseResult],
    *,
    outdir: Path,
    runtimes_s: dict[str, float] | None = None,
    generated: _dt.datetime | None = None,
) -> dict[str, Any]:
    """The whole ``results.json`` document.

    Parameters
    ----------
    results : iterable of CaseResult
        The cases that ran.
    outdir : Path
        Directory of the report; figure paths are written relative to it.
    runtimes_s : dict, optional
        Wall-clock runtime [s] per case name.
    generated : datetime, optional
        Time stamp of the header (default: now, UTC).

    Returns
    -------
    dict
        ``$schema`` (the schema file written beside it), ``servokit_version,
        generated_utc, cases, rows, summary``; each case holds
        ``name, title, chapter, runtime_s, figures, notes`` (``notes``: the text-valued
        entries of ``CaseResult.extra``, e.g. a delay convention).
    """
    from servokit import __version__

    results = list(results)
    runtimes_s = runtimes_s or {}
    stamp = generated or _dt.datetime.now(_dt.UTC)
    rows = [row_record(r, c) for r in results for c in r.comparisons]
    cases = [
        {
            "name": r.name,
            "title": r.title,
            "chapter": int(r.chapter),
            "runtime_s": _finite_or_none(runtimes_s.get(r.name, float("nan"))),
            "figures": [_relative(f, outdir) for f in r.figures],
            # the case's stated conventions and assumptions (its text-valued extras)
            "notes": {str(k): v for k, v in r.extra.items() if isinstance(v, str)},
        }
        for r in results
    ]
    return {
        "$schema": SCHEMA_NAME,
        "servokit_version": __version__,
        "generated_utc": stamp.strftime("%Y-%m-%dT%H:%M:%SZ"),
        "cases": cases,
        "rows": rows,
        "summary": summarize(rows),
    }


def load_schema() -> dict[str, Any]:
    """The JSON schema of ``results.json`` shipped with the package.

    Returns
    -------
    dict
        The schema (JSON Schema draft 2020-12).
    """
    text = resources.files("servokit.report").joinpath(SCHEMA_NAME).read_text("utf-8")
    return json.loads(text)


def write_results(document: dict[str, Any], path: Path) -> Path:
    """Write ``document`` as indented JSON atomically (non-finite numbers refused).

    Parameters
    ----------
    document : dict
        From :func:`results_document`.
    path : Path
        Destination (``results.json``).

    Returns
    -------
    Path
        ``path``.
    """
    text = json.dumps(document, indent=2, allow_nan=False, ensure_ascii=False)
    return write_atomic(path, text + "\n")
