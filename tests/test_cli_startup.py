"""Start-up: parsing any command must not import the heavy libraries.

A correctness check, not a timing test (timings are in ``bench/startup.py``): the CLI's
module tree and the parsing of every command's arguments stay free of python-control,
matplotlib, scipy.signal and scipy.stats, which cost seconds to import; a command imports
them inside the function that needs them.
"""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("control", "matplotlib", "scipy.signal", "scipy.stats", "sklearn", "distributed")

_PROBE = r"""
import sys
import typer.main
import servokit.cli
servokit.cli._discover()
root = typer.main.get_command(servokit.cli.app)
for name, cmd in root.commands.items():
    subs = getattr(cmd, "commands", None) or {"": cmd}
    for sub_name, sub in subs.items():
        ctx = sub.make_context(sub_name or name, ["--help"], resilient_parsing=True)
        sub.get_help(ctx)
print(" ".join(m for m in %r if m in sys.modules))
"""


def test_parsing_every_command_imports_no_heavy_library() -> None:
    # a fresh interpreter: the test session itself has imported everything already
    out = subprocess.run(
        [sys.executable, "-c", _PROBE % (HEAVY,)],
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout.strip()
    assert out == "", f"imported while parsing the CLI: {out}"
