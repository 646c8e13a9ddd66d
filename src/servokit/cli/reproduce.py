"""``servokit reproduce``: run the book's case studies, book value vs servokit value."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated

import typer

from servokit.cli._app import app, console, emit_json, example, progress
from servokit.errors import ServokitValueError, check_out_dir

_CASES_DIR = Path(__file__).resolve().parent.parent / "cases"
_REGISTER = re.compile(r"@register\(\s*\"([^\"]+)\"(?:\s*,\s*order\s*=\s*(-?\d+))?")


def case_names() -> list[str]:
    """Registered case names in run order, read from the case modules without importing them.

    ``--help`` must stay fast: importing the cases pulls in scipy, python-control and
    matplotlib.  :func:`servokit.cases.registry` remains the authority when running.
    """
    found: list[tuple[int, str]] = []
    for path in sorted(_CASES_DIR.glob("*.py")):
        if path.name.startswith("_"):
            continue
        for name, order in _REGISTER.findall(path.read_text(encoding="utf-8")):
            found.append((int(order) if order else 100, name))
    return [name for _, name in sorted(found)]


_JSON_KEYS = (
    "[{case, title, chapter, runtime_s, comparisons [{quantity, book, book_text, "
    "servokit, ratio, unit, rel_tol, ok, source, kind, note}], figures}]"
)


@app.command(
    "reproduce",
    help="Reproduce the book's published numbers and figures.\n\nCases: " + ", ".join(case_names()),
    epilog=example("servokit reproduce --out out --case hdd-seek") + f"  JSON: {_JSON_KEYS}.",
)
def reproduce(
    out: Annotated[
        Path, typer.Option("--out", help="directory for the figures", metavar="DIR")
    ] = Path("out"),
    case: Annotated[
        list[str] | None,
        typer.Option("--case", help="run only this case (repeatable; names listed above)"),
    ] = None,
    json_out: Annotated[
        bool,
        typer.Option("--json", help="machine-readable JSON on stdout (nothing else on stdout)"),
    ] = False,
) -> None:
    out = check_out_dir(out)
    import time

    from servokit.cases import registry

    cases = registry()
    names = case or list(cases)
    unknown = [n for n in names if n not in cases]
    if unknown:
        raise ServokitValueError(
            f"--case {unknown[0]!r} is unknown; choose one of {', '.join(cases)}"
        )
    out.mkdir(parents=True, exist_ok=True)
    results = []
    with progress(len(names), "cases", enabled=not json_out and len(names) > 1) as advance:
        for name in names:
            if not json_out:
                typer.echo(f"running {name} ...", err=True)
            start = time.perf_counter()
            result = cases[name](out)
            results.append((result, time.perf_counter() - start))
            advance()
    if json_out:
        emit_json([_case_json(r, dt) for r, dt in results])
        return
    _print_tables(results, out)


def _case_json(r, runtime: float) -> dict:  # noqa: ANN001
    return {
        "case": r.name,
        "title": r.title,
        "chapter": r.chapter,
        "runtime_s": runtime,
        "comparisons": [
            {
                "quantity": c.quantity,
                "book": c.book,
                "book_text": c.book_text,
                "servokit": c.servokit,
                "ratio": c.ratio,
                "unit": c.unit,
                "rel_tol": c.rel_tol,
                "ok": c.ok,
                "source": c.source,
                "kind": c.kind,
                "note": c.note,
            }
            for c in r.comparisons
        ],
        "figures": [str(f) for f in r.figures],
    }


def _print_tables(results: list, out: Path) -> None:
    from rich.markup import escape
    from rich.table import Table

    n_ok = n_all = 0
    for r, runtime in results:
        title = escape(f"{r.title}  [{r.name}]  ({runtime:.1f} s)")
        table = Table(title=title, title_justify="left")
        for col in ("quantity", "book", "servokit", "ratio", "tol", "kind", "ok"):
            table.add_column(col, justify="left" if col in ("quantity", "kind") else "right")
        for c in r.comparisons:
            n_all += 1
            n_ok += c.ok
            table.add_row(
                escape(f"{c.quantity} [{c.unit}]" if c.unit else c.quantity),
                escape(c.book_text or f"{c.book:.7g}"),
                f"{c.servokit:.7g}",
                f"{c.ratio:.4f}",
                f"{c.rel_tol * 100:.3g}%",
                escape(c.kind),
                "[green]yes[/green]" if c.ok else "[red]no[/red]",
            )
        if r.comparisons:
            console.print(table)
        else:
            console.print(
                f"{title}: the book prints no number this model can "
                "reproduce; see the figures and the case's notes"
            )
        for f in r.figures:
            console.print(f"  figure: {escape(str(f))}")
    console.print(escape(f"{n_ok}/{n_all} book numbers within tolerance; figures in {out}/"))
