"""Tacview ACMI 2.2 export, read back by a parser written here from the specification.

Specification: "Technical Reference - ACMI flight recordings 2.2",
https://www.tacview.net/documentation/acmi/en/ . The parser below follows it and shares no
code with ``rangeproc.interchange.acmi``: a header of two mandatory lines; then per line a
time frame ``#<seconds after ReferenceTime>``, an object line ``<hex id>,<prop>=<value>,...``
(object 0: global properties), or a removal ``-<hex id>``; text values escape a comma as
``\\,`` and an end of line with a backslash before it; ``T`` is ``lon|lat|alt`` (optionally
followed by U|V, roll|pitch|yaw, or all of them), a component left empty keeps its last value,
and longitude and latitude are offsets from ReferenceLongitude / ReferenceLatitude when given;
lines starting with ``//`` are comments. A zipped recording is a zip holding the text.
Calendar times are checked with ``datetime`` arithmetic.
"""
from __future__ import annotations

import io
import logging
import re
import zipfile
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from conftest import SAMPLE_CONFIG, copy_sample, describe, invoke
from rangeproc.config import load_config
from rangeproc.interchange import export_run
from rangeproc.interchange.trajectories import object_trajectories, to_utc
from rangeproc.timescale import parse_epoch

EPOCH = "2026-05-10T00:00:00Z"                 # GPS week start for the sample's seconds of week
EPOCH_UTC = datetime(2026, 5, 10, tzinfo=timezone.utc)
#: What the export promises: 1e-7 degree, 0.01 m, and times exact to the nanosecond.
DEG_TOL, ALT_TOL, TIME_TOL = 0.5e-7 + 1e-12, 0.005 + 1e-9, 1e-6


# ------------------------------------------------------------------------------------------
# A reader of ACMI 2.2 written from the specification
# ------------------------------------------------------------------------------------------

@dataclass
class AcmiObject:
    props: dict[str, str] = field(default_factory=dict)
    samples: list[tuple[float, float, float, float]] = field(default_factory=list)  # t,lon,lat,alt
    removed: list[float] = field(default_factory=list)        # frame offsets of its removals
    last_t: list[float | None] = field(default_factory=lambda: [None, None, None])


@dataclass
class Acmi:
    header: dict[str, str]
    globals: dict[str, str]
    frames: list[float]
    objects: dict[int, AcmiObject]

    @property
    def reference_time(self) -> datetime:
        return datetime.fromisoformat(self.globals["ReferenceTime"].replace("Z", "+00:00"))


def read_acmi(data: bytes) -> Acmi:
    """Parse an ACMI 2.2 recording (text, UTF-8 with or without BOM, or zipped)."""
    if data[:4] == b"PK\x03\x04":                             # zip container
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            (member,) = archive.namelist()
            data = archive.read(member)
    text = data.decode("utf-8")
    text = text.removeprefix("\ufeff")
    raw = text.replace("\r\n", "\n").split("\n")
    lines: list[str] = []
    pending = ""
    for line in raw:                      # an end of line escaped by a backslash continues
        if _escaped_end(line):
            pending += line[:-1] + "\n"
            continue
        lines.append(pending + line)
        pending = ""
    assert not pending, "file ends inside a continued line"
    body = [ln for ln in lines if ln.strip()]
    header = dict(ln.split("=", 1) for ln in body[:2])
    assert header.get("FileType") == "text/acmi/tacview", body[:2]
    assert header.get("FileVersion") == "2.2", body[:2]
    acmi = Acmi(header, {}, [], {})
    now = 0.0
    for line in body[2:]:
        if line.startswith("//"):
            continue
        if line.startswith("#"):
            now = float(line[1:])
            acmi.frames.append(now)
        elif line.startswith("-"):
            acmi.objects[int(line[1:], 16)].removed.append(now)
        else:
            ident, *props = [_unescape(p) for p in re.split(r"(?<!\\),", line)]
            oid = int(ident, 16)
            pairs = [p.split("=", 1) for p in props]
            if oid == 0:
                acmi.globals.update(pairs)
                continue
            obj = acmi.objects.setdefault(oid, AcmiObject())
            for key, value in pairs:
                if key == "T":
                    obj.samples.append((now, *_transform(acmi.globals, obj, value)))
                else:
                    obj.props[key] = value
    return acmi


def _escaped_end(line: str) -> bool:
    trailing = len(line) - len(line.rstrip("\\"))
    return trailing % 2 == 1


def _unescape(value: str) -> str:
    return value.replace("\\,", ",")


def _transform(globals_: dict[str, str], obj: AcmiObject, value: str) -> tuple[float, ...]:
    parts = value.split("|")
    assert len(parts) in (3, 5, 6, 9), value
    for j in range(3):                                   # empty: unchanged since last time
        if parts[j] != "":
            obj.last_t[j] = float(parts[j])
    lon, lat, alt = obj.last_t
    assert lon is not None and lat is not None and alt is not None, value
    return (lon + float(globals_.get("ReferenceLongitude", 0)),
            lat + float(globals_.get("ReferenceLatitude", 0)), alt)


def by_name(acmi: Acmi) -> dict[str, AcmiObject]:
    named = {o.props["Name"]: o for o in acmi.objects.values()}
    assert len(named) == len(acmi.objects), "object names are not unique"
    return named


def test_the_reader_follows_the_specification_s_examples() -> None:
    """The reader on the specification's own examples, plus a comment and a continued line."""
    text = ("\ufeffFileType=text/acmi/tacview\nFileVersion=2.2\n"
            "0,ReferenceTime=2011-06-02T05:00:00Z\n"
            "0,Briefing=Here is a text value\\, which contains an escaped comma in it!\n"
            "0,Comments=two\\\nlines\n"
            "// a comment\n"
            "#47.13\n3000102,T=41.6251307|41.5910417|2000.14,Name=C172\n"
            "#49\n3000102,T=41.626||\n#50\n-3000102\n")
    acmi = read_acmi(text.encode())
    assert acmi.reference_time == datetime(2011, 6, 2, 5, tzinfo=timezone.utc)
    assert acmi.globals["Briefing"] == ("Here is a text value, which contains an escaped "
                                        "comma in it!")
    assert acmi.globals["Comments"] == "two\nlines"
    c172 = acmi.objects[0x3000102]
    assert c172.props["Name"] == "C172" and c172.removed == [50.0]
    assert c172.samples == [(47.13, 41.6251307, 41.5910417, 2000.14),
                            (49.0, 41.626, 41.5910417, 2000.14)]
    zipped = io.BytesIO()
    with zipfile.ZipFile(zipped, "w") as archive:
        archive.writestr("x.txt.acmi", text.encode())
    assert read_acmi(zipped.getvalue()) == acmi


# ------------------------------------------------------------------------------------------
# Checks shared by the tests
# ------------------------------------------------------------------------------------------

def check_tracks(acmi: Acmi, table: pd.DataFrame, epoch_utc: datetime,
                 interval_s: float = 0.0) -> None:
    """Every fused object of ``table`` is an ACMI object with each of its (thinned) epochs:
    time = ReferenceTime + frame offset = epoch + fused time, position = fused lat, lon,
    height within the written precision; removed once, at its last epoch, never seen after."""
    assert acmi.frames == sorted(set(acmi.frames)), "frames not in strictly ascending time"
    utc = to_utc(table["time"].to_numpy(), parse_epoch(epoch_utc.isoformat()), "fused")
    expected = object_trajectories(table, utc, interval_s)
    named = by_name(acmi)
    assert {o.id for o in expected} <= set(named)
    for obj in expected:
        got = named[obj.id]
        assert got.props["Type"] == "Air+FixedWing" and got.props.get("Color")
        t, lon, lat, alt = (np.array(c) for c in zip(*got.samples))
        assert t.size == len(obj), (obj.id, t.size, len(obj))
        seconds = np.array([(acmi.reference_time + timedelta(seconds=float(s)) - epoch_utc)
                            .total_seconds() for s in t])
        np.testing.assert_allclose(seconds, obj.time, rtol=0, atol=TIME_TOL)
        np.testing.assert_allclose(lon, obj.lon, rtol=0, atol=DEG_TOL)
        np.testing.assert_allclose(lat, obj.lat, rtol=0, atol=DEG_TOL)
        np.testing.assert_allclose(alt, obj.height, rtol=0, atol=ALT_TOL)
        assert got.removed == [float(t[-1])], (obj.id, got.removed)


# ------------------------------------------------------------------------------------------
# The sample run
# ------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def acmi_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The sample scenario run with ``[output] export = ["acmi", "acmi-zip"]`` and its epoch."""
    folder = copy_sample(tmp_path_factory.mktemp("acmi") / "sample")
    config = folder / SAMPLE_CONFIG
    text = config.read_text()
    assert "[output]\n" in text
    config.write_text(text.replace(
        "[output]\n", f'[output]\nexport = ["acmi", "acmi-zip"]\nepoch = "{EPOCH}"\n', 1))
    result = invoke(["run", "--quiet", config])
    assert result.exit_code == 0, describe(result)
    return folder


def test_sample_run_acmi_reads_back_every_track_and_site(acmi_run: Path) -> None:
    out = acmi_run / "out"
    data = (out / "fused.acmi").read_bytes()
    assert data.startswith(b"\xef\xbb\xbfFileType=text/acmi/tacview\nFileVersion=2.2\n")
    acmi = read_acmi(data)
    assert acmi.reference_time.microsecond == 0
    table = pd.read_parquet(out / "fused.parquet")
    check_tracks(acmi, table, EPOCH_UTC)
    first = acmi.reference_time + timedelta(seconds=acmi.frames[0]) - EPOCH_UTC
    assert 0 <= acmi.frames[0] < 1
    assert first.total_seconds() == pytest.approx(float(table["time"].min()), abs=TIME_TOL)
    # the sensors' fixed sites, as static objects present from the first frame on
    cfg = load_config(acmi_run / SAMPLE_CONFIG)
    sites = {s.id: s.site for s in cfg.sensors if s.site is not None}
    sites |= {st.id: st.site for s in cfg.sensors for st in s.stations}
    assert set(sites) == {"R1", "TH1", "M1", "M2", "M3", "M4"}
    named = by_name(acmi)
    assert set(named) == set(table["target_id"]) | set(sites)   # no S1, SHIP_INS, G1
    for sid, site in sites.items():
        obj = named[sid]
        assert "Static" in obj.props["Type"].split("+") and not obj.removed
        ((t, lon, lat, alt),) = obj.samples
        assert t == acmi.frames[0]
        assert abs(lon - site.lon) <= DEG_TOL and abs(lat - site.lat) <= DEG_TOL
        assert abs(alt - site.height) <= ALT_TOL
    assert named["M1"].props["Group"] == "MISTRAM"
    # the zipped form: one member holding the same text
    with zipfile.ZipFile(out / "fused.zip.acmi") as archive:
        (member,) = archive.infolist()
        assert member.filename.endswith(".txt.acmi")
        assert archive.read(member) == data
    assert not [p for p in out.rglob("*") if p.name.startswith(".")]   # no temp or staging


def test_cli_export_of_the_run_matches_the_run_s_acmi(acmi_run: Path, tmp_path: Path) -> None:
    """``rangeproc export --format acmi`` later: the epoch from summary.json, the sites from the
    config it names; the same recording as the run wrote but for its title."""
    out = acmi_run / "out"
    written_by_run = (out / "fused.acmi").read_text(encoding="utf-8-sig")
    result = invoke(["export", out, "--format", "acmi"])
    assert result.exit_code == 0, describe(result)
    assert result.stderr == ""
    again = (out / "fused.acmi").read_text(encoding="utf-8-sig")

    def untitled(text: str) -> list[str]:
        return [ln for ln in text.splitlines() if not ln.startswith("0,Title=")]
    assert untitled(again) == untitled(written_by_run)


# ------------------------------------------------------------------------------------------
# Small tables: several objects, thinning, text escaping, the calendar and site warnings
# ------------------------------------------------------------------------------------------

def two_objects() -> pd.DataFrame:
    """T1 (12 epochs at 10 Hz) and "O,1" (7 epochs at 2 Hz, starting later), on seconds of
    day (no calendar of their own)."""
    rng = np.random.default_rng(3)
    parts = []
    for oid, n, dt, t0 in (("T1", 12, 0.1, 1000.05), ("O,1", 7, 0.5, 1000.4)):
        parts.append(pd.DataFrame({
            "target_id": oid, "time": t0 + dt * np.arange(n),
            "lat": 35.1 + rng.normal(0, 1e-3, n), "lon": -117.6 + rng.normal(0, 1e-3, n),
            "height": 3000 + rng.normal(0, 50, n), "sigma_e": 1.0, "sigma_n": 1.0,
            "sigma_u": 2.0}))
    return pd.concat(parts, ignore_index=True)


@pytest.mark.parametrize("interval_s", [0.0, 0.3])
def test_several_objects_interleave_in_ascending_frames(tmp_path: Path,
                                                        interval_s: float) -> None:
    table = two_objects()
    table.to_parquet(tmp_path / "fused.parquet", index=False)
    epoch = "2026-05-11T00:00:00Z"
    paths = export_run(tmp_path, ["acmi", "acmi-zip"], epoch=epoch, interval_s=interval_s,
                       title="Range day 3, sortie 2", config=load_config(
                           Path(__file__).resolve().parents[2] / "configs" / "sample.toml"))
    assert paths == [tmp_path / "fused.acmi", tmp_path / "fused.zip.acmi"]
    acmi = read_acmi(paths[0].read_bytes())
    assert read_acmi(paths[1].read_bytes()) == acmi
    assert acmi.globals["Title"] == "Range day 3, sortie 2"
    assert acmi.reference_time == datetime(2026, 5, 11, 0, 16, 40, tzinfo=timezone.utc)
    check_tracks(acmi, table, datetime(2026, 5, 11, tzinfo=timezone.utc), interval_s)
    assert set(by_name(acmi)) == {"T1", "O,1", "R1", "TH1", "M1", "M2", "M3", "M4"}


def test_no_calendar_and_no_sites_each_warn_once(tmp_path: Path, caplog) -> None:
    """Seconds of day without an epoch: taken as seconds from 1970-01-01, with the export's
    calendar warning; a table without a run summary: no sites, with one warning line."""
    table = two_objects()
    table.to_parquet(tmp_path / "fused.parquet", index=False)
    with caplog.at_level(logging.WARNING):
        (path,) = export_run(tmp_path, ["acmi"])
    messages = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(messages) == 2, messages
    assert "no known calendar date" in messages[0] and "--epoch" in messages[0]
    assert "no sensor sites" in messages[1] and "summary.json" in messages[1]
    acmi = read_acmi(path.read_bytes())
    assert acmi.reference_time == datetime(1970, 1, 1, 0, 16, 40, tzinfo=timezone.utc)
    check_tracks(acmi, table, datetime(1970, 1, 1, tzinfo=timezone.utc))
    assert set(by_name(acmi)) == {"T1", "O,1"}


def test_cli_unknown_format_lists_acmi(tmp_path: Path) -> None:
    two_objects().to_parquet(tmp_path / "fused.parquet", index=False)
    result = invoke(["export", tmp_path, "--format", "tacview"])
    assert result.exit_code == 2
    assert "acmi, acmi-zip" in result.stderr and not list(tmp_path.glob("*.acmi"))
