"""Tests of rangeproc.io.readers.read_sensor: units, time forms, sorting, every bad input."""
from __future__ import annotations

import datetime as dt
import logging
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

from rangeproc.config import Geodetic, SensorSettings, StationSettings
from rangeproc.errors import DataError
from rangeproc.io.readers import read_sensor

STATIONS = (StationSettings(id="M1", site=Geodetic(lat=35.0, lon=-117.5, height=720.0)),
            StationSettings(id="M2", site=Geodetic(lat=35.1, lon=-117.6, height=730.0)))

RADAR_CSV = """\
time,range,azimuth,elevation,range_rate
100.0,15000.0,45.0,10.0,-120.5
100.1,14990.0,45.1,10.1,-120.4
100.2,14980.0,45.2,10.2,
"""


def settings(path: Path, kind: str = "radar", **kw: object) -> SensorSettings:
    if kind == "mistram":
        kw.setdefault("stations", STATIONS)
    return SensorSettings(id=path.stem, kind=kind, file=path, **kw)  # type: ignore[arg-type]


def write_csv(tmp_path: Path, text: str, name: str = "R1.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def read_text(tmp_path: Path, text: str, kind: str = "radar", name: str = "R1.csv",
              **kw: object):
    return read_sensor(settings(write_csv(tmp_path, text, name), kind, **kw))


def rows_csv(header: str, rows: list[str]) -> str:
    return header + "\n" + "\n".join(rows) + "\n"


def good_radar_rows(n: int) -> list[str]:
    return [f"{100 + 0.1 * i:.1f},{15000 - i},45.0,10.0" for i in range(n)]


# ---------------------------------------------------------------------------------------------
# Error cases: exception type, one line, file name and row/column in the message.
# ---------------------------------------------------------------------------------------------

RADAR_HEAD = "time,range,azimuth,elevation"

# (case id, kind, file name, file text, substrings expected in the message)
CSV_ERRORS = [
    ("text-in-number", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, good_radar_rows(16) + ["101.6,abc,45.0,10.0"] + good_radar_rows(3)),
     ["R1.csv: row 17, column 'range': 'abc' is not a number"]),
    ("missing-column", "radar", "R1.csv", rows_csv("time,range,azimuth", ["1,2,3"]),
     ["R1.csv: missing required column 'elevation'"]),
    ("missing-time", "gps", "G1.csv", rows_csv("t,lat,lon,height", ["1,2,3,4"]),
     ["G1.csv: missing required column 'time'"]),
    ("literal-nan", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", "2,nan,3,4"]),
     ["R1.csv: row 2, column 'range':", "not a finite number"]),
    ("literal-inf", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", "2,3,4,5", "3,2,inf,4"]),
     ["R1.csv: row 3, column 'azimuth':", "not a finite number"]),
    ("literal-minus-infinity", "theodolite", "T.csv",
     rows_csv("time,azimuth,elevation", ["1,2,3", "2,3,-Infinity"]),
     ["T.csv: row 2, column 'elevation':", "not a finite number"]),
    ("nan-in-slow-path", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1, ,3,4", "2,NaN,3,4"]),
     ["R1.csv: row 2, column 'range': 'NaN' is not a finite number"]),
    ("empty-time", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", ",2,3,4"]),
     ["R1.csv: row 2, column 'time': empty (time is required)"]),
    ("nan-time", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", "nan,2,3,4"]),
     ["R1.csv: row 2, column 'time':", "not a finite time"]),
    ("text-time", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", "noon,2,3,4"]),
     ["R1.csv: row 2, column 'time': 'noon' is not a number"]),
    ("iso-without-offset", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, ["2024-05-01T10:00:00Z,2,3,4", "2024-05-01T10:00:00.1,2,3,4"]),
     ["R1.csv: row 2, column 'time':", "no UTC offset"]),
    ("iso-without-offset-first-row", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, ["2024-05-01 10:00:00,2,3,4"]),
     ["R1.csv: row 1, column 'time':", "no UTC offset"]),
    ("iso-invalid-date", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, ["2024-02-28T10:00:00Z,2,3,4", "2024-02-30T10:00:00Z,2,3,4"]),
     ["R1.csv: row 2, column 'time':", "not a valid ISO-8601 time"]),
    ("mixed-numeric-then-iso", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, ["1,2,3,4", "2,2,3,4", "2024-05-01T10:00:00Z,2,3,4"]),
     ["R1.csv: row 3, column 'time':", "earlier times are numbers"]),
    ("mixed-iso-then-numeric", "radar", "R1.csv",
     rows_csv(RADAR_HEAD, ["2024-05-01T10:00:00Z,2,3,4", "17.5,2,3,4"]),
     ["R1.csv: row 2, column 'time':", "earlier times are ISO-8601"]),
    ("unknown-station", "mistram", "M.csv",
     rows_csv("time,station,range_rate", ["1,M1,5", "1,M2,5", "2,M1,5", "2,M2,5", "3,M9,5"]),
     ["M.csv: row 5, column 'station': station 'M9' not in config (known: M1, M2)"]),
    ("empty-station", "mistram", "M.csv", rows_csv("time,station,range_rate", ["1,M1,5", "2,,5"]),
     ["M.csv: row 2, column 'station': empty"]),
    ("wrong-field-count", "radar", "R1.csv", rows_csv(RADAR_HEAD, ["1,2,3,4", "2,3,4,5", "3,4"]),
     ["R1.csv: row 3:", "expected 4 fields, got 2"]),
    ("duplicate-column", "radar", "R1.csv", rows_csv("time,range,azimuth,elevation, range",
                                                    ["1,2,3,4,5"]),
     ["R1.csv: duplicate column 'range'"]),
    ("header-only", "radar", "R1.csv", RADAR_HEAD + "\n", ["R1.csv: no data rows"]),
    ("empty-file", "radar", "R1.csv", "", ["R1.csv: file is empty"]),
    ("blank-first-line", "radar", "R1.csv", "\n" + RADAR_HEAD + "\n1,2,3,4\n",
     ["R1.csv: no header row"]),
    ("lat-out-of-range", "gps", "G1.csv",
     rows_csv("time,lat,lon,height", ["1,35.0,-117.0,1000", "2,95.0,-117.0,1000"]),
     ["G1.csv: row 2, column 'lat':", "outside [-90, 90]"]),
    ("lon-out-of-range", "ins", "SHIP.csv",
     rows_csv("time,roll,pitch,yaw,lat,lon,height", ["1,0,0,0,35.0,-190.0,0"]),
     ["SHIP.csv: row 1, column 'lon':", "outside [-180, 360)"]),
    ("unsupported-extension", "radar", "R1.xlsx", rows_csv(RADAR_HEAD, ["1,2,3,4"]),
     ["R1.xlsx: unsupported file extension '.xlsx'"]),
]


@pytest.mark.parametrize("kind, name, text, expected", [c[1:] for c in CSV_ERRORS],
                         ids=[c[0] for c in CSV_ERRORS])
def test_csv_errors(tmp_path: Path, kind: str, name: str, text: str,
                    expected: list[str]) -> None:
    with pytest.raises(DataError) as info:
        read_text(tmp_path, text, kind, name)
    msg = str(info.value)
    assert "\n" not in msg
    for part in expected:
        assert part in msg, msg


def test_missing_file_names_full_path(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "R1.csv"
    with pytest.raises(DataError) as info:
        read_sensor(settings(path))
    msg = str(info.value)
    assert msg.startswith("R1.csv: file not found") and str(path) in msg and "\n" not in msg


def test_directory_is_not_a_file(tmp_path: Path) -> None:
    (tmp_path / "R1.csv").mkdir()
    with pytest.raises(DataError, match=r"^R1\.csv: not a regular file"):
        read_sensor(settings(tmp_path / "R1.csv"))


def test_non_utf8_header(tmp_path: Path) -> None:
    path = tmp_path / "R1.csv"
    path.write_bytes(b"time,range,azimuth,elevation\xff\n1,2,3,4\n")
    with pytest.raises(DataError, match=r"^R1\.csv: header row is not UTF-8"):
        read_sensor(settings(path))


def _parquet(tmp_path: Path, table: pa.Table, name: str = "R1.parquet") -> Path:
    path = tmp_path / name
    pq.write_table(table, path)
    return path


PARQUET_ERRORS = [
    ("inf-value", {"time": [1.0, 2.0], "range": [1.0, math.inf], "azimuth": [1.0, 2.0],
                   "elevation": [1.0, 2.0]}, ["row 2, column 'range':", "not a finite number"]),
    ("nan-value", {"time": [1.0, 2.0, 3.0], "range": [1.0, 2.0, 3.0],
                   "azimuth": [1.0, 2.0, 3.0], "elevation": [1.0, 2.0, math.nan]},
     ["row 3, column 'elevation':", "not a finite number"]),
    ("null-time", {"time": [1.0, None], "range": [1.0, 2.0], "azimuth": [1.0, 2.0],
                   "elevation": [1.0, 2.0]}, ["row 2, column 'time': empty"]),
    ("naive-timestamp", {"time": pa.array([dt.datetime(2024, 5, 1, 10)], pa.timestamp("us")),
                         "range": [1.0], "azimuth": [1.0], "elevation": [1.0]},
     ["row 1, column 'time':", "no time zone"]),
    ("bool-column", {"time": [1.0], "range": [True], "azimuth": [1.0], "elevation": [1.0]},
     ["column 'range': has type bool, expected numbers"]),
    ("text-in-string-column", {"time": [1.0, 2.0], "range": ["5", "x5"], "azimuth": [1.0, 2.0],
                               "elevation": [1.0, 2.0]},
     ["row 2, column 'range': 'x5' is not a number"]),
    ("missing-column", {"time": [1.0], "range": [1.0], "azimuth": [1.0]},
     ["missing required column 'elevation'"]),
    ("iso-string-no-offset", {"time": ["2024-05-01T10:00:00"], "range": [1.0],
                              "azimuth": [1.0], "elevation": [1.0]},
     ["row 1, column 'time':", "no UTC offset"]),
]


@pytest.mark.parametrize("columns, expected", [c[1:] for c in PARQUET_ERRORS],
                         ids=[c[0] for c in PARQUET_ERRORS])
def test_parquet_errors(tmp_path: Path, columns: dict, expected: list[str]) -> None:
    path = _parquet(tmp_path, pa.table(columns))
    with pytest.raises(DataError) as info:
        read_sensor(settings(path))
    msg = str(info.value)
    assert msg.startswith("R1.parquet: ") and "\n" not in msg
    for part in expected:
        assert part in msg, msg


@pytest.mark.parametrize("content", [b"PAR1 this is not parquet at all", b"x" * 10])
def test_corrupt_parquet(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "R1.pq"
    path.write_bytes(content)
    with pytest.raises(DataError) as info:
        read_sensor(settings(path))
    msg = str(info.value)
    assert msg.startswith("R1.pq: not a readable Parquet file") and "\n" not in msg


# ---------------------------------------------------------------------------------------------
# Positive cases
# ---------------------------------------------------------------------------------------------

def test_radar_csv_basic(tmp_path: Path) -> None:
    log = read_text(tmp_path, RADAR_CSV)
    assert log.sensor_id == "R1" and log.kind == "radar" and len(log) == 3 and log.n_read == 3
    np.testing.assert_array_equal(log.time, [100.0, 100.1, 100.2])
    np.testing.assert_array_equal(log.row, [1, 2, 3])
    np.testing.assert_allclose(log.columns["azimuth"], np.radians([45.0, 45.1, 45.2]),
                               rtol=1e-15)
    np.testing.assert_array_equal(log.columns["range"], [15000.0, 14990.0, 14980.0])
    assert np.isnan(log.columns["range_rate"][2]) and log.columns["range_rate"][0] == -120.5
    assert log.track_id is None and log.station is None
    assert log.time.dtype == np.float64 and log.row.dtype == np.int64


@pytest.mark.parametrize("unit, az, el", [
    ("deg", 90.0, 45.0),
    ("rad", math.pi / 2, math.pi / 4),
    ("mil", 1600.0, 800.0),   # 6400 mil per circle
])
def test_angle_units(tmp_path: Path, unit: str, az: float, el: float) -> None:
    log = read_text(tmp_path, rows_csv(RADAR_HEAD, [f"0,1000,{az!r},{el!r}"]), angle_unit=unit)
    assert log.columns["azimuth"][0] == pytest.approx(math.pi / 2, rel=1e-15)
    assert log.columns["elevation"][0] == pytest.approx(math.pi / 4, rel=1e-15)
    assert log.columns["range"][0] == 1000.0  # not an angle


def test_ins_attitude_units_and_lat_lon_stay_degrees(tmp_path: Path) -> None:
    text = rows_csv("time,roll,pitch,yaw,lat,lon,height,ve,vn,vu",
                    ["0,-100,200,3200,35.5,-117.25,12.0,1,2,3"])
    log = read_text(tmp_path, text, "ins", "SHIP.csv", angle_unit="mil")
    k = 2 * math.pi / 6400
    assert log.columns["roll"][0] == pytest.approx(-100 * k)
    assert log.columns["pitch"][0] == pytest.approx(200 * k)
    assert log.columns["yaw"][0] == pytest.approx(math.pi)
    assert (log.columns["lat"][0], log.columns["lon"][0]) == (35.5, -117.25)
    assert log.columns["vu"][0] == 3.0


def test_time_offset_added(tmp_path: Path) -> None:
    log = read_text(tmp_path, RADAR_CSV, time_offset=-0.25)
    np.testing.assert_allclose(log.time, [99.75, 99.85, 99.95], rtol=0, atol=1e-12)


def test_iso_times_with_offset_and_z(tmp_path: Path) -> None:
    text = rows_csv(RADAR_HEAD, ["2024-05-01T12:00:00.250000+02:00,1,2,3",
                                 "2024-05-01T10:00:01Z,1,2,3",
                                 " 2024-05-01T10:00:01.123456z ,1,2,3",
                                 "2024-05-01 07:30:02-0230,1,2,3"])
    log = read_text(tmp_path, text, time_offset=1.0)
    base = dt.datetime(2024, 5, 1, 10, tzinfo=dt.timezone.utc).timestamp()
    np.testing.assert_allclose(log.time - base, [1.25, 2.0, 2.123456, 3.0], rtol=0, atol=1e-6)
    # microseconds survive (float64 at 1.7e9 s resolves ~0.24 µs)
    assert abs((log.time[2] - 1.0 - base) - 1.123456) < 5e-7


def test_unsorted_rows_are_sorted_and_rows_follow(tmp_path: Path) -> None:
    text = rows_csv(RADAR_HEAD, ["3,300,3,3", "1,100,1,1", "2,200,2,2", "1,101,1,1"])
    log = read_text(tmp_path, text)
    np.testing.assert_array_equal(log.time, [1, 1, 2, 3])
    np.testing.assert_array_equal(log.row, [2, 4, 3, 1])           # stable for equal times
    np.testing.assert_array_equal(log.columns["range"], [100, 101, 200, 300])


def test_empty_cells_nan_and_unmeasured_rows_dropped(tmp_path: Path) -> None:
    text = rows_csv("time,range,azimuth,elevation,range_rate",
                    ["1,100,,,", "2,,,,", "3,  ,10,20,", "4,400,40,40,-1", ",,,,", "5,,,,7"])
    log = read_text(tmp_path, text)
    assert log.n_read == 6
    np.testing.assert_array_equal(log.time, [1, 3, 4, 5])
    np.testing.assert_array_equal(log.row, [1, 3, 4, 6])
    assert np.isnan(log.columns["azimuth"][0]) and np.isnan(log.columns["range"][1])
    assert log.columns["range_rate"][3] == 7.0 and np.isnan(log.columns["range"][3])


def test_optional_columns_absent_and_extra_columns_ignored(tmp_path: Path) -> None:
    text = rows_csv(" elevation , notes,time,azimuth ,range,snr",
                    ['10,"free text, with comma",1,20,5000,abc', "11,more,2,21,5001,"])
    log = read_text(tmp_path, text)
    assert set(log.columns) == {"range", "azimuth", "elevation", "range_rate"}
    assert np.isnan(log.columns["range_rate"]).all() and log.columns["range_rate"].shape == (2,)
    np.testing.assert_allclose(log.columns["elevation"], np.radians([10, 11]))
    np.testing.assert_array_equal(log.columns["range"], [5000, 5001])


def test_utf8_bom_and_crlf(tmp_path: Path) -> None:
    path = tmp_path / "R1.csv"
    path.write_bytes(b"\xef\xbb\xbftime,range,azimuth,elevation\r\n1,2,3,4\r\n2,3,4,5\r\n")
    log = read_sensor(settings(path))
    np.testing.assert_array_equal(log.time, [1, 2])
    np.testing.assert_array_equal(log.columns["range"], [2, 3])


def test_txt_extension_is_csv(tmp_path: Path) -> None:
    log = read_text(tmp_path, RADAR_CSV, name="R1.txt")
    assert len(log) == 3


def test_parquet_round_trip_identical_to_csv(tmp_path: Path) -> None:
    text = rows_csv("time,range,azimuth,elevation,range_rate,track_id",
                    ["3.5,300,3,3,,7", "1.25,100,1,1,-2,7", "2,,2,2,0.5,", "4,,,,,9"])
    from_csv = read_text(tmp_path, text, angle_unit="mil", time_offset=2.0)
    df = pd.read_csv(tmp_path / "R1.csv")
    df["track_id"] = df["track_id"].astype("Int64")
    path = tmp_path / "R1.parquet"
    df.to_parquet(path, index=False)
    from_pq = read_sensor(settings(path, angle_unit="mil", time_offset=2.0))
    for name in ("time", "row", "track_id"):
        np.testing.assert_array_equal(getattr(from_pq, name), getattr(from_csv, name))
    assert from_pq.n_read == from_csv.n_read == 4
    assert set(from_pq.columns) == set(from_csv.columns)
    for k in from_csv.columns:
        np.testing.assert_array_equal(from_pq.columns[k], from_csv.columns[k])
    np.testing.assert_array_equal(from_csv.track_id, [7, -1, 7])


def test_parquet_time_types(tmp_path: Path) -> None:
    t0 = dt.datetime(2024, 5, 1, 10, tzinfo=dt.timezone.utc)
    stamps = pa.array([t0, t0 + dt.timedelta(microseconds=1_500_001)],
                      pa.timestamp("ns", tz="Europe/Berlin"))
    common = {"range": [1.0, 2.0], "azimuth": [1.0, 2.0], "elevation": [1.0, 2.0]}
    log = read_sensor(settings(_parquet(tmp_path, pa.table({"time": stamps, **common}))))
    np.testing.assert_allclose(log.time - t0.timestamp(), [0.0, 1.500001], atol=1e-6, rtol=0)
    ints = pa.table({"time": pa.array([5, 6], pa.int64()), **common})
    log = read_sensor(settings(_parquet(tmp_path, ints, "R2.parquet")))
    np.testing.assert_array_equal(log.time, [5.0, 6.0])
    iso = pa.table({"time": ["2024-05-01T10:00:00Z", "2024-05-01T10:00:00.5Z"], **common})
    log = read_sensor(settings(_parquet(tmp_path, iso, "R3.parquet")))
    np.testing.assert_allclose(log.time - t0.timestamp(), [0.0, 0.5], atol=1e-6, rtol=0)


def test_parquet_nulls_are_not_measured(tmp_path: Path) -> None:
    table = pa.table({"time": [1.0, 2.0, 3.0], "range": [1.0, None, None],
                      "azimuth": [1.0, 2.0, None], "elevation": pa.array([None, 2, None],
                                                                          pa.int32())})
    log = read_sensor(settings(_parquet(tmp_path, table)))
    assert log.n_read == 3 and len(log) == 2
    np.testing.assert_array_equal(log.row, [1, 2])
    assert np.isnan(log.columns["range"][1]) and np.isnan(log.columns["elevation"][0])


def test_track_id_integers_and_labels(tmp_path: Path) -> None:
    head = "time,range,azimuth,elevation,track_id"
    log = read_text(tmp_path, rows_csv(head, ["1,1,1,1,12", "2,1,1,1,", "3,1,1,1,3"]))
    assert log.track_id is not None and log.track_id.dtype == np.int64
    np.testing.assert_array_equal(log.track_id, [12, -1, 3])
    log = read_text(tmp_path, rows_csv(head, ["1,1,1,1,B7", "2,1,1,1,A", "0,1,1,1,B7"]))
    assert log.track_id is not None
    np.testing.assert_array_equal(log.time, [0, 1, 2])
    np.testing.assert_array_equal(log.track_id, [0, 0, 1])   # B7 first seen -> 0, A -> 1


def test_mistram_duplicate_timestamps_and_station_index(tmp_path: Path) -> None:
    text = rows_csv("time,station,range_rate",
                    ["1.0,M2,10.5", "1.0,M1,-3.0", "0.5, M1 ,-3.1", "0.5,M2,10.4", "1.5,M1,"])
    log = read_text(tmp_path, text, "mistram", "M.csv")
    np.testing.assert_array_equal(log.time, [0.5, 0.5, 1.0, 1.0])
    assert log.station is not None and log.station.dtype == np.int64
    np.testing.assert_array_equal(log.station, [0, 1, 1, 0])
    np.testing.assert_array_equal(log.columns["range_rate"], [-3.1, 10.4, 10.5, -3.0])
    np.testing.assert_array_equal(log.row, [3, 4, 1, 2])
    assert log.n_read == 5


def test_mistram_numeric_station_ids(tmp_path: Path) -> None:
    stations = tuple(StationSettings(id=i, site=STATIONS[0].site) for i in ("1", "02"))
    text = rows_csv("time,station,range_rate", ["1,02,1.0", "2,1,2.0"])
    log = read_text(tmp_path, text, "mistram", "M.csv", stations=stations)
    np.testing.assert_array_equal(log.station, [1, 0])   # '02' kept as text, not 2


def test_ins_rows_missing_attitude_dropped_with_warning(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    text = rows_csv("time,roll,pitch,yaw,lat,lon,height",
                    ["1,0,0,0,35,-117,10", "2,0,,0,35,-117,10", "3,0,0,0,35,,10",
                     "4,1,1,1,35,-117,10"])
    with caplog.at_level(logging.WARNING, logger="rangeproc.io.readers"):
        log = read_text(tmp_path, text, "ins", "SHIP.csv")
    np.testing.assert_array_equal(log.time, [1, 4])
    np.testing.assert_array_equal(log.row, [1, 4])
    assert log.n_read == 4 and np.isnan(log.columns["ve"]).all()
    assert any(r.levelno == logging.WARNING and "SHIP.csv" in r.getMessage()
               and "dropped 2 rows" in r.getMessage() for r in caplog.records)


def test_gps_columns(tmp_path: Path) -> None:
    text = rows_csv("time,lat,lon,height,ve,vn,vu", ["1,35.1,242.9,1500,10,-5,0.25"])
    log = read_text(tmp_path, text, "gps", "G1.csv", angle_unit="mil")
    assert (log.columns["lat"][0], log.columns["lon"][0]) == (35.1, 242.9)  # never converted
    assert log.columns["vu"][0] == 0.25


def test_read_200k_rows(tmp_path: Path) -> None:
    rng = np.random.default_rng(7)
    n = 200_000
    t = 4.0e5 + np.arange(n) * 0.01
    data = np.column_stack([t, rng.uniform(1e3, 1e5, n), rng.uniform(0, 360, n),
                            rng.uniform(0, 90, n), rng.normal(0, 50, n)])
    path = tmp_path / "R1.csv"
    names = ["time", "range", "azimuth", "elevation", "range_rate"]
    # pyarrow writes the shortest round-trip repr of each float (and a quoted header)
    pacsv.write_csv(pa.table(dict(zip(names, data.T, strict=True))), path)
    log = read_sensor(settings(path))
    assert len(log) == n == log.n_read
    np.testing.assert_array_equal(log.time, t)
    np.testing.assert_allclose(log.columns["azimuth"], np.radians(data[:, 2]), rtol=1e-15)
    assert log.row[-1] == n


def test_track_id_labels_consistent_across_parquet_chunks(tmp_path: Path) -> None:
    labels = ["A", "B", "B", "C", "A", "C", "D", "A"]
    n = len(labels)
    table = pa.table({"time": np.arange(n, dtype=float), "azimuth": np.ones(n),
                      "elevation": np.ones(n), "track_id": labels})
    path = tmp_path / "TH.parquet"
    pq.write_table(table, path, row_group_size=3)     # several chunks on reading
    log = read_sensor(settings(path, "theodolite"))
    assert log.track_id is not None
    np.testing.assert_array_equal(log.track_id, [0, 1, 1, 2, 0, 2, 3, 0])


def test_log_arrays_are_read_only(tmp_path: Path) -> None:
    log = read_text(tmp_path, RADAR_CSV)
    with pytest.raises(ValueError):
        log.columns["range"][0] = 1.0
    with pytest.raises(ValueError):
        log.time[0] = 1.0
    with pytest.raises(TypeError):
        log.columns["new"] = np.zeros(3)  # type: ignore[index]


def test_config_and_reader_together_from_another_cwd(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from rangeproc.config import load_config
    folder = tmp_path / "flight"
    (folder / "data").mkdir(parents=True)
    (folder / "data" / "R1.csv").write_text(RADAR_CSV)
    (folder / "f.toml").write_text(
        "[range]\norigin = { lat = 34.9, lon = -117.9, height = 700.0 }\n\n[[sensors]]\n"
        'id = "R1"\nkind = "radar"\nfile = "data/R1.csv"\nangle_unit = "mil"\n'
        "site = { lat = 35.0, lon = -117.5, height = 713.0 }\n")
    monkeypatch.chdir(tmp_path)
    (sensor,) = load_config("flight/f.toml").sensors
    log = read_sensor(sensor)
    assert len(log) == 3
    assert log.columns["azimuth"][0] == pytest.approx(45.0 * 2 * math.pi / 6400)
