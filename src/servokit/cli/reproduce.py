"""``servokit reproduce``: run the book's case studies, book value vs servokit value."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import typer
from rich.markup import escape
from rich.table import Table

from servokit.cases.registry import case_names
from servokit.cli._app import app, console, emit_json, example, progress, started, wrote
from servokit.errors import check_out_dir


def _unique(values: list | None) -> list | None:
    """``--case X --case X`` runs X once (order kept)."""
    return None if values is None else list(dict.fromkeys(values))


@app.command(
    "reproduce",
    epilog="Cases: "
    + ", ".join(case_names())
    + ".  "
    + example("servokit reproduce --chapter 2 --out out", "servokit reproduce --json"),
)
def reproduce(
    out: str = typer.Option(
        "out", "--out", help="directory for report.html, results.json and the figures",
        metavar="DIR",
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
    from servokit.cases.runner import select_cases

    out_dir = check_out_dir(out)  # "" refused (typer would have made it ".")
    names = select_cases(_unique(case), _unique(chapter))  # before any file is written
    results, doc = _run_cases(out_dir, names, svg)
    wrote(out_dir / "results.json")
    wrote(out_dir / "report.html")
    if json_out:
        emit_json(doc)
        return
    render_reproduce(results, doc, out_dir)


def _run_cases(out_dir: Path, names: list[str], svg: bool) -> tuple[list, dict]:
    """Run the cases into a staging directory swapped in at the end; (results, results.json).

    One run's files, swapped in under a lock: an interrupted or failed run leaves the
    previous report intact; a concurrent run on the same ``--out`` is refused.
    """
    from servokit._io import staged_output
    from servokit.cases.runner import default_workers, iter_cases, previous_runtimes
    from servokit.report.files import write_report

    results, runtimes = [], {}
    # the last run's case times, read before this run replaces them: longest cases first
    costs = previous_runtimes(out_dir / "results.json")
    with staged_output(out_dir) as stage:
        # after the lock: a refused second writer prints its one error line only
        workers = min(default_workers(), len(names))
        started("reproduce", f"{len(names)} case(s) on up to {workers} process(es) -> {out_dir}/")
        with progress(len(names), "reproducing") as advance:
            # cases in parallel processes when there are cores; one line per case as it is
            # collected, in run order (stderr: --json output stays clean)
            cases = iter_cases(stage, names, svg=svg, costs=costs)
            for i, (name, done, seconds) in enumerate(cases, start=1):
                typer.echo(f"[{i}/{len(names)}] {name} done ({seconds:.1f} s)", err=True)
                results += done
                runtimes[name] = seconds
                advance()
        doc = json.loads(write_report(results, stage, runtimes)[0].read_text(encoding="utf-8"))
    return results, doc


def _case_table(r: Any) -> Table:
    """Book value vs servokit value of one case's comparisons."""
    table = Table(title=escape(f"{r.title}  [{r.name}]"), title_justify="left")
    for col in ("quantity", "book", "servokit", "ratio", "tol", "ok"):
        table.add_column(col, justify="left" if col == "quantity" else "right")
    for c in r.comparisons:
        table.add_row(
            escape(f"{c.quantity} [{c.unit}]" if c.unit else c.quantity),
            f"{c.book:.7g}",
            f"{c.servokit:.7g}",
            f"{c.ratio:.4f}",
            f"{c.rel_tol * 100:.3g}%",
            "[green]yes[/green]" if c.ok else "[red]no[/red]",
        )
    return table


def render_reproduce(results: list, doc: dict, out_dir: Path) -> None:
    """Print each case's table and figures, then the summary of results.json.

    Parameters
    ----------
    results : list of CaseResult
        The cases run.
    doc : dict
        results.json as written.
    out_dir : Path
        ``--out``.
    """
    for r in results:
        if r.comparisons:
            console.print(_case_table(r))
        else:
            console.print(
                f"{escape(r.title)}  \\[{r.name}]: the book prints no number this model can "
                "reproduce; see the figures and the case's notes"
            )
        for f in r.figures:
            console.print(f"  figure: {out_dir / Path(f).name}")
    n_all = sum(len(r.comparisons) for r in results)
    n_ok = sum(c.ok for r in results for c in r.comparisons)
    console.print(f"{n_ok}/{n_all} book numbers within tolerance; figures in {out_dir}/")
    total = doc["summary"]["total"]
    console.print(
        f"independent reproductions within tolerance: {total['reproduced']}; missed "
        f"{total['missed']}; fitted {total['fitted']}, assumed {total['assumed']}, "
        f"spec {total['spec']}, consistency checks {total['consistency']} (see report.html)"
    )
    console.print(f"report: {(out_dir / 'report.html').resolve()}")
