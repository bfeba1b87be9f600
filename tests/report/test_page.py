"""report/index.html: one self-contained page with the summary tables and every figure.

Checked two ways: its HTML parsed by the standard library (every figure embedded, byte for
byte; nothing fetched from anywhere; the tables carry summary.json's figures), and loaded in
a real headless Chromium (Debian's ``chromium`` + ``chromium-driver``, driven by Selenium):
no console error, every image decoded, and a screenshot of each figure that is not blank.
The browser part is skipped where no Chromium is installed, unless
``RANGEPROC_REQUIRE_BROWSER=1`` (CI sets it and installs Chromium first), then it fails.
"""
from __future__ import annotations

import base64
import io
import json
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
from PIL import Image

from rangeproc.report.page import page_html


class PageParser(HTMLParser):
    """Collects the page's tags with their attributes, and its text."""

    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict[str, str | None]]] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):  # type: ignore[no-untyped-def]
        self.tags.append((tag, dict(attrs)))

    def handle_data(self, data):  # type: ignore[no-untyped-def]
        self.text.append(data)


def parsed(path: Path) -> PageParser:
    p = PageParser()
    p.feed(path.read_text(encoding="utf-8"))
    return p


def test_page_embeds_every_figure_and_fetches_nothing(sample_run) -> None:
    report = sample_run.out_dir / "report"
    page = parsed(report / "index.html")
    pngs = sorted(report.glob("*.png"))
    images = [a for tag, a in page.tags if tag == "img"]
    assert len(images) == len(pngs) >= 8
    embedded = {}
    for a in images:
        src = a["src"] or ""
        assert src.startswith("data:image/png;base64,")
        embedded[a["alt"]] = base64.b64decode(src.split(",", 1)[1])
    for png in pngs:
        assert embedded[png.name] == png.read_bytes()
    for tag, a in page.tags:
        assert tag not in ("script", "link", "iframe", "object", "embed")
        for key in ("src", "href"):
            value = a.get(key) or ""
            assert value.startswith(("data:", "#")) or not value, (tag, key, value[:60])


def test_page_tables_carry_the_summary(sample_run) -> None:
    summary = json.loads((sample_run.out_dir / "summary.json").read_text())
    text = " ".join(parsed(sample_run.out_dir / "report" / "index.html").text)
    for sid, s in summary["sensors"].items():
        assert sid in text and str(s["n_read"]) in text
    for oid, t in summary["targets"].items():
        assert oid in text and str(t["n_epochs"]) in text
    r1 = summary["sensors"]["R1"]
    est = r1["noise"]["azimuth"]["estimated"] * 1e3            # shown in mrad
    assert f"{est:.4g} mrad" in text
    cal = r1["calibration"]["range"]
    assert f"{cal['estimate']:.4g} m ± {cal['sigma']:.4g} m" in text


def test_page_shows_unobservable_terms_with_their_reason(tmp_path: Path) -> None:
    summary = {"sensors": {"G1": {"kind": "gps", "n_read": 5, "calibration": {"latency": {
        "estimate": None, "sigma": None, "unobservable": "GPS is the reference <of time>"}}}},
        "targets": {}}
    html = page_html(summary, [], "t")
    assert "latency: <i>unobservable</i> (GPS is the reference &lt;of time&gt;)" in html


def test_page_shows_where_a_plot_objects_reference_point_can_be() -> None:
    boat = {"extent_sigma_m": {"along": 4.25, "across": 1.5},
            "persistent_offset_sigma_m": {"along": 3.125, "across": 0.0},
            "return_spread_sigma_m": 2.75, "reference_sigma_m": 0.5,
            "unwritten": [[10.0, 22.5], [40.0, 41.0]]}
    aircraft = {"extent_sigma_m": {"along": 0.0, "across": 0.0}, "reference_sigma_m": 0.0,
                "persistent_offset_sigma_m": {"along": 0.0, "across": 0.0},
                "return_spread_sigma_m": 0.0, "unwritten": []}
    html = page_html({"sensors": {}, "targets": {"B1": boat, "T1": aircraft}}, [], "t")
    table = html.split("<h2>Reference point</h2>", 1)[1].split("<h2>", 1)[0]
    assert "4.25 / 1.5" in table and "3.12 / 0" in table and "2.75" in table
    assert "13.5" in table                                     # 12.5 s + 1 s unwritten
    assert "B1" in table and "T1" not in table                 # a point object has no row
    assert "Reference point" not in page_html(
        {"sensors": {}, "targets": {"T1": aircraft}}, [], "t")


# ------------------------------------------------------------------ in a real browser
def test_page_loads_in_chromium_with_every_figure_shown(browser, open_page, sample_run,
                                                        tmp_path) -> None:
    from selenium.webdriver.common.by import By

    errors, images = open_page(sample_run.out_dir / "report" / "index.html")
    assert browser.execute_script("return document.readyState") == "complete"
    assert errors == []
    assert len(images) >= 8 and all(done and width > 300 for _, done, width in images), images
    for img in browser.find_elements(By.TAG_NAME, "img")[:3]:
        browser.execute_script("arguments[0].scrollIntoView()", img)
        shot = np.asarray(Image.open(io.BytesIO(img.screenshot_as_png)).convert("L"), float)
        assert shot.shape[1] > 300
        assert shot.std() > 20 and (shot < 128).mean() > 0.005      # a figure, not blank
    browser.save_screenshot(str(tmp_path / "page.png"))


def test_the_browser_checks_can_fail(open_page, tmp_path: Path) -> None:
    """The console and image checks above see a script error and a missing image."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html><body><img alt="gone" src="missing.png">'
                   "<script>throw new Error('boom')</script></body></html>")
    errors, images = open_page(bad)
    assert any("boom" in e["message"] for e in errors)
    assert images == [["gone", True, 0]]
