"""Command start-up and run time: from process start to the first output and to the exit.

Every command of the ``servokit`` tree runs as a whole process twice over: with
``--help``, and as a cheap real invocation (the table :data:`REAL`, small sizes; files
written into a scratch directory), as a user at a terminal runs it: stdout a pipe,
stderr a pseudo-terminal (so the start line a long command prints once its arguments are
valid shows, as on a screen). Each run is timed from spawning the process to its first
byte on stdout or stderr (``first_output_s``), to the first byte of the answer on stdout
(``first_stdout_s``) and to its exit (``completion_s``): a start line makes the first
output early but not the work shorter, and the table shows both. The best of the runs is
reported, beside the baseline of a bare ``python -c pass`` of the same interpreter
measured in between (the ratio is what carries across machines and loads). Target
(issue 23): first output within 0.5 s.

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
#: this order: ``settle train`` writes the judge the other ``settle`` commands read). Every
#: run completes (its exit status is checked).
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


def _open_terminal() -> tuple[int, int]:
    """A pseudo-terminal (120 x 40) for the command's stderr: (our end, its end)."""
    import fcntl
    import pty
    import struct
    import termios

    ours, theirs = pty.openpty()
    fcntl.ioctl(theirs, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
    return ours, theirs


def _read_some(fd: int) -> bytes:
    try:
        return os.read(fd, 65536)
    except OSError:  # the terminal's other end closed (EIO on Linux)
        return b""


def run_timed(argv: list[str], cwd: str, src: str | None = None) -> dict[str, object]:
    """Run ``servokit argv`` as a user at a terminal sees it and time it.

    stdout is a pipe (where ``--json`` goes), stderr a pseudo-terminal (where the start
    lines and progress of long commands go, as on a user's screen). Returns the seconds
    from spawning to the first byte on either (``first_output_s``), to the first byte on
    stdout (``first_stdout_s``: the answer itself; None when the command prints none) and
    to the exit (``completion_s``), and the exit status (None: killed after the time
    limit). ``src``: the servokit source tree to run (``PYTHONPATH``), by default the one
    this interpreter finds.
    """
    import select

    env = dict(os.environ, MPLBACKEND="Agg")
    env.pop("SERVOKIT_PROGRESS", None)  # the terminal decides, as for a user
    if src is not None:
        env["PYTHONPATH"] = src
    term, their_term = _open_terminal()
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _ENTRY, *argv], stdout=subprocess.PIPE, stderr=their_term,
        env=env, cwd=cwd,
    )  # fmt: skip
    os.close(their_term)
    assert proc.stdout is not None
    out_fd = proc.stdout.fileno()
    times: dict[str, float | None] = {"first_output_s": None, "first_stdout_s": None}
    open_fds = {out_fd, term}
    while open_fds and time.perf_counter() - start < _TIMEOUT_S:
        ready, _, _ = select.select(list(open_fds), [], [], 1.0)
        for fd in ready:
            if not _read_some(fd):
                open_fds.discard(fd)
                continue
            now = time.perf_counter() - start
            times["first_output_s"] = times["first_output_s"] or now
            if fd == out_fd:
                times["first_stdout_s"] = times["first_stdout_s"] or now
    try:
        code: int | None = proc.wait(timeout=max(1.0, _TIMEOUT_S - (time.perf_counter() - start)))
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        code = None
    completion = time.perf_counter() - start
    proc.stdout.close()
    os.close(term)
    first = times["first_output_s"]
    return {**times, "first_output_s": completion if first is None else first,
            "completion_s": completion, "exit_code": code}  # fmt: skip


def bare_python_s() -> float:
    """Seconds for ``python -c pass`` (the interpreter's own start-up)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.perf_counter() - start


#: Seconds measured per run; the best of the runs is reported for each.
_TIMES = ("first_output_s", "first_stdout_s", "completion_s")


def _best(runs: list[dict[str, object]], key: str) -> float | None:
    values = [r[key] for r in runs if r[key] is not None]
    return min(values) if values else None  # type: ignore[type-var]


def _measure(argv: list[str], runs: int, cwd: str, baseline: str | None) -> dict[str, object]:
    mine, base = [], []
    for _ in range(runs):  # every run completes: first output and completion both count
        mine.append(run_timed(argv, cwd))
        if baseline is not None:  # interleaved, so that both see the same machine load
            base.append(run_timed(argv, cwd, src=baseline))
    bare = min(bare_python_s() for _ in range(runs))
    row: dict[str, object] = {key: _best(mine, key) for key in _TIMES}
    row["bare_python_s"] = bare
    if baseline is not None:
        row |= {f"baseline_{key}": _best(base, key) for key in _TIMES}
    return {**row, "exit_codes": [r["exit_code"] for r in mine]}


def _line(row: dict[str, object]) -> str:
    """One table line: first output, first answer on stdout, completion (and baseline)."""
    ok = "" if all(c == 0 for c in row["exit_codes"]) else " (exit != 0!)"  # type: ignore[attr-defined]
    stdout = row["first_stdout_s"]
    text = (
        f"{row['first_output_s']:7.3f} s first output, "
        f"{'   -   ' if stdout is None else f'{stdout:7.3f}'} s stdout, "
        f"{row['completion_s']:7.3f} s done"
    )
    if "baseline_first_output_s" in row:
        text += (
            f"  (baseline {row['baseline_first_output_s']:.3f} s first, "
            f"{row['baseline_completion_s']:.3f} s done)"
        )
    return f"{text}  (bare python {row['bare_python_s']:.3f} s)  servokit {row['command']}{ok}"


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
            print(_line(row), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(rows, indent=2) + "\n")
    for kind in ("help", "real"):
        sel = [r for r in rows if r["kind"] == kind]
        fast = sum(r["first_output_s"] <= 0.5 for r in sel)
        worst = max(sel, key=lambda r: r["first_output_s"], default=None)
        longest = max(sel, key=lambda r: r["completion_s"], default=None)
        if worst is not None and longest is not None:
            print(
                f"{kind}: first output within 0.5 s: {fast}/{len(sel)}; slowest "
                f"{worst['first_output_s']:.3f} s (servokit {worst['command']}); longest run "
                f"{longest['completion_s']:.3f} s (servokit {longest['command']})"
            )


if __name__ == "__main__":
    main()
