"""report.html: generic rendering, embedded figures that load, summary equal to results.json."""

from __future__ import annotations

import base64
import io
import json
import subprocess
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from PIL import Image
from report_page import Page, chromium, rendered_dom

from servokit._figures import also_save_as, save_figure
from servokit.report import CaseResult, Comparison
from servokit.report.files import write_report
from servokit.report.html import figure_caption, render_html


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
        CaseResult(
            "fake-a",
            "Fake case A",
            rows,
            [png],
            {"delay_convention": "no delay", "n": 3},
            chapter=2,
        ),
        CaseResult("fake-b", "Fake case B", [Comparison("x", 1.0, 1.0)], [], chapter=5),
    ]


@pytest.fixture
def report(tmp_path: Path) -> Path:
    write_report(_fake_results(tmp_path), tmp_path, {"fake-a": 0.1})
    return tmp_path


def test_every_image_loads_and_summary_equals_results_json(report: Path) -> None:
    page = Page()
    page.feed((report / "report.html").read_text(encoding="utf-8"))
    assert len(page.images) == 1
    for src in page.images:
        assert src.startswith("data:image/png;base64,")  # self-contained
        Image.open(io.BytesIO(base64.b64decode(src.split(",", 1)[1]))).verify()
    doc = json.loads((report / "results.json").read_text())
    assert page.total == doc["summary"]["total"]
    assert page.total["rows"] == 4 and page.total["not_comparable"] == 1
    assert page.total["miss_open"] == 1  # the printed 0.26 miss carries no class


def test_misses_are_listed_per_chapter_open_first(tmp_path: Path) -> None:
    rows = [
        Comparison("classified", 4.5, 4.13, rel_tol=0.0, miss_class="book_inconsistent",
                   miss_note="the book's controller gives 4.13 dB"),
        Comparison("unexplained", 17.0, 15.0, rel_tol=0.0),
        Comparison("study", 0.333, 0.341, kind="informational"),
    ]  # fmt: skip
    write_report([CaseResult("c", "C", rows, [], chapter=4)], tmp_path)
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    table = html[html.index('id="misses-4"') :]
    assert table.index("unexplained") < table.index("classified")
    assert "the book&#39;s controller gives 4.13 dB" in html
    assert "informational:</span> study" in html
    assert json.loads((tmp_path / "results.json").read_text())["$schema"] == "results.schema.json"
    assert (tmp_path / "results.schema.json").exists()


def test_rows_kinds_notes_and_caption_render_escaped(report: Path) -> None:
    html = (report / "report.html").read_text(encoding="utf-8")
    assert "Step &lt;response&gt; (cf. book Fig. 9.9)" in html  # caption from the PNG title
    assert "<response>" not in html
    assert "fitted:</span> fitted delay" in html and "fitted: Mf" in html
    assert "not judged" in html and 'href="fake_fig_9_9.svg"' in html
    assert html.index("chapter-2") < html.index("chapter-5")
    assert ">0.26<" in html  # the book number as printed
    assert "<em>delay convention:</em> no delay" in html  # text extras are case notes


def test_caption_falls_back_to_file_name(tmp_path: Path) -> None:
    assert figure_caption(tmp_path / "missing_fig.png") == "missing fig"


def test_caption_is_read_without_decoding_the_image(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import matplotlib.pyplot as plt
    from PIL import PngImagePlugin

    from servokit._figures import save_figure

    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    fig.suptitle("Seek <time> (Fig. 2.9)")
    path = save_figure(fig, tmp_path / "seek.png")

    def no_decoding(self: object) -> None:
        raise AssertionError("the caption decoded the image")

    monkeypatch.setattr(PngImagePlugin.PngImageFile, "load", no_decoding)
    assert figure_caption(path) == "Seek <time> (Fig. 2.9)"


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


@pytest.mark.skipif(
    chromium() is None,
    reason="headless Chromium (Debian package 'chromium') is not installed",
)
def test_headless_chromium_images_load_and_summary_matches(report: Path) -> None:
    dom, total, loaded = rendered_dom(report / "report.html")
    assert total == loaded == 1
    page = Page()
    page.feed(dom)  # the summary as the browser rendered it
    doc = json.loads((report / "results.json").read_text())
    assert page.total == doc["summary"]["total"]
    shot = report / "screenshot.png"
    subprocess.run(
        [chromium(), "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={shot}",
         "--window-size=1200,2000", (report / "report.html").as_uri()],
        check=True, timeout=120, capture_output=True,
    )  # fmt: skip
    with Image.open(shot) as img:
        assert img.size == (1200, 2000)
        assert len(set(img.convert("L").getdata())) > 10  # not a blank page
