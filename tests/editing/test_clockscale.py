"""Clock scales named and aligned (editing.clockscale), on hand-made files (tests/newuser.py)."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import describe, invoke
from newuser import DAY_UNIX, make_flight, seconds_of_week
from rangeproc.editing.clockscale import aligning_offset, clock_scale, describe_scale

UNIX = DAY_UNIX + 50400.0 + np.arange(0.0, 120.0, 0.1)     # 2026-05-11 14:00 UTC


@pytest.mark.parametrize("t,scale", [(UNIX, "unix"), (UNIX - DAY_UNIX, "day"),
                                     (seconds_of_week(UNIX), "week"), (UNIX * 100, "unknown"),
                                     (np.array([-5.0, 3.0]), "unknown")])
def test_clock_scale(t, scale):
    assert clock_scale(t) == scale


def test_offsets_align_each_scale_with_the_others():
    sod, sow = UNIX - DAY_UNIX, seconds_of_week(UNIX)
    off, text = aligning_offset(sod, UNIX)
    assert off == DAY_UNIX and text == 'time_offset = "2026-05-11"'
    off, text = aligning_offset(sow, UNIX)
    np.testing.assert_allclose(sow + off, UNIX, atol=1e-6)
    assert "GPS week starting 2026-05-10" in text and "18 leap seconds" in text
    off, _ = aligning_offset(UNIX, sod)
    assert off == -DAY_UNIX
    off, _ = aligning_offset(sod, sow)
    np.testing.assert_allclose(sod + off, sow, atol=1e-6)
    off, _ = aligning_offset(sow, sod)
    np.testing.assert_allclose(sow + off, sod, atol=1e-6)
    assert aligning_offset(UNIX, UNIX + 5) is None
    assert describe_scale(UNIX) == "Unix time (UTC 2026-05-11 14:00:00)"


@pytest.mark.parametrize("scale,needle", [
    ("sod", 'its stamps are seconds of day (or of the GPS week), the others\' Unix time (UTC '
            '2026-05-11 14:00:00): time_offset = "2026-05-11" would align them'),
    ("gpsweek", "its stamps are GPS seconds of week, the others' Unix time (UTC 2026-05-11 "
                "14:00:00): time_offset = 1778371182.0 (the GPS week starting 2026-05-10, "
                "less 18 leap seconds) would align them"),
])
def test_a_radar_on_another_scale_names_both_and_the_offset(tmp_path, scale, needle):
    flight = make_flight(tmp_path / scale, scale=scale, time_offset=None)
    result = invoke(["run", "--quiet", flight.config])
    assert result.exit_code == 2, describe(result)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rangeproc: error: R1.csv: sensor R1")
    assert needle in lines[0]
    assert not (flight.folder / "out").exists()


def _spoil(flight, column_fn=None, config=None):
    if column_fn is not None:
        lines = (flight.folder / "R1.csv").read_text().splitlines()
        rows = [ln.split(",") for ln in lines[1:]]
        for r in rows:
            column_fn(r)
        (flight.folder / "R1.csv").write_text("\n".join([lines[0]] + [",".join(r) for r in rows]))
    if config is not None:
        flight.config.write_text(flight.config.read_text().replace(*config))


def test_unix_milliseconds_are_named(tmp_path):
    flight = make_flight(tmp_path, scale="unix")

    def to_ms(r):
        r[0] = f"{float(r[0]) * 1000:.0f}"
    _spoil(flight, to_ms)
    result = invoke(["run", "--quiet", flight.config])
    assert result.exit_code == 2, describe(result)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].endswith("they look like Unix milliseconds (from UTC 2026-05-11 14:00:00); "
                             "the time column must be in seconds")


def test_an_offset_with_the_wrong_sign_is_named(tmp_path):
    flight = make_flight(tmp_path)                  # seconds of day + time_offset
    _spoil(flight, config=("time_offset = 1778457600.0", "time_offset = -1778457600.0"))
    result = invoke(["run", "--quiet", flight.config])
    assert result.exit_code == 2, describe(result)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert "time_offset = 1778457600.0 (the other sign) would align them" in lines[0]
