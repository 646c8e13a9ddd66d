"""``servokit reproduce``: run the book's case studies, book value vs servokit value."""

from __future__ import annotations

import json
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from servokit.cases.registry import case_names
from servokit.cli._app import app, console, emit_json, example, progress, wrote
from servokit.errors import check_out_dir


@app.command(
    "reproduce",
    epilog="Cases: "
    + ", ".join(case_names())
    + ".  "
    + example("servokit reproduce --chapter 2 --out out", "servokit reproduce --json"),
)
def reproduce(
    out: Path = typer.Option(
        Path("out"), help="directory for report.html, results.json and the figures"
    ),
    case: list[str] | None = typer.Option(
        None, help="run only these cases (repeatable)", metavar="NAME"
    ),
    chapter: list[int] | None = typer.Option(
        None, help="run only the cases of this book chapter 2-6 (repeatable)", metavar="N"
    ),
    json_out: bool = typer.Option(
        False, "--json", help="print results.json on stdout (nothing else on stdout)"
    ),
    svg: bool = typer.Option(False, "--svg", help="also save every figure as SVG"),
) -> None:
    """Reproduce the book's published numbers and figures; write report.html and results.json.

    results.json: servokit_version, generated_utc, cases (name, title, chapter, runtime_s,
    figures, notes), rows (case, chapter, source, quantity, unit, book, book_text, servokit,
    ratio, tolerance, within_tolerance, kind, note, bound) and summary (counts per chapter).
    """
    from servokit.cases.runner import iter_cases, select_cases
    from servokit.report.files import clear_report, write_report

    out = check_out_dir(out)
    names = select_cases(case, chapter)  # before any file is written
    out.mkdir(parents=True, exist_ok=True)
    clear_report(out)
    results, runtimes = [], {}
    with progress(len(names), "reproducing") as advance:
        # cases in parallel processes when there are cores; one line per case as it is
        # collected, in run order (stderr: --json output stays clean)
        cases = iter_cases(out, names, svg=svg)
        for i, (name, done, seconds) in enumerate(cases, start=1):
            typer.echo(f"[{i}/{len(names)}] {name} done ({seconds:.1f} s)", err=True)
            results += done
            runtimes[name] = seconds
            advance()
    json_path, html_path = write_report(results, out, runtimes)
    wrote(json_path)
    wrote(html_path)
    if json_out:
        emit_json(json.loads(json_path.read_text(encoding="utf-8")))
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
    total = json.loads(json_path.read_text(encoding="utf-8"))["summary"]["total"]
    console.print(
        f"independent reproductions within tolerance: {total['reproduced']}; missed "
        f"{total['missed']}; fitted {total['fitted']}, assumed {total['assumed']}, "
        f"spec {total['spec']}, consistency checks {total['consistency']} (see report.html)"
    )
    console.print(f"report: {html_path.resolve()}")
