"""Time sanity: impossible stamps edited, sensors on another time scale refused."""
from __future__ import annotations

from pathlib import Path
from types import MappingProxyType

import numpy as np
import pytest

from rangeproc.config import SensorSettings
from rangeproc.editing.record import EditRecord
from rangeproc.editing.timecheck import (
    MAX_ABS_TIME,
    check_overlap,
    edit_time,
    isolated_stamps,
)
from rangeproc.editing.repeats import drop_repeats, repeated_stamps
from rangeproc.errors import DataError
from rangeproc.io.logs import SensorLog


def make_log(sid: str, kind: str, t: np.ndarray) -> SensorLog:
    t = np.asarray(t, dtype=float)
    cols = {"range": np.full(t.size, 1000.0)}
    return SensorLog(sensor_id=sid, kind=kind, time=t, columns=MappingProxyType(cols),
                     row=np.arange(1, t.size + 1), track_id=None, station=None, n_read=t.size)


def settings(sid: str, kind: str = "radar", **kw) -> SensorSettings:
    return SensorSettings(id=sid, kind=kind, file=Path(f"/data/{sid}.csv"), **kw)


def test_isolated_single_stamp_far_after_and_before_is_found() -> None:
    t = np.concatenate([[-5e5], np.arange(0.0, 100.0, 0.1), [1e6]])
    bad = isolated_stamps(t, 60.0)
    assert bad[0] and bad[-1] and bad.sum() == 2


def test_two_long_segments_with_a_gap_are_both_kept() -> None:
    t = np.concatenate([np.arange(0.0, 50.0, 0.1), np.arange(500.0, 550.0, 0.1)])
    assert not isolated_stamps(t, 60.0).any()


def test_a_small_but_substantial_share_is_not_isolated() -> None:
    """A cluster of 3 rows in a 100-row sensor is 3 %: a re-acquisition, kept."""
    t = np.concatenate([np.arange(97.0), [1000.0, 1001.0, 1002.0]])
    assert not isolated_stamps(t, 60.0).any()


def test_repeated_stamps_keep_the_first_file_row() -> None:
    t = np.array([1.0, 2.0, 2.0, 2.0, 3.0])
    row = np.array([1, 2, 5, 3, 4])
    assert repeated_stamps(t, row).tolist() == [False, False, True, True, False]


def test_edit_time_records_reason_time_and_keeps_the_rest() -> None:
    t = np.concatenate([np.arange(0.0, 100.0, 0.1), [1e6]])
    rec = EditRecord()
    out = edit_time(make_log("R1", "radar", t), settings("R1"), rec, max_gap=60.0)
    assert len(out) == t.size - 1 and out.time.max() < 100.0
    assert rec.counts("R1") == {"time": 1}
    assert rec.examples("R1")[0]["row"] == t.size


def test_gps_repeated_stamps_are_edited_radar_plots_are_not() -> None:
    t = np.repeat(np.arange(0.0, 10.0), 2)
    rec = EditRecord()
    gps = drop_repeats(_varied(make_log("G1", "gps", t)), rec)
    radar = drop_repeats(_varied(make_log("R1", "radar", t)), rec)
    assert len(gps) == 10 and len(radar) == 20
    assert rec.counts("G1") == {"repeated stamp": 10} and rec.counts("R1") == {}


def _varied(log: SensorLog) -> SensorLog:
    """``log`` with a different range in every row (no row duplicates another)."""
    cols = {"range": 1000.0 + np.arange(len(log), dtype=float)}
    return SensorLog(sensor_id=log.sensor_id, kind=log.kind, time=log.time,
                     columns=MappingProxyType(cols), row=log.row, track_id=log.track_id,
                     station=log.station, n_read=log.n_read)


def test_every_stamp_beyond_the_representable_range_is_refused() -> None:
    with pytest.raises(DataError, match=r"R1\.csv: row 1, column 'time'"):
        edit_time(make_log("R1", "radar", np.full(5, 2 * MAX_ABS_TIME)), settings("R1"),
                  EditRecord(), max_gap=60.0)


def test_overlap_refuses_the_sensor_a_day_off_and_names_both_spans() -> None:
    logs = {"R1": make_log("R1", "radar", np.arange(0.0, 100.0)),
            "TH1": make_log("TH1", "theodolite", np.arange(10.0, 90.0)),
            "G1": make_log("G1", "gps", np.arange(0.0, 100.0) + 86400.0)}
    cfg = [settings("R1"), settings("TH1", "theodolite"), settings("G1", "gps")]
    with pytest.raises(DataError) as info:
        check_overlap(logs, cfg, margin=60.0)
    msg = str(info.value)
    assert msg.startswith("G1.csv: sensor G1 time span 86400.000 to 86499.000 s")
    assert "(0.000 to 99.000 s)" in msg and "allow_disjoint_time" in msg
    cfg[2] = settings("G1", "gps", allow_disjoint_time=True)
    check_overlap(logs, cfg, margin=60.0)            # accepted when intended


def test_overlap_within_the_margin_is_accepted() -> None:
    logs = {"R1": make_log("R1", "radar", np.arange(0.0, 100.0)),
            "G1": make_log("G1", "gps", np.arange(150.0, 200.0))}
    check_overlap(logs, [settings("R1"), settings("G1", "gps")], margin=60.0)
    with pytest.raises(DataError):
        check_overlap(logs, [settings("R1"), settings("G1", "gps")], margin=40.0)


def test_an_ins_is_checked_against_the_sensors_on_its_platform() -> None:
    logs = {"R1": make_log("R1", "radar", np.arange(0.0, 100.0)),
            "SHIP": make_log("SHIP", "ins", np.arange(0.0, 100.0) + 1e5),
            "S1": make_log("S1", "radar", np.arange(0.0, 100.0))}
    cfg = [settings("R1"), settings("SHIP", "ins"), settings("S1", platform="SHIP")]
    with pytest.raises(DataError, match="SHIP.csv: sensor SHIP .* the sensors on its platform"):
        check_overlap(logs, cfg, margin=60.0)


def test_repeated_stamps_are_per_series_and_plots_may_share_a_stamp() -> None:
    t = np.array([5.0, 5.0, 5.0, 5.0, 6.0, 6.0])
    row = np.arange(1, 7)
    station = np.array([0, 1, 0, 1, 0, 1])               # MISTRAM: one value per station
    assert repeated_stamps(t, row, station).tolist() == [False, False, True, True, False, False]
    track = np.array([-1, -1, 3, 3, -1, 4])              # plots (-1) share stamps freely
    assert repeated_stamps(t, row, track).tolist() == [False, False, False, True, False, False]


def test_mistram_rows_all_at_one_time_keep_one_per_station() -> None:
    n = 40
    log = make_log("M", "mistram", np.full(n, 100.0))
    log = SensorLog(sensor_id="M", kind="mistram", time=log.time, columns=log.columns,
                    row=log.row, track_id=None, station=np.arange(n) % 4, n_read=n)
    rec = EditRecord()
    out = drop_repeats(_varied(log), rec)
    assert sorted(out.station.tolist()) == [0, 1, 2, 3]
    assert rec.counts("M") == {"repeated stamp": n - 4}
