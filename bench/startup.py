"""Command start-up: wall time from process start to the first byte of output.

Every command of the ``servokit`` tree runs as a whole process twice over: with
``--help``, and as a cheap real invocation (the table :data:`REAL`, small sizes; files
written into a scratch directory). Each is timed several times from spawning the process
to its first byte on stdout or stderr (the process is then stopped: only the start
matters here); the best run is reported, beside the baseline of a bare ``python -c pass``
of the same interpreter measured in between (the ratio is what carries across machines
and loads). Target (issue 23): first output within 0.5 s.

Run: ``MPLBACKEND=Agg python bench/startup.py [--runs N] [--only WORD] [--out FILE]
[--baseline OTHER/src]``; writes ``bench/out/startup.json`` by default. ``--baseline``
times another source tree (e.g. main's) interleaved with this one, run by run.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FRF = str(ROOT / "examples" / "data" / "stage_frf.csv")
HDD = ["--plant", "hdd-sampled-data", "--controller", "eq-4.69"]
LEAD_LAG = ["--plant", "hdd-benchmark", "--controller", "lead-lag", "--freq", "500"]

#: A cheap real invocation of every command (small sizes; run in a scratch directory, in
#: this order: ``settle train`` writes the judge the other ``settle`` commands read). The
#: first run of each completes (its exit status is checked); later runs stop after the
#: first byte.
REAL: dict[str, list[str]] = {
    "plant list": [],
    "plant show": ["hdd-benchmark", "--json"],
    "plant bode": ["hdd-sampled-data", "--json"],
    "fit": [FRF, "--out", "fitted", "--modes", "2"],
    "simulate": ["--plant", "hdd-benchmark", "--dt", "1e-4", "--duration", "0.01", "--step", "1"],
    "feedforward polynomial": ["--order", "3", "--n-samples", "40", "--dt", "25e-6"],
    "feedforward minimum-jerk": ["--move-time", "1", "--dt", "0.1"],
    "seek": ["--target", "1", "--method", "fsc", "--n-samples", "26"],
    "sweep": ["--method", "fsc", "--tracks", "1", "--n-variants", "100"],
    "switching ivc": [*HDD, "--method", "jmin"],
    "switching admissible-set": [*LEAD_LAG, "--dt", "3.7879e-5", "--u-max", "0.02",
                                 "--condition", "-16:3.9e4"],
    "switching cost-map": [*LEAD_LAG, "--dt", "3.7879e-5", "--position", "-60",
                           "--vel-range", "-1e5:1e5", "--acc-range", "-1e9:1e9"],
    "sensitivity": HDD,
    "unobservable magnitude": ["--freq", "4000", "--dt", "25e-6"],
    "unobservable sampling": ["--freq", "4000", "--damping", "0.01", "--n-samples", "10"],
    "unobservable time": ["--freq", "4000", "--dt", "25e-6", "--damping", "0.01"],
    "srs": ["--input", "half-sine", "--duration", "0.5e-3", "--dt", "25e-6"],
    "identify": ["--plant", "vcm-dual-stage", "--controller", "table-5.2", "--fmin", "1000",
                 "--fmax", "3000", "--freq-step", "1000"],
    "filter notch": ["--freq", "4449", "--damping", "0.09", "--dt", "1e-4"],
    "filter peak": ["--freq", "4449", "--damping", "0.015", "--gain", "0.1778", "--phi",
                    "2.5414"],
    "filter lag": ["--freq", "6900", "--damping", "0.1", "--phase", "1.1519"],
    "filter inverse": ["--zero-freq", "4449", "--pole-freq", "4775"],
    "margins": HDD,
    "loopshape": [FRF, "--dt", "2.5e-5", "--order", "4", "--out", "ctrl"],
    "dual-stage": ["--method", "inverse", "--json"],
    "pes": ["--peak-filter", "960:0.08:12"],
    "ssa ddssa": ["--c-pzt", "2e-9", "--c1", "2e-9", "--c2", "2e-9", "--c3", "2e-9",
                  "--freq", "1000"],
    "ssa idssa": ["--c", "1e-9", "--r", "10e3", "--k", "2"],
    "ssa amd": ["--mode", "5461:2:10", "--mode", "9103:2:10"],
    "ssa adaptive": ["--duration", "2e-4"],
    "limits waterbed": ["--alpha-db", "-40", "--freq", "1000", "--dt", "4e-5"],
    "limits bode-integral": ["--num", "0.5,0.1", "--den", "1,-0.5,0.1", "--dt", "1e-4"],
    "limits variance": ["--num", "40000", "--den", "1,300,0", "--dist-num", "1",
                        "--dist-den", "0.01,1"],
    "limits dynamic-range": ["--stroke-m", "0.03", "--accuracy-m", "3e-9"],
    "settle train": ["--judge", "judge.skops", "--n-distances", "3", "--n-lengths", "3"],
    "settle evaluate": ["--judge", "judge.skops"],
    "settle judge": ["--judge", "judge.skops", "--target", "300", "--n-samples", "50"],
    "export feedforward": ["--method", "fsc", "--target", "10", "--format", "c", "--out", "fw"],
    "export controller": ["--controller", "eq-4.69", "--precision", "q15", "--u-max", "2",
                          "--input-max", "1"],
    "export ivc": ["--method", "pole-zero", "--precision", "q15", "--format", "c"],
    "export table": ["--input", "gains.json", "--precision", "q15", "--format", "c"],
    "report": [*HDD, "--out", "design"],
    "reproduce": ["--case", "resonance-filters", "--out", "reproduced"],
}  # fmt: skip
_ENTRY = "import sys; from servokit.cli import main; sys.argv[0] = 'servokit'; main()"
_TIMEOUT_S = 120.0


def leaf_commands() -> list[str]:
    """Every command of the ``servokit`` tree, as space-separated paths."""
    code = (
        "import servokit.cli as c; c._discover(); root = c._app.build_command()\n"
        "def walk(cmd, path):\n"
        "    subs = getattr(cmd, 'commands', None)\n"
        "    if not subs:\n"
        "        print(' '.join(path))\n"
        "    for name, sub in (subs or {}).items():\n"
        "        walk(sub, [*path, name])\n"
        "walk(root, [])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.split("\n")[:-1]


def first_output_s(
    argv: list[str], cwd: str, finish: bool, src: str | None = None
) -> tuple[float, int | None]:
    """Seconds from spawning ``servokit argv`` to its first byte (stdout or stderr), and
    its exit status; unless ``finish``, a process still running shortly after its first
    byte is stopped (status ``None``): only its start counts. ``src``: the servokit source
    tree to run (``PYTHONPATH``), by default the one this interpreter finds."""
    env = dict(os.environ, MPLBACKEND="Agg")
    if src is not None:
        env["PYTHONPATH"] = src
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _ENTRY, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env=env,
        cwd=cwd,
    )
    assert proc.stdout is not None
    proc.stdout.read(1)
    elapsed = time.perf_counter() - start
    try:
        code: int | None = proc.wait(timeout=_TIMEOUT_S if finish else 2 + 4 * elapsed)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        code = None
    proc.stdout.close()
    return elapsed, code


def bare_python_s() -> float:
    """Seconds for ``python -c pass`` (the interpreter's own start-up)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.perf_counter() - start


def _measure(argv: list[str], runs: int, cwd: str, baseline: str | None) -> dict[str, object]:
    times, codes, base = [], [], []
    for run in range(runs):  # the first run completes: its files and exit status count
        t, code = first_output_s(argv, cwd, finish=run == 0)
        times.append(t)
        codes.append(code)
        if baseline is not None:  # interleaved, so that both see the same machine load
            base.append(first_output_s(argv, cwd, finish=run == 0, src=baseline)[0])
    bare = min(bare_python_s() for _ in range(runs))
    row: dict[str, object] = {"first_output_s": min(times), "bare_python_s": bare}
    if baseline is not None:
        row["baseline_first_output_s"] = min(base)
    return {**row, "exit_codes": codes}


def main() -> None:
    """Measure every command; print a table and write ``bench/out/startup.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--only", default="", help="only commands containing this word")
    parser.add_argument(
        "--baseline", help="another servokit src/ tree (e.g. main's) timed interleaved"
    )
    parser.add_argument("--out", type=Path, default=Path(__file__).parent / "out" / "startup.json")
    args = parser.parse_args()
    leaves = leaf_commands()
    missing = sorted(set(leaves) - set(REAL))
    if missing:
        print(f"warning: no cheap invocation in REAL for: {', '.join(missing)}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="servokit-startup-") as scratch:
        Path(scratch, "gains.json").write_text('{"k": [[1.0, -0.5], [0.25, 2.0]]}\n')
        jobs = [(["--help"], "help")] + [(c.split() + ["--help"], "help") for c in leaves]
        jobs += [(c.split() + REAL[c], "real") for c in REAL if c in leaves]
        for argv, kind in jobs:
            if args.only and args.only not in " ".join(argv):
                continue
            row = {
                "command": " ".join(argv),
                "kind": kind,
                **_measure(argv, args.runs, scratch, args.baseline),
            }
            rows.append(row)
            ok = "" if all(c in (0, None) for c in row["exit_codes"]) else " (exit != 0!)"
            was = row.get("baseline_first_output_s")
            was_text = "" if was is None else f"  (baseline {was:.3f} s)"
            print(
                f"{row['first_output_s']:7.3f} s{was_text}  (bare python "
                f"{row['bare_python_s']:.3f} s)  servokit {row['command']}{ok}",
                flush=True,
            )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=2) + "\n")
    for kind in ("help", "real"):
        sel = [r for r in rows if r["kind"] == kind]
        fast = sum(r["first_output_s"] <= 0.5 for r in sel)
        worst = max(sel, key=lambda r: r["first_output_s"], default=None)
        if worst is not None:
            print(
                f"{kind}: within 0.5 s: {fast}/{len(sel)}; slowest "
                f"{worst['first_output_s']:.3f} s (servokit {worst['command']})"
            )


if __name__ == "__main__":
    main()
