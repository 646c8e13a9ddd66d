"""``servokit reproduce --out``: report files, selection, bad input, a run killed mid-way."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import jsonschema
import pytest
from report_page import Page, chromium, rendered_dom

from servokit.report.results import load_schema

# a driver that registers two fake cases (one fast with a figure, one that blocks) and
# runs the real CLI entry point on the given arguments
_DRIVER = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    import matplotlib.pyplot as plt
    from servokit._figures import save_figure
    from servokit.cases import register
    from servokit.report import CaseResult, Comparison

    @register("zz-fast", order=500)
    def fast(out):
        fig, ax = plt.subplots()
        ax.plot([0, 1]); ax.set_title("fake (cf. book Fig. 0.1)")
        png = save_figure(fig, Path(out) / "zz_fast.png")
        rows = [Comparison.printed("q", "1.00", 1.001), Comparison("miss", 1.0, 2.0)]
        return CaseResult("zz-fast", "fast fake", rows, [png], chapter=0)

    @register("zz-slow", order=501)
    def slow(out):
        (Path(out) / "started").touch()
        time.sleep(120)
        return CaseResult("zz-slow", "slow fake", [], [], chapter=0)

    from servokit.cli import main
    sys.argv = ["servokit", *sys.argv[1:]]
    main()
    """
)


def _env() -> dict[str, str]:
    src = str(Path(__file__).resolve().parents[1] / "src")
    return {**os.environ, "PYTHONPATH": src, "MPLBACKEND": "Agg"}


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-c", _DRIVER, *args],
        capture_output=True, text=True, env=_env(), timeout=120,
    )  # fmt: skip


def test_reproduce_writes_report_json_svg(tmp_path: Path) -> None:
    proc = _run("reproduce", "--case", "zz-fast", "--out", str(tmp_path), "--json", "--svg")
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {tmp_path / 'report.html'}" in proc.stderr
    names = {p.name for p in tmp_path.iterdir()}
    assert {"report.html", "results.json", "zz_fast.png", "zz_fast.svg"} <= names
    doc = json.loads((tmp_path / "results.json").read_text())
    assert json.loads(proc.stdout) == doc  # --json prints exactly results.json
    jsonschema.validate(doc, load_schema())
    assert doc["summary"]["total"]["reproduced"] == 1
    assert doc["summary"]["total"]["missed"] == 1
    assert doc["cases"][0]["figures"] == ["zz_fast.png"]


@pytest.mark.parametrize(
    ("args", "flag"),
    [(("--case", "nope"), "--case"), (("--chapter", "9"), "--chapter")],
)
def test_reproduce_bad_selection_exits_2_one_line(
    tmp_path: Path, monkeypatch, capsys, args: tuple[str, ...], flag: str
) -> None:
    from servokit.cli import main

    monkeypatch.setattr(sys, "argv", ["servokit", "reproduce", *args, "--out", str(tmp_path)])
    with pytest.raises(SystemExit) as exc:
        main()
    err = capsys.readouterr().err
    assert exc.value.code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and flag in lines[0] and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # refused before any work


def test_killed_run_leaves_the_previous_report(tmp_path: Path) -> None:
    # the complete report of an earlier run is there: a run killed half-way (its files are
    # staged in OUT/.staging-*) must leave it intact, not mixed with its own new figures
    (tmp_path / "report.html").write_text("<html>old</html>")
    (tmp_path / "results.json").write_text("{}")
    proc = subprocess.Popen(
        [sys.executable, "-c", _DRIVER, "reproduce", "--case", "zz-fast", "--case", "zz-slow",
         "--out", str(tmp_path)],
        env=_env(), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip

    def staged(name: str) -> bool:
        return any((d / name).exists() for d in tmp_path.glob(".staging-*"))

    try:
        deadline = time.monotonic() + 180
        # the cases may run in parallel processes: wait for both to have got going
        while not (staged("started") and staged("zz_fast.png")):
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert (tmp_path / "report.html").read_text() == "<html>old</html>"
    assert (tmp_path / "results.json").read_text() == "{}"
    names = {p.name for p in tmp_path.iterdir()}
    assert "zz_fast.png" not in names  # the killed run's figure stays in its staging dir
    assert not [n for n in names if n.endswith(".tmp")]


@pytest.mark.slow
def test_real_case_twice_same_numbers_and_valid(tmp_path: Path) -> None:
    docs = []
    for run in ("a", "b"):
        proc = subprocess.run(
            [sys.executable, "-c", "from servokit.cli import main; main()", "reproduce",
             "--case", "hdd-residual", "--out", str(tmp_path / run), "--json"],
            capture_output=True, text=True, env=_env(), timeout=300,
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        docs.append(json.loads(proc.stdout))
    for doc in docs:
        jsonschema.validate(doc, load_schema())
    assert docs[0]["rows"] == docs[1]["rows"] and docs[0]["summary"] == docs[1]["summary"]
    assert docs[0]["summary"]["total"]["fitted"] >= 6
    if chromium() is not None:  # the real page in a browser: every figure decodes
        dom, total, loaded = rendered_dom(tmp_path / "a" / "report.html")
        assert total == loaded == len(docs[0]["cases"][0]["figures"]) > 0
        page = Page()
        page.feed(dom)
        assert page.total == docs[0]["summary"]["total"]
