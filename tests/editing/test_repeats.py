"""Duplicate rows and stuck clocks (editing.repeats): found, dropped, counted, said once; plots
sharing their scan's stamp are left alone."""
from __future__ import annotations

from pathlib import Path
from types import MappingProxyType

import numpy as np

from rangeproc.config import SensorSettings
from rangeproc.editing.record import EditRecord
from rangeproc.editing.repeats import (
    drop_repeats,
    duplicate_rows,
    repeat_lines,
    stuck_clock,
)
from rangeproc.io.logs import SensorLog


def _log(t, rng_m, kind="radar", track=None) -> SensorLog:
    t = np.asarray(t, float)
    order = np.argsort(t, kind="stable")
    row = np.arange(1, t.size + 1)[order]
    cols = {"range": np.asarray(rng_m, float)[order], "azimuth": np.full(t.size, 0.5)}
    return SensorLog(sensor_id="R1", kind=kind, time=t[order], columns=MappingProxyType(cols),
                     row=row, track_id=None if track is None else np.asarray(track)[order],
                     station=None, n_read=t.size)


def _settings(kind="radar") -> SensorSettings:
    return SensorSettings(id="R1", kind=kind, file=Path("R1.csv"))


def _track(n=1200, dt=0.1):
    t = np.arange(n) * dt
    return t, 20000.0 + 150.0 * t


def test_a_block_written_twice_is_dropped_and_said_once():
    t, r = _track()
    block = np.arange(600, 900)
    t2, r2 = np.r_[t[:900], t[block], t[900:]], np.r_[r[:900], r[block], r[900:]]
    rec = EditRecord()
    log = _log(t2, r2)
    out = drop_repeats(log, rec)
    assert len(out) == 1200 and rec.counts("R1") == {"duplicate": 300}
    assert sorted(rec.edits[0].rows.tolist()) == list(range(901, 1201))   # the copies
    lines = list(repeat_lines(_settings(), rec, out))
    assert lines == ["R1.csv: 300 rows repeat an earlier row exactly (first: row 901): dropped "
                     "as duplicates (the log or a block of it written twice?)"]


def test_rows_equal_but_in_one_value_are_no_duplicates():
    t, r = _track(10)
    t2, r2 = np.r_[t, t[3]], np.r_[r, r[3] + 0.001]
    assert not duplicate_rows(_log(t2, r2)).any()


def test_a_stuck_clock_keeps_the_first_row_of_each_stamp():
    t, r = _track()
    t[400:550] = t[399]                        # the clock stopped for 150 rows
    rec = EditRecord()
    out = drop_repeats(_log(t, r), rec)
    assert rec.counts("R1") == {"repeated stamp": 150}
    assert out.row[out.time == t[399]].tolist() == [400]     # file row 400 = index 399
    (line,) = repeat_lines(_settings(), rec, out)
    assert line.startswith("R1.csv: 150 rows repeat the time stamp of an earlier row with "
                           "other values (first: row 401 at 39.900 s): a stuck clock?")


def test_stuck_clock_shapes():
    t, _ = _track()
    half = t.copy()
    half[300:600:2] = half[299:599:2]          # a clock at half rate: each stamp twice
    assert stuck_clock(half)
    single = t.copy()
    single[[100, 250, 700]] = single[[99, 249, 699]]
    assert stuck_clock(single)
    end = t.copy()
    end[-50:] = end[-51]                       # stopped and never resumed
    assert stuck_clock(end)
    assert not stuck_clock(t)


def test_plots_sharing_their_scan_stamp_are_no_stuck_clock():
    rng = np.random.default_rng(3)
    scans = np.arange(300) * 1.68              # a rotating radar: several plots per scan
    t = np.repeat(scans, rng.integers(1, 5, scans.size))
    assert not stuck_clock(t)
    frames = np.arange(600) * 0.117            # a camera: mostly one detection, 8 % two,
    seen = frames[rng.random(frames.size) < 0.7]            # frames without any left out
    two = seen[rng.random(seen.size) < 0.09]
    assert not stuck_clock(np.sort(np.r_[seen, two]))
    rec = EditRecord()
    out = drop_repeats(_log(np.sort(np.r_[seen, two]), rng.normal(5e3, 50.0,
                                                                   seen.size + two.size)), rec)
    assert rec.counts("R1") == {} and len(out) == seen.size + two.size


def test_a_detection_reported_twice_in_a_plot_feed_is_dropped_quietly():
    rng = np.random.default_rng(4)
    t = np.repeat(np.arange(500) * 0.2, 3)     # three detections per frame
    r = rng.normal(500.0, 50.0, t.size)
    t2, r2 = np.r_[t, t[10]], np.r_[r, r[10]]
    rec = EditRecord()
    out = drop_repeats(_log(t2, r2), rec)
    assert rec.counts("R1") == {"duplicate": 1}
    assert list(repeat_lines(_settings(), rec, out)) == []


def test_repeated_stamps_of_a_track_are_dropped_per_track():
    t = np.array([0.0, 0.0, 0.1, 0.1, 0.2])
    rec = EditRecord()
    out = drop_repeats(_log(t, [1.0, 2.0, 3.0, 4.0, 5.0], track=[1, 2, 1, 1, 2]), rec)
    assert rec.counts("R1") == {"repeated stamp": 1} and len(out) == 4


def _duplicates_by_full_sort(log: SensorLog) -> np.ndarray:
    """The rule by one lexsort of every row (what ``duplicate_rows`` narrows to the rows
    of shared stamps): rows equal in stamp and every value to an earlier file row."""
    keys = [log.time, *log.columns.values()]
    keys += [a.astype(float) for a in (log.track_id, log.station) if a is not None]
    table = np.column_stack([np.where(np.isnan(k), np.inf, k) for k in keys])
    order = np.lexsort((log.row, *table.T[::-1]))
    same = np.zeros(len(log), dtype=bool)
    same[1:] = (table[order][1:] == table[order][:-1]).all(axis=1)
    out = np.zeros(len(log), dtype=bool)
    out[order[same]] = True
    return out


def test_duplicates_found_on_shared_stamps_only_are_those_of_the_full_sort():
    rng = np.random.default_rng(7)
    for trial in range(20):
        n = 400
        t = np.round(rng.uniform(0.0, 30.0, n), 1)          # many shared stamps
        r = np.round(rng.uniform(0.0, 3.0, n))               # equal values now and then
        r[rng.random(n) < 0.05] = np.nan
        if trial % 3 == 0:
            t[rng.random(n) < 0.03] = np.nan                 # stamps unread
        track = rng.integers(0, 3, n) if trial % 2 else None
        log = _log(t, r, track=track)
        expected = _duplicates_by_full_sort(log)
        got = duplicate_rows(log)
        assert expected.any() and np.array_equal(got, expected)
    t, r = _track(50)                                        # increasing stamps: none
    assert not duplicate_rows(_log(t, r)).any()
