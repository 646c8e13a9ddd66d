"""Every script in examples/ runs top to bottom (small sizes), prints its results and
writes every file it says it wrote."""

from __future__ import annotations

import re
import runpy
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_one_example_per_chapter() -> None:
    chapters = {m.group(1) for p in EXAMPLES if (m := re.match(r"chapter(\d)", p.name))}
    assert {"2", "3", "4", "5", "6"} <= chapters


def test_every_example_is_in_the_docs() -> None:
    page = (ROOT / "docs" / "reference" / "examples.rst").read_text(encoding="utf-8")
    included = set(re.findall(r"literalinclude:: \.\./\.\./examples/(\S+\.py)", page))
    assert included == {p.name for p in EXAMPLES}


def _param(script: Path) -> object:
    # an example that honours SERVOKIT_EXAMPLE_SMALL runs in the default suite; one that
    # does not (always full size) runs with the slow tests (make test-all)
    small = "SERVOKIT_EXAMPLE_SMALL" in script.read_text(encoding="utf-8")
    return pytest.param(script, id=script.stem, marks=() if small else pytest.mark.slow)


@pytest.mark.parametrize("script", [_param(p) for p in EXAMPLES])
def test_example_runs(script: Path, tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("SERVOKIT_EXAMPLE_SMALL", "1")
    monkeypatch.setattr(sys, "argv", [str(script), str(tmp_path)])
    runpy.run_path(str(script), run_name="__main__")
    out = capsys.readouterr().out
    written = [
        Path(line.split(" ", 1)[1]) for line in out.splitlines() if line.startswith("wrote ")
    ]
    assert out.strip(), "an example prints what it computes"
    for path in written:
        assert path.is_file() and path.stat().st_size > 0
