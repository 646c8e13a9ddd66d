"""report.html: generic rendering, embedded figures that load, summary equal to results.json."""

from __future__ import annotations

import base64
import io
import json
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from PIL import Image

from servokit._figures import also_save_as, save_figure
from servokit.report import CaseResult, Comparison
from servokit.report.html import figure_caption, render_html
from servokit.report.output import write_report


class _Page(HTMLParser):
    """Collects image sources and the summary cells (data-key) of the total row."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.total: dict[str, int] = {}
        self._in_total = False
        self._key: str | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "img":
            self.images.append(a["src"] or "")
        if tag == "tr":
            self._in_total = a.get("id") == "summary-total"
        if self._in_total and "data-key" in a:
            self._key = a["data-key"]

    def handle_data(self, data: str) -> None:
        if self._key and data.strip():
            self.total[self._key] = int(data)
            self._key = None


def _fake_results(outdir: Path) -> list[CaseResult]:
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1], label="y")
    ax.set_title("Step <response> (cf. book Fig. 9.9)")
    ax.legend()
    with also_save_as("svg"):
        png = save_figure(fig, outdir / "fake_fig_9_9.png")
    rows = [
        Comparison.printed("seek time", "0.26", 0.2714, unit="ms", source="Fig. 9.9"),
        Comparison("fitted delay", 20.0, 20.0, unit="us", kind="fitted", note="fitted: Mf"),
        Comparison("no book number", float("nan"), 1.0, kind="assumed", note="omitted"),
    ]
    return [
        CaseResult("fake-a", "Fake case A", rows, [png], chapter=2),
        CaseResult("fake-b", "Fake case B", [Comparison("x", 1.0, 1.0)], [], chapter=5),
    ]


@pytest.fixture
def report(tmp_path: Path) -> Path:
    write_report(_fake_results(tmp_path), tmp_path, {"fake-a": 0.1})
    return tmp_path


def test_every_image_loads_and_summary_equals_results_json(report: Path) -> None:
    page = _Page()
    page.feed((report / "report.html").read_text(encoding="utf-8"))
    assert len(page.images) == 1
    for src in page.images:
        assert src.startswith("data:image/png;base64,")  # self-contained
        Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1]))).verify()
    doc = json.loads((report / "results.json").read_text())
    assert page.total == doc["summary"]["total"]
    assert page.total["rows"] == 4 and page.total["not_comparable"] == 1


def test_rows_kinds_notes_and_caption_render_escaped(report: Path) -> None:
    html = (report / "report.html").read_text(encoding="utf-8")
    assert "Step &lt;response&gt; (cf. book Fig. 9.9)" in html  # caption from the PNG title
    assert "<response>" not in html
    assert "fitted:</span> fitted delay" in html and "fitted: Mf" in html
    assert "not judged" in html and 'href="fake_fig_9_9.svg"' in html
    assert html.index("chapter-2") < html.index("chapter-5")
    assert ">0.26<" in html  # the book number as printed


def test_caption_falls_back_to_file_name(tmp_path: Path) -> None:
    assert figure_caption(tmp_path / "missing_fig.png") == "missing fig"


def test_second_render_is_identical_but_for_the_date(tmp_path: Path) -> None:
    results = _fake_results(tmp_path)
    write_report(results, tmp_path)
    first = json.loads((tmp_path / "results.json").read_text())
    write_report(results, tmp_path)
    second = json.loads((tmp_path / "results.json").read_text())
    first.pop("generated_utc"), second.pop("generated_utc")
    assert first == second


def test_render_with_no_cases(tmp_path: Path) -> None:
    from servokit.report.results import results_document

    html = render_html(results_document([], outdir=tmp_path), tmp_path)
    assert "Summary" in html


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(
    _chromium() is None,
    reason="headless Chromium (Debian package 'chromium') is not installed",
)
def test_headless_chromium_images_load_and_summary_matches(report: Path) -> None:
    exe = _chromium()
    url = (report / "report.html").as_uri()
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000"]
    dom = subprocess.run(
        [exe, *flags, "--dump-dom", url], check=True, timeout=120, capture_output=True, text=True
    ).stdout
    total = re.search(r'data-images-total="(\d+)"', dom)
    loaded = re.search(r'data-images-loaded="(\d+)"', dom)
    assert total and loaded and int(total.group(1)) == int(loaded.group(1)) == 1
    page = _Page()
    page.feed(dom)  # the summary as the browser rendered it
    doc = json.loads((report / "results.json").read_text())
    assert page.total == doc["summary"]["total"]
    shot = report / "screenshot.png"
    subprocess.run(
        [exe, *flags, f"--screenshot={shot}", "--window-size=1200,2000", url],
        check=True, timeout=120, capture_output=True,
    )  # fmt: skip
    with Image.open(shot) as img:
        assert img.size == (1200, 2000)
        assert len(set(img.convert("L").getdata())) > 10  # not a blank page
