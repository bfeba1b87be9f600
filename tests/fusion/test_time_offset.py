"""A configured time_offset is clock alignment, not latency (hand-made flight, tests/newuser.py).

The radar is stamped in seconds of day, the GPS in ISO UTC; ``time_offset`` puts the radar on
the Unix scale. The offset is reported as given (value, role, the instant it names) and the
estimated latency is the residual after it (the planted latency is zero).
"""
from __future__ import annotations

import json
import re

import pandas as pd
import pytest

from conftest import describe, invoke
from newuser import DAY_UNIX, make_flight
from rangeproc.config import load_config
from rangeproc.errors import ConfigError


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    out = {}
    for form in ("auto", "iso"):
        flight = make_flight(tmp_path_factory.mktemp(form), time_offset=form)
        result = invoke(["run", "--quiet", flight.config])
        assert result.exit_code == 0, describe(result)
        out[form] = flight.folder / "out"
    return out


def test_offset_reported_as_given_and_latency_is_the_residual(runs):
    summary = json.loads((runs["auto"] / "summary.json").read_text())
    radar = summary["sensors"]["R1"]
    assert radar["time_offset"] == {"value": DAY_UNIX, "unit": "s",
                                    "role": "clock scale alignment",
                                    "instant": "2026-05-11T00:00:00Z"}
    latency = radar["calibration"]["latency"]
    assert "given" not in latency
    assert latency["unit"] == "s" and 0 < latency["sigma"] < 0.01
    assert abs(latency["estimate"]) < 4 * latency["sigma"] + 1e-3   # none planted
    page = (runs["auto"] / "report" / "index.html").read_text()
    assert "time_offset (clock alignment): +1778457600.000 s = 2026-05-11T00:00:00Z" in page
    m = re.search(r"latency: (-?[0-9.]+) ms ± ([0-9.]+) ms", page)
    assert m and abs(float(m.group(1))) < 10.0
    assert "e+" not in m.group(0)


def test_iso_offset_gives_the_same_trajectory(runs):
    a = pd.read_parquet(runs["auto"] / "fused.parquet")
    b = pd.read_parquet(runs["iso"] / "fused.parquet")
    pd.testing.assert_frame_equal(a, b)


def _config(tmp_path, offset_toml: str):
    flight = make_flight(tmp_path, time_offset=None)
    text = flight.config.read_text().replace('angle_unit = "deg"',
                                             f'angle_unit = "deg"\ntime_offset = {offset_toml}')
    flight.config.write_text(text)
    return flight.config


@pytest.mark.parametrize("offset_toml", ['"2026-05-11T00:00:00Z"', '"2026-05-11"',
                                         '"2026-05-11T02:00:00+02:00"', "2026-05-11",
                                         "2026-05-11T00:00:00Z", "1778457600"])
def test_offset_forms(tmp_path, offset_toml):
    cfg = load_config(_config(tmp_path, offset_toml))
    assert cfg.sensors[0].time_offset == DAY_UNIX


@pytest.mark.parametrize("offset_toml,needle", [
    ('"2026-05-11T00:00:00"', "needs a UTC offset or 'Z'"),
    ("2026-05-11T00:00:00", "needs a UTC offset or 'Z'"),
    ('"yesterday"', "expected seconds or an ISO-8601 date or instant"),
    ("00:00:00", "a time of day"),
    ("true", "sensors[0].time_offset"),
])
def test_bad_offsets_name_the_key(tmp_path, offset_toml, needle):
    with pytest.raises(ConfigError) as info:
        load_config(_config(tmp_path, offset_toml))
    assert "sensors[0].time_offset" in str(info.value) and needle in str(info.value)
