"""CPU time of ``servokit reproduce``: every case, as a user runs it (issue 24).

Runs ``servokit reproduce --out DIR`` in a subprocess (the cases in its worker
processes), reports user + system CPU of the whole process tree
(``resource.getrusage(RUSAGE_CHILDREN)``) and the wall time, and the wall seconds of
each case from its ``results.json`` (``runtime_s``).  Target (issue 24): at most 20 s of
CPU on the 2-core machine class, judged on the best of ``--runs`` runs (3).  Writes
``bench/out/reproduce.json``.

With ``--per-case`` it also runs the cases one after another in this process
(``servokit.cases.runner.iter_cases(workers=1)``, as a one-core machine would) and
reports each case's CPU seconds (``RUSAGE_SELF`` before and after; the first case also
pays the imports).

With ``--baseline SRC`` (the ``src`` directory of another tree, e.g. a ``git worktree``
of ``3ed6d77``, the tree issue 24's work started from; the issue measured main at 57 s)
each run of this tree alternates with a run of that tree's ``servokit reproduce`` (by
``PYTHONPATH``), so a change of the shared host's speed hits both alike, and it reports
the ratio of their best CPU times.  The host-normalised figure is the issue's own
measurement of the baseline divided by that ratio: what this tree would take on the host
the issue was measured on; the target in this form is a ratio of at least 57 / 20 = 2.85.

Run: ``MPLBACKEND=Agg python bench/reproduce_cpu.py [--case NAME ...] [--per-case]
[--out DIR] [--baseline SRC]``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _timing import write_result

_ENTRY = "import sys; from servokit.cli import main; sys.argv[0] = 'servokit'; main()"


#: Issue 24: CPU seconds of ``servokit reproduce`` on the 2-core machine class.
TARGET_CPU_S = 20.0

#: Issue 24: CPU seconds of ``servokit reproduce`` of the tree before its work (3ed6d77),
#: as the issue measured it on a quiet machine; the base of the host-normalised figure.
ISSUE_BASELINE_CPU_S = 57.0

#: Per-run keys kept for every run in ``runs`` (the best run's are also top-level).
_RUN_KEYS = ("user_s", "sys_s", "cpu_s", "wall_s", "load_avg_1min")


def run_reproduce(cases: list[str], out: Path, src: str | None = None) -> dict:
    """Run ``servokit reproduce`` once; CPU [s] of the process tree, wall [s], case times.

    ``src`` (a tree's ``src`` directory) runs that tree's package instead of the
    installed one."""
    argv = [sys.executable, "-c", _ENTRY, "reproduce", "--out", str(out)]
    for name in cases:
        argv += ["--case", name]
    env = dict(os.environ, MPLBACKEND="Agg")
    if src is not None:
        env["PYTHONPATH"] = src
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, env=env)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    doc = json.loads((out / "results.json").read_text(encoding="utf-8"))
    return {
        "user_s": after.ru_utime - before.ru_utime,
        "sys_s": after.ru_stime - before.ru_stime,
        "cpu_s": (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime),
        "wall_s": wall,
        "cores": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "load_avg_1min": os.getloadavg()[0],
        "n_rows": len(doc["rows"]),
        "runtime_s": {c["name"]: c["runtime_s"] for c in doc["cases"]},
    }


def per_case_cpu(cases: list[str], out: Path) -> dict[str, float]:
    """CPU seconds of each case run in turn in this process (one BLAS thread, as reproduce)."""
    from servokit.cases.runner import iter_cases, select_cases

    def cpu() -> float:
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    result: dict[str, float] = {}
    last = cpu()
    for name, _, _ in iter_cases(out, select_cases(cases, None), workers=1):
        now = cpu()
        result[name], last = now - last, now
    return result


def compile_sources(baseline: str | None = None) -> None:
    """Write the bytecode of servokit's sources, as ``make demo`` does (an editable
    install has none, and PYTHONDONTWRITEBYTECODE keeps Python from writing it), and of
    the baseline tree's sources if one is given."""
    import compileall
    import importlib.util

    spec = importlib.util.find_spec("servokit")
    paths = list(spec.submodule_search_locations or []) if spec is not None else []
    for path in paths + ([baseline] if baseline else []):
        compileall.compile_dir(path, quiet=1)


def measure(cases: list[str], out: Path, runs: int, baseline: str | None) -> dict:
    """Best of ``runs`` runs of this tree (every run kept in ``runs``); with a baseline
    tree, its runs alternate with this tree's and the ratio of the best CPU times and the
    host-normalised CPU time are added."""
    mine, theirs = [], []
    for _ in range(max(1, runs)):
        if baseline is not None:
            theirs.append(run_reproduce([], out.with_name(out.name + "-baseline"), baseline))
        mine.append(run_reproduce(cases, out))
    # best of the runs: the host's other tenants only ever add CPU seconds (the same
    # tree measured 19-29 s within an hour on the shared 2-core machine), so the least
    # is the closest to what the code costs; every run is kept in ``runs``
    best = min(mine, key=lambda r: r["cpu_s"])
    res = dict(best, best_of=len(mine), runs=[{k: r[k] for k in _RUN_KEYS} for r in mine])
    res["target_cpu_s"], res["met"] = TARGET_CPU_S, best["cpu_s"] <= TARGET_CPU_S
    if theirs:
        base = min(r["cpu_s"] for r in theirs)
        res["baseline"] = {
            "src": baseline,
            "cpu_s": base,
            "n_rows": theirs[0]["n_rows"],
            "runs": [{k: r[k] for k in _RUN_KEYS} for r in theirs],
        }
        res["ratio"] = base / best["cpu_s"]
        res["target_ratio"] = ISSUE_BASELINE_CPU_S / TARGET_CPU_S
        res["normalised_cpu_s"] = ISSUE_BASELINE_CPU_S / res["ratio"]
        res["met_normalised"] = res["ratio"] >= res["target_ratio"]
    return res


def main() -> None:
    """Measure one run; print the per-case table and write ``bench/out/reproduce.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", action="append", default=[], help="only these cases")
    parser.add_argument("--per-case", action="store_true", help="also CPU s per case, serially")
    parser.add_argument("--out", help="keep the report here (default: a temporary directory)")
    parser.add_argument(
        "--runs", type=int, default=3,
        help="runs into the same --out (from the second on, the pool takes the longest "
        "cases of the last run first, as a user's repeated run does); the headline is "
        "the run with the least CPU",
    )  # fmt: skip
    parser.add_argument(
        "--baseline", metavar="SRC",
        help="src directory of a tree to alternate with (every case; e.g. a worktree of "
        "3ed6d77, the tree issue 24's work started from)",
    )  # fmt: skip
    args = parser.parse_args()
    if args.baseline and args.case:
        parser.error("--baseline compares whole runs: leave out --case")
    if args.baseline and not (Path(args.baseline) / "servokit" / "__init__.py").is_file():
        parser.error(f"--baseline {args.baseline}: no servokit package there (give its src)")
    compile_sources(args.baseline)
    with tempfile.TemporaryDirectory(prefix="servokit-reproduce-") as tmp:
        out = Path(args.out) if args.out else Path(tmp) / "out"
        res = measure(args.case, out, args.runs, args.baseline)
        if args.per_case:
            res["per_case_cpu_s"] = per_case_cpu(args.case, Path(tmp) / "serial")
    cpu_of = res.get("per_case_cpu_s", {})
    print("  wall [s]  CPU [s]  case (wall in the reproduce run; CPU run serially)")
    for name, seconds in sorted(res["runtime_s"].items(), key=lambda kv: -kv[1]):
        print(f"{seconds:10.1f} {cpu_of.get(name, float('nan')):8.2f}  {name}")
    for i, run in enumerate(res["runs"], start=1):
        print(
            f"reproduce run {i}: {run['cpu_s']:.1f} s CPU (user {run['user_s']:.1f} + sys "
            f"{run['sys_s']:.1f}), {run['wall_s']:.1f} s wall on {res['cores']} cores "
            f"(load {run['load_avg_1min']:.1f}); {res['n_rows']} rows"
        )
    print(
        f"{'met ' if res['met'] else 'MISS'}  reproduce CPU, best of {res['best_of']} runs: "
        f"{res['cpu_s']:.1f} s <= {TARGET_CPU_S:g} s (issue 24)"
    )
    if "baseline" in res:
        for i, run in enumerate(res["baseline"]["runs"], start=1):
            print(f"baseline run {i}: {run['cpu_s']:.1f} s CPU (load {run['load_avg_1min']:.1f})")
        print(
            f"{'met ' if res['met_normalised'] else 'MISS'}  baseline / this tree, best CPU: "
            f"{res['ratio']:.2f} >= {res['target_ratio']:.2f}; host-normalised "
            f"{ISSUE_BASELINE_CPU_S:g} s / {res['ratio']:.2f} = {res['normalised_cpu_s']:.1f} s "
            f"(issue 24)"
        )
    write_result("reproduce", res)


if __name__ == "__main__":
    main()
