"""Helpers of the report tests: read the summary and images of report.html, in Chromium."""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path


class Page(HTMLParser):
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


def chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


def rendered_dom(html: Path) -> tuple[str, int, int]:
    """The DOM Chromium renders for ``html`` and its (total, loaded) image counts."""
    exe = chromium()
    assert exe is not None
    dom = subprocess.run(
        [exe, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
         "--dump-dom", html.as_uri()],
        check=True, timeout=120, capture_output=True, text=True,
    ).stdout  # fmt: skip
    total = re.search(r'data-images-total="(\d+)"', dom)
    loaded = re.search(r'data-images-loaded="(\d+)"', dom)
    assert total and loaded, "the page's load script did not run"
    return dom, int(total.group(1)), int(loaded.group(1))
