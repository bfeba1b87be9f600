"""The report speaks the engineer's language (issue 28, item 6), on hand-made flights
(``tests/newuser.py``: constant 3000 m above the WGS-84 ellipsoid, 2026-05-11 14:00:00 UTC):

* times as UTC clock time where the calendar is known (ISO GPS stamps + a radar put on the
  Unix scale by ``time_offset``; or ``[output] epoch``), else seconds from start;
* the altitude panel's series is the ellipsoidal height of ``fused.parquet``, not the range
  frame's up (which bends away from it with the Earth's curvature, ~6 m at 9 km);
* the run's warnings in a box at the top of the page; the terminal headline;
* ``--debug`` after the command; ``--format`` repeated; an export of times with no calendar
  says what it did.

One CLI run per case for the module (``conftest.invoke``), read-only afterwards.
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import Result

from conftest import describe, invoke
from newuser import HEIGHT, make_flight
from rangeproc.report.common import ClockLocator, TimeOrigin, day_seconds, t0_note, time_label
from rangeproc.report.page import page_html
from rangeproc.report.trajectory import HEIGHT_LABEL, height_series
from rangeproc.results import TrackEstimate
from rangeproc.timescale import TimeScale, from_summary, time_scale

UTC_START = "2026-05-11 14:00:00.0 UTC"
NO_CALENDAR = "have no known calendar date"


@dataclass(frozen=True)
class Case:
    out: Path
    result: Result

    @property
    def page(self) -> str:
        return (self.out / "report" / "index.html").read_text(encoding="utf-8")

    @property
    def summary(self) -> dict:
        return json.loads((self.out / "summary.json").read_text())


def run_case(folder: Path, output_lines: str = "", **flight) -> Case:  # type: ignore[no-untyped-def]
    f = make_flight(folder, **flight)
    if output_lines:
        text = f.config.read_text()
        f.config.write_text(text.replace("[output]\n", "[output]\n" + output_lines, 1))
    result = invoke(["run", f.config])
    assert result.exit_code == 0, describe(result)
    return Case(folder / "out", result)


@pytest.fixture(scope="module")
def unix(tmp_path_factory: pytest.TempPathFactory) -> Case:
    """GPS with ISO stamps + a seconds-of-day radar with a float time_offset: Unix scale."""
    return run_case(tmp_path_factory.mktemp("unix"))


@pytest.fixture(scope="module")
def sod(tmp_path_factory: pytest.TempPathFactory) -> Case:
    """A radar alone on seconds of day (calendar unknown), exported to KML with the run."""
    return run_case(tmp_path_factory.mktemp("sod"), 'export = ["kml"]\n', with_gps=False)


@pytest.fixture(scope="module")
def sod_epoch(tmp_path_factory: pytest.TempPathFactory) -> Case:
    """The same radar with ``[output] epoch`` = the flight's day: calendar known."""
    return run_case(tmp_path_factory.mktemp("sod_epoch"), 'epoch = "2026-05-11T00:00:00Z"\n',
                    with_gps=False)


def text_of(html: str) -> str:
    return re.sub(r"<[^>]+>", " ", re.sub(r'src="data:[^"]*"', "", html))


# ------------------------------------------------------------------ the rule
def test_the_calendar_rule() -> None:
    unix = time_scale([np.array([1778508000.0, 1778508120.0])])
    assert unix.known and unix.basis == "unix"
    assert unix.clock(1778508012.34) == "2026-05-11 14:00:12.3 UTC"
    for t in ([50400.0, 50520.0], [345600.0, 345720.0], [0.0, 120.0]):   # sod, GPS week, rel.
        scale = time_scale([np.array(t)])
        assert not scale.known and scale.basis == "unknown"
        assert scale.clock(t[0] + 12.34) == "t = 12.3 s from start"
        assert f"{t[0]:.3f} s" in scale.start_text()
    given = time_scale([np.array([50400.0])], "2026-05-11T02:00:00+02:00")
    assert given.basis == "epoch" and given.clock(50400.0) == UTC_START
    assert from_summary({"time_scale": given.as_dict()}) == given
    # an older summary without the entry: the rule on the objects' spans
    assert from_summary({"targets": {"T1": {"t_start": 1778508000.0, "t_end": 1.8e9}}}).known


def test_clock_ticks_fall_on_round_utc_times() -> None:
    scale = time_scale([np.array([1778508007.3])])
    t0 = TimeOrigin(1778508007.3, scale)                  # 14:00:07.3 UTC
    ticks = ClockLocator(day_seconds(scale.utc(t0))).tick_values(0.0, 120.0)
    clock = (ticks + float(t0)) % 60.0
    assert ticks.size >= 4 and np.allclose(np.minimum(clock % 20, 20 - clock % 20), 0, atol=1e-6)
    assert time_label(t0) == "time, UTC on 2026-05-11 [hh:mm:ss]"
    assert t0_note(t0).startswith("t0 = 2026-05-11 14:00:07.3 UTC")
    plain = TimeOrigin(50400.0, time_scale([np.array([50400.0])]))
    assert "from start" in time_label(plain) and "calendar date unknown" in t0_note(plain)
    assert "from start" in time_label(50400.0)           # a plain float: no calendar


# ------------------------------------------------------------------ the page
def test_page_shows_utc_clock_time_on_the_unix_scale(unix: Case) -> None:
    text = text_of(unix.page)
    assert f"start {UTC_START}" in text and "2026-05-11 14:02:00.0 UTC" in text
    assert "1778508000.000 s on the range time scale" in text       # the raw start, once
    assert "1778508000" not in text.replace("1778508000.000 s on the range", "")
    assert unix.summary["time_scale"]["basis"] == "unix"


def test_page_shows_seconds_from_start_when_the_calendar_is_unknown(sod: Case) -> None:
    text = text_of(sod.page)
    assert "t = 0.0 s from start" in text and "t = 120.0 s from start" in text
    assert "50400.000 s on the range time scale" in text and "calendar date unknown" in text
    objects = text[text.index("Objects"):text.index("Sensors")]
    assert "UTC" not in objects and "1970" not in objects
    assert sod.summary["time_scale"] == {"calendar": "unknown", "basis": "unknown",
                                         "epoch": None, "t0": 50400.0}


def test_output_epoch_gives_the_calendar(sod_epoch: Case) -> None:
    text = text_of(sod_epoch.page)
    assert f"start {UTC_START}" in text and "time 0 = [output] epoch" in text
    # a later export without --epoch takes the run's [output] epoch, silently
    result = invoke(["export", sod_epoch.out, "--format", "csv"])
    assert result.exit_code == 0 and result.stderr == "", describe(result)
    utc = pd.read_csv(sod_epoch.out / "fused.csv")["utc"]
    assert utc.iloc[0] == "2026-05-11T14:00:00.000Z"


def test_altitude_series_is_the_fused_ellipsoidal_height(unix: Case) -> None:
    fused = pd.read_parquet(unix.out / "fused.parquet")
    track = TrackEstimate(
        target_id="T1", time=fused["time"].to_numpy(),
        x=fused[["e", "n", "u", "ve", "vn", "vu", "ae", "an", "au"]].to_numpy(),
        P=np.zeros((len(fused), 9, 9)), n_sensors=fused["n_sensors"].to_numpy(),
        lat=fused["lat"].to_numpy(), lon=fused["lon"].to_numpy(),
        height=fused["height"].to_numpy())
    t, h = height_series(track)
    np.testing.assert_array_equal(t, fused["time"].to_numpy())
    np.testing.assert_array_equal(h, fused["height"].to_numpy())
    assert np.abs(h - HEIGHT).max() < 3.0                  # constant within the noise
    assert np.ptp(fused["u"]) > 5.0 > 2 * np.ptp(h)       # the tangent plane's up is not
    assert "ellipsoid" in HEIGHT_LABEL


# ------------------------------------------------------------------ warnings
def test_warnings_box_at_the_top_of_the_page(unix: Case, sod: Case) -> None:
    warnings = sod.summary["warnings"]
    assert any(NO_CALENDAR in w for w in warnings), warnings
    page = sod.page
    box = page.index('<div class="warnings"')
    assert box < page.index("<h2>Objects</h2>")
    assert f"{len(warnings)} warning" in page[box:box + 200]
    assert NO_CALENDAR in page[box:page.index("</div>", box)]
    assert '<p class="nowarn">no warnings</p>' in unix.page
    assert 'class="warnings"' not in unix.page


def test_warnings_box_escapes_its_lines() -> None:
    html = page_html({"warnings": ["R1: <odd> & more"], "targets": {}}, [], "t")
    assert "<li>R1: &lt;odd&gt; &amp; more</li>" in html


# ------------------------------------------------------------------ the terminal
def test_run_prints_the_headline(unix: Case, sod: Case) -> None:
    lines = unix.result.stdout.splitlines()
    assert lines[0].startswith("wrote ") and len(lines) <= 6
    (obj,) = [ln for ln in lines if ln.startswith("T1: ")]
    assert "1,201 epochs, 2026-05-11 14:00:00.0 to 14:02:00.0 UTC" in obj
    median, peak = map(float, re.findall(r"median ([\d.]+) m, max ([\d.]+) m", obj)[0])
    assert 0 < median <= peak
    assert peak == pytest.approx(unix.summary["targets"]["T1"]["max_sigma_position_m"],
                                 abs=0.006)
    assert "0 warnings" in lines
    assert lines[-1] == f"report: {unix.out / 'report' / 'index.html'}"
    sod_lines = sod.result.stdout.splitlines()
    assert any("t = 0.0 to 120.0 s from start" in ln for ln in sod_lines)
    n = len(sod.summary["warnings"])
    assert any(ln.startswith(f"{n} warning") for ln in sod_lines)
    assert NO_CALENDAR in sod.result.stderr


def test_debug_is_accepted_after_the_command(unix: Case) -> None:
    for args in (["export", unix.out, "--format", "csv", "--debug"],
                 ["--debug", "export", unix.out, "--format", "csv"]):
        result = invoke(args)
        assert result.exit_code == 0, describe(result)
    result = invoke(["export", unix.out, "--format", "nope", "--debug"])
    assert result.exit_code == 2                          # still a one-line input error
    assert "--format: unknown format 'nope'" in result.stderr


def test_run_accepts_debug_after_the_config(tmp_path: Path) -> None:
    f = make_flight(tmp_path, with_gps=False)
    result = invoke(["run", f.config, "--quiet", "--debug"])
    assert result.exit_code == 0, describe(result)
    assert "rangeproc: INFO: " in result.stderr          # streamed as with rangeproc --debug


# ------------------------------------------------------------------ export
def test_format_repeated_or_comma_separated(unix: Case) -> None:
    for name in ("fused.kml", "fused.czml", "fused.csv"):
        (unix.out / name).unlink(missing_ok=True)
    result = invoke(["export", unix.out, "--format", "kml", "--format", "czml"])
    assert result.exit_code == 0, describe(result)
    assert (unix.out / "fused.kml").exists() and (unix.out / "fused.czml").exists()
    assert not (unix.out / "fused.csv").exists()
    assert result.stderr == ""                            # Unix times: no calendar warning
    result = invoke(["export", unix.out, "--format", "czml,csv"])
    assert result.exit_code == 0 and (unix.out / "fused.csv").exists()
    result = invoke(["export", unix.out, "--format", "kml", "czml"])
    assert result.exit_code == 2
    assert "--format kml --format czml, or --format kml,czml" in result.stderr


def test_export_without_a_calendar_says_what_it_did(sod: Case) -> None:
    result = invoke(["export", sod.out, "--format", "kml"])
    assert result.exit_code == 0, describe(result)
    (line,) = [ln for ln in result.stderr.splitlines() if NO_CALENDAR in ln]
    assert line.startswith("rangeproc: WARNING: export: the times (50400 to 50520 s)")
    assert "taken as seconds from 1970-01-01T00:00:00Z" in line
    assert "start at 1970-01-01T14:00:00Z" in line and "--epoch" in line
    assert "<when>1970-01-01T14:00:00.000Z</when>" in (sod.out / "fused.kml").read_text()
    result = invoke(["export", sod.out, "--format", "kml", "--epoch", "2026-05-11T00:00:00Z"])
    assert result.exit_code == 0 and result.stderr == "", describe(result)
    assert "<when>2026-05-11T14:00:00.000Z</when>" in (sod.out / "fused.kml").read_text()


def test_time_scale_of_no_times() -> None:
    scale = time_scale([np.zeros(0)])
    assert scale == TimeScale(None, "unknown", scale.start) and np.isnan(scale.start)
