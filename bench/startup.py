"""Command start-up: wall time from process start to the first byte of output.

Each command runs as a whole process (``python -m servokit.cli``-equivalent console
entry) several times; the best run is reported, beside the baseline of a bare
``python -c pass`` of the same interpreter measured in between (the ratio is what
carries across machines). Target (issue 23): first output within 0.5 s.

Run: ``MPLBACKEND=Agg python bench/startup.py [--runs N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

COMMANDS = (
    ["--help"],
    ["seek", "--help"],
    ["plant", "list"],
    ["limits", "dynamic-range", "--stroke-m", "0.03", "--accuracy-m", "3e-9"],
    ["limits", "waterbed", "--alpha-db", "-40", "--freq", "1000", "--dt", "4e-5"],
    ["filter", "notch", "--freq", "4449", "--damping", "0.09", "--dt", "1e-4"],
    ["simulate", "--plant", "hdd-benchmark", "--dt", "1e-4", "--duration", "0.01", "--step", "1"],
)
_ENTRY = "import sys; from servokit.cli import main; sys.argv[0] = 'servokit'; main()"


def first_output_s(argv: list[str]) -> float:
    """Seconds from spawning ``servokit argv`` to its first byte on stdout or stderr."""
    env = dict(os.environ, MPLBACKEND="Agg")
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _ENTRY, *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env=env,
    )
    assert proc.stdout is not None
    proc.stdout.read(1)
    elapsed = time.perf_counter() - start
    proc.stdout.read()
    proc.wait()
    return elapsed


def bare_python_s() -> float:
    """Seconds for ``python -c pass`` (the interpreter's own start-up)."""
    start = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.perf_counter() - start


def main() -> None:
    """Measure every command; print a table and write ``bench/out/startup.json``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    runs = parser.parse_args().runs
    rows = []
    for argv in COMMANDS:
        best = min(first_output_s(argv) for _ in range(runs))
        bare = min(bare_python_s() for _ in range(runs))
        rows.append({"command": " ".join(argv), "first_output_s": best, "bare_python_s": bare})
        print(f"{best:7.3f} s  (bare python {bare:.3f} s)  servokit {' '.join(argv)}")
    out = Path(__file__).parent / "out"
    out.mkdir(exist_ok=True)
    (out / "startup.json").write_text(json.dumps(rows, indent=2) + "\n")
    print(f"within 0.5 s: {sum(r['first_output_s'] <= 0.5 for r in rows)}/{len(rows)}")


if __name__ == "__main__":
    main()
