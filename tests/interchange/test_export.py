"""rangeproc.interchange: KML, CZML and CSV exports, each parsed back by an independent reader.

Readers: fastkml (KML's ``gx:Track``; not simplekml, which writes it) and the standard
library's ElementTree (its ``gx:SimpleArrayData``); the standard library's ``json`` (CZML;
not czml3, which writes it); the standard library's ``csv`` (CSV; not pyarrow, which writes
it). Calendar times are checked against ``datetime`` arithmetic, not numpy's.
"""
from __future__ import annotations

import csv
import json
import warnings
import xml.etree.ElementTree as ET
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from rangeproc.cli import main
from rangeproc.errors import DataError
from rangeproc.interchange import export_run
from rangeproc.timescale import parse_epoch
from rangeproc.interchange.trajectories import (object_trajectories, read_fused,
                                                to_utc)

with warnings.catch_warnings():          # fastkml warns that lxml (pretty printing) is missing
    warnings.simplefilter("ignore")
    from fastkml import kml as fastkml

GX = "{http://www.google.com/kml/ext/2.2}"
EPOCH = "2026-05-11T09:00:00+02:00"            # = 07:00:00 UTC
EPOCH_UTC = datetime(2026, 5, 11, 7, 0, 0, tzinfo=timezone.utc)


def fused_table() -> pd.DataFrame:
    """Two objects in contract section 4's layout: T1 (12 epochs at 10 Hz) and O1 (7 epochs
    at 2 Hz, the middle three bridged), with distinct, irregular values."""
    rng = np.random.default_rng(7)
    parts = []
    for oid, n, dt, t0 in (("T1", 12, 0.1, 1000.05), ("O1", 7, 0.5, 1000.4)):
        t = t0 + dt * np.arange(n)
        parts.append(pd.DataFrame({
            "target_id": oid, "time": t,
            "lat": 35.1 + rng.normal(0, 1e-3, n), "lon": -117.6 + rng.normal(0, 1e-3, n),
            "height": 3000 + rng.normal(0, 50, n),
            **{c: rng.normal(0, 100, n) for c in ("e", "n", "u", "ve", "vn", "vu",
                                                  "ae", "an", "au")},
            "sigma_e": rng.uniform(0.5, 3, n), "sigma_n": rng.uniform(0.5, 3, n),
            "sigma_u": rng.uniform(1, 6, n), "n_sensors": rng.integers(0, 4, n),
            "bridged": (oid == "O1") & (np.abs(np.arange(n) - 3) <= 1)}))
    return pd.concat(parts, ignore_index=True)


@pytest.fixture()
def run_dir(tmp_path: Path) -> tuple[Path, pd.DataFrame]:
    table = fused_table()
    table.to_parquet(tmp_path / "fused.parquet", index=False)
    return tmp_path, table


def objects_of(folder: Path, epoch: str, interval_s: float = 0.0):  # type: ignore[no-untyped-def]
    """The exports' per-object trajectories of ``folder``'s fused.parquet."""
    table = read_fused(folder)
    return object_trajectories(table, to_utc(table["time"].to_numpy(), parse_epoch(epoch),
                                             "fused.parquet"), interval_s)


def utc_of(t: float) -> datetime:
    return EPOCH_UTC + timedelta(seconds=float(t))


def test_kml_tracks_read_back_by_fastkml(run_dir) -> None:
    folder, table = run_dir
    (path,) = export_run(folder, ["kml"], epoch=EPOCH)
    assert path == folder / "fused.kml"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        doc = fastkml.KML.parse(path)
    folders = list(doc.features[0].features)
    assert [f.name for f in folders] == ["T1", "O1"]
    for f in folders:
        rows = table[table.target_id == f.name]
        track = f.features[0].kml_geometry
        assert len(track.whens) == len(rows)
        for when, t in zip(track.whens, rows.time):
            assert abs((when.dt - utc_of(t)).total_seconds()) < 1e-3   # ms resolution
        coords = np.array(track.coords)
        np.testing.assert_allclose(coords[:, 0], rows.lon, rtol=0, atol=1e-12)
        np.testing.assert_allclose(coords[:, 1], rows.lat, rtol=0, atol=1e-12)
        np.testing.assert_allclose(coords[:, 2], rows.height, rtol=0, atol=1e-9)
    # the per-epoch uncertainty and bridged flag, read with ElementTree
    arrays: dict[str, list[list[str]]] = {}
    for node in ET.parse(path).getroot().iter(f"{GX}SimpleArrayData"):
        arrays.setdefault(node.get("name"), []).append(
            [v.text for v in node.iter(f"{GX}value")])
    for k, oid in enumerate(("T1", "O1")):
        rows = table[table.target_id == oid]
        for c in ("sigma_e", "sigma_n", "sigma_u"):
            np.testing.assert_allclose(np.array(arrays[c][k], float), rows[c], atol=5e-4)
        assert [int(v) for v in arrays["bridged"][k]] == rows.bridged.astype(int).tolist()


def test_czml_packets_read_back_by_json(run_dir) -> None:
    folder, table = run_dir
    (path,) = export_run(folder, ["czml"], epoch=EPOCH)
    packets = json.loads(path.read_text())
    assert packets[0]["id"] == "document" and packets[0]["version"] == "1.0"
    start, end = packets[0]["clock"]["interval"].split("/")
    assert start == utc_of(table.time.min()).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
    assert end == utc_of(table.time.max()).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
    assert [p["id"] for p in packets[1:]] == ["T1", "O1"]
    for p in packets[1:]:
        rows = table[table.target_id == p["id"]]
        epoch = datetime.fromisoformat(p["position"]["epoch"].replace("Z", "+00:00"))
        assert abs((epoch - utc_of(rows.time.iloc[0])).total_seconds()) < 1e-3
        samples = np.array(p["position"]["cartographicDegrees"]).reshape(-1, 4)
        np.testing.assert_allclose(samples[:, 0], rows.time - rows.time.iloc[0], atol=1e-6)
        np.testing.assert_allclose(samples[:, 1:], rows[["lon", "lat", "height"]],
                                   rtol=0, atol=1e-9)
        radii = np.array(p["ellipsoid"]["radii"]["cartesian"]).reshape(-1, 4)
        np.testing.assert_allclose(radii[:, 1:], 3 * rows[["sigma_e", "sigma_n", "sigma_u"]],
                                   rtol=1e-12)
        a0, a1 = p["availability"].split("/")
        assert a0 < a1


def test_csv_reads_back_exactly_with_a_utc_column(run_dir) -> None:
    folder, table = run_dir
    (path,) = export_run(folder, ["csv"], epoch=EPOCH)
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == [*table.columns[:2], "utc", *table.columns[2:]]
    assert len(rows) == len(table)
    for row, (_, ref) in zip(rows, table.iterrows()):
        assert row["target_id"] == ref.target_id
        for c in ("time", "lat", "lon", "height", "sigma_u", "au"):
            assert float(row[c]) == ref[c]                 # exact: shortest round-trip
        assert int(row["n_sensors"]) == ref.n_sensors
        assert row["bridged"] == ("true" if ref.bridged else "false")
        stamp = datetime.fromisoformat(row["utc"].replace("Z", "+00:00"))
        assert abs((stamp - utc_of(ref.time)).total_seconds()) < 1e-3


def test_interval_thins_kml_and_czml_keeping_each_object_s_ends(run_dir) -> None:
    folder, table = run_dir
    objects = objects_of(folder, EPOCH, interval_s=0.35)
    t1 = objects[0].time
    assert t1[0] == table.time.iloc[0] and t1[-1] == table.time.iloc[11]
    # the first epoch of each 0.35 s slot from the first (0-0.35 s, 0.35-0.7 s, ...), and the
    # last epoch of the object
    np.testing.assert_allclose(t1, [1000.05, 1000.45, 1000.75, 1001.15])
    assert len(objects[1]) == 7                          # 2 Hz: every epoch is its own slot


def test_unix_epoch_is_the_default(run_dir) -> None:
    folder, table = run_dir
    objects = objects_of(folder, "1970-01-01T00:00:00Z")
    assert str(objects[0].utc[0])[:23] == "1970-01-01T00:16:40.050"


@pytest.mark.parametrize("epoch, message", [
    ("2026-05-11T09:00:00", "no UTC offset"),
    ("tomorrow", "not an ISO-8601 time"),
    ("9000-01-01T00:00:00Z", "outside the years"),
])
def test_bad_epoch_is_named(run_dir, epoch: str, message: str) -> None:
    with pytest.raises(DataError, match=f"--epoch: .*{message}"):
        export_run(run_dir[0], ["csv"], epoch=epoch)


def test_time_outside_the_calendar_names_the_row(tmp_path: Path) -> None:
    table = fused_table()
    table.loc[3, "time"] = 1e13                      # a time scale the epoch does not fit
    table.to_parquet(tmp_path / "fused.parquet", index=False)
    with pytest.raises(DataError, match=r"fused\.parquet: row 3: time 1e\+13 s"):
        export_run(tmp_path, ["kml"])
    assert not (tmp_path / "fused.kml").exists()


def test_missing_or_incomplete_table_is_named(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"fused\.parquet: not found"):
        export_run(tmp_path)
    fused_table().drop(columns="sigma_u").to_parquet(tmp_path / "fused.parquet")
    with pytest.raises(DataError, match="column 'sigma_u' missing"):
        export_run(tmp_path)
    (tmp_path / "fused.parquet").write_text("not parquet")
    with pytest.raises(DataError, match="not a readable Parquet file"):
        export_run(tmp_path)


def test_cli_export_writes_the_formats_asked_for(run_dir) -> None:
    folder, _ = run_dir
    result = CliRunner().invoke(main, ["export", str(folder), "--format", "kml,csv",
                                       "--epoch", EPOCH, "--interval", "0.2"])
    assert result.exit_code == 0, result.output
    assert (folder / "fused.kml").exists() and (folder / "fused.csv").exists()
    assert not (folder / "fused.czml").exists()
    assert not list(folder.glob(".*tmp"))


@pytest.mark.parametrize("args, message", [
    (["--format", "kmz"], "--format: unknown format 'kmz'"),
    (["--epoch", "noon"], "--epoch: 'noon' is not an ISO-8601 time"),
    (["--interval", "-1"], "--interval: must be a finite number of seconds >= 0"),
])
def test_cli_bad_option_is_one_line_exit_2(run_dir, args: list[str], message: str) -> None:
    result = CliRunner().invoke(main, ["export", str(run_dir[0]), *args])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]
    assert not list(run_dir[0].glob("fused.[kc]*"))
