"""``servokit reproduce``: run the book's case studies, book value vs servokit value."""

from __future__ import annotations

import re
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from servokit.cli._app import app, console, emit_json, example
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
        if not path.name.startswith("_"):
            text = path.read_text(encoding="utf-8")
            found += [(int(order or 100), name) for name, order in _REGISTER.findall(text)]
    return [name for _, name in sorted(found)]


@app.command(
    "reproduce",
    help="Reproduce the book's published numbers and figures.\n\nCases: " + ", ".join(case_names()),
    epilog=example("servokit reproduce --out out --case hdd-seek"),
)
def reproduce(
    out: Path = typer.Option(Path("out"), help="directory for the figures"),
    case: list[str] | None = typer.Option(None, help="run only these cases (repeatable)"),
    json_out: bool = typer.Option(False, "--json", help="machine-readable output"),
) -> None:
    out = check_out_dir(out)
    from servokit.cases import registry, run_all

    unknown = [c for c in case or [] if c not in registry()]
    if unknown:  # before run_all creates --out
        raise ServokitValueError(
            f"--case {unknown[0]!r} is unknown; choose one of {', '.join(registry())}"
        )
    results = run_all(out, only=case or None)
    if json_out:
        emit_json(
            [
                {
                    "case": r.name,
                    "title": r.title,
                    "comparisons": [
                        {
                            "quantity": c.quantity,
                            "book": c.book,
                            "servokit": c.servokit,
                            "ratio": c.ratio,
                            "unit": c.unit,
                            "rel_tol": c.rel_tol,
                            "ok": c.ok,
                            "source": c.source,
                        }
                        for c in r.comparisons
                    ],
                    "figures": [str(f) for f in r.figures],
                }
                for r in results
            ]
        )
        return
    n_ok = n_all = 0
    for r in results:
        table = Table(title=escape(f"{r.title}  [{r.name}]"), title_justify="left")
        for col in ("quantity", "book", "servokit", "ratio", "tol", "ok"):
            table.add_column(col, justify="left" if col == "quantity" else "right")
        for c in r.comparisons:
            n_all += 1
            n_ok += c.ok
            table.add_row(
                escape(f"{c.quantity} [{c.unit}]" if c.unit else c.quantity),
                f"{c.book:.7g}",
                f"{c.servokit:.7g}",
                f"{c.ratio:.4f}",
                f"{c.rel_tol * 100:.3g}%",
                "[green]yes[/green]" if c.ok else "[red]no[/red]",
            )
        if r.comparisons:
            console.print(table)
        else:
            console.print(
                f"{escape(r.title)}  \\[{r.name}]: the book prints no number this model can "
                "reproduce; see the figures and the case's notes"
            )
        for f in r.figures:
            console.print(f"  figure: {f}")
    console.print(f"{n_ok}/{n_all} book numbers within tolerance; figures in {out}/")
