"""Physical limits: impossible values edited with a reason, everything else untouched."""
from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import numpy as np

from rangeproc.config import DEFAULT_SIGMAS, Geodetic, SensorSettings
from rangeproc.editing.limits import Limits, apply_limits, speed_spikes
from rangeproc.editing.record import EditRecord
from rangeproc.io.logs import SensorLog

SITE = Geodetic(lat=35.0, lon=-117.0, height=700.0)


def radar_log(r, az, el, rr=None, t=None) -> SensorLog:
    n = len(r)
    t = np.arange(n) * 0.05 if t is None else np.asarray(t, float)
    cols = {"range": np.asarray(r, float), "azimuth": np.asarray(az, float),
            "elevation": np.asarray(el, float),
            "range_rate": np.full(n, np.nan) if rr is None else np.asarray(rr, float)}
    return SensorLog(sensor_id="R1", kind="radar", time=t, columns=MappingProxyType(cols),
                     row=np.arange(1, n + 1), track_id=None, station=None, n_read=n)


def radar_settings() -> SensorSettings:
    return SensorSettings(id="R1", kind="radar", file=Path("/d/R1.csv"), site=SITE,
                          sigma=DEFAULT_SIGMAS["radar"])


def straight_track(n: int = 200):
    t = np.arange(n) * 0.05
    x, y, z = 20000.0 + 250.0 * t, 5000.0 + 0 * t, 3000.0 + 0 * t
    r = np.sqrt(x * x + y * y + z * z)
    return r, np.arctan2(x, y), np.arcsin(z / r), t


def test_clean_track_is_untouched() -> None:
    r, az, el, t = straight_track()
    rec = EditRecord()
    log = radar_log(r, az, el, t=t)
    out = apply_limits(log, radar_settings(), rec, Limits())
    assert out is log and rec.counts("R1") == {}


def test_absurd_components_are_edited_alone() -> None:
    r, az, el, t = straight_track()
    r, az, el = r.copy(), az.copy(), el.copy()
    rr = np.full(r.size, 10.0)
    r[3], el[5], az[7], rr[9] = 1e308, math.radians(500.0), 1e20, 1e300
    r[11] = -5.0
    rec = EditRecord()
    out = apply_limits(radar_log(r, az, el, rr, t), radar_settings(), rec, Limits())
    assert len(out) == r.size                        # rows kept, components edited
    assert np.isnan(out.columns["range"][[3, 11]]).all()
    assert np.isfinite(out.columns["azimuth"][3]) and np.isnan(out.columns["elevation"][5])
    assert np.isnan(out.columns["azimuth"][7]) and np.isnan(out.columns["range_rate"][9])
    assert rec.counts("R1") == {"limit": 5}


def test_a_row_with_nothing_left_is_removed() -> None:
    r, az, el, t = straight_track()
    r, az, el = r.copy(), az.copy(), el.copy()
    r[4], az[4], el[4] = 1e308, 1e20, 9.0
    out = apply_limits(radar_log(r, az, el, t=t), radar_settings(), EditRecord(), Limits())
    assert len(out) == r.size - 1 and 5 not in out.row


def test_an_impossible_jump_is_a_speed_edit_but_a_plausible_one_is_not() -> None:
    r, az, el, t = straight_track()
    r = r.copy()
    r[50] += 5000.0                                  # 100 km/s for one sample: impossible
    r[120] += 300.0                                  # a wild point the gate will judge
    got = speed_spikes(radar_log(r, az, el, t=t), radar_settings(), Limits())
    assert got is not None
    cols, bad = got
    assert cols == ("range", "azimuth", "elevation")
    assert np.flatnonzero(bad).tolist() == [50]


def test_a_jump_at_the_start_is_caught() -> None:
    r, az, el, t = straight_track()
    r = r.copy()
    r[0] += 8000.0
    _, bad = speed_spikes(radar_log(r, az, el, t=t), radar_settings(), Limits())
    assert np.flatnonzero(bad).tolist() == [0]


def test_a_run_of_wild_fixes_at_either_end_of_a_track_is_cut() -> None:
    r, az, el, t = straight_track(300)
    r = r.copy()
    r[:25] += 3000.0                                 # acquisition transient: 25 fixes
    r[-4:] -= 4000.0                                 # and a short run at the end
    _, bad = speed_spikes(radar_log(r, az, el, t=t), radar_settings(), Limits())
    assert np.flatnonzero(bad).tolist() == [*range(25), *range(296, 300)]


def test_a_long_jump_inside_a_track_is_left_for_association() -> None:
    r, az, el, t = straight_track(300)
    r = r.copy()
    r[:40] += 3000.0                                 # more than a tenth of the track: a swap?
    r[150:] += 6000.0                                # a jump in the middle: another object
    _, bad = speed_spikes(radar_log(r, az, el, t=t), radar_settings(), Limits())
    assert not bad.any()


def test_gps_height_and_velocity_limits() -> None:
    n = 30
    cols = {"lat": np.full(n, 35.0), "lon": np.full(n, -117.0), "height": np.full(n, 3000.0),
            "ve": np.full(n, 100.0), "vn": np.zeros(n), "vu": np.zeros(n)}
    cols["height"][2] = 1e9
    cols["ve"][4] = 1e12
    log = SensorLog(sensor_id="G1", kind="gps", time=np.arange(n) * 1.0,
                    columns=MappingProxyType(cols), row=np.arange(1, n + 1), track_id=None,
                    station=None, n_read=n)
    s = SensorSettings(id="G1", kind="gps", file=Path("/d/G1.csv"), sigma=DEFAULT_SIGMAS["gps"])
    rec = EditRecord()
    out = apply_limits(log, s, rec, Limits())
    assert np.isnan(out.columns["height"][2]) and np.isfinite(out.columns["lat"][2])
    assert np.isnan([out.columns[c][4] for c in ("ve", "vn", "vu")]).all()
    assert rec.counts("G1") == {"limit": 4}


def gps_log(lat: np.ndarray) -> tuple[SensorLog, SensorSettings]:
    n = lat.size
    cols = {"lat": lat, "lon": np.full(n, -117.0), "height": np.full(n, 3000.0),
            "ve": np.full(n, np.nan), "vn": np.full(n, np.nan), "vu": np.full(n, np.nan)}
    log = SensorLog(sensor_id="G1", kind="gps", time=np.arange(n) * 0.1,
                    columns=MappingProxyType(cols), row=np.arange(1, n + 1), track_id=None,
                    station=None, n_read=n)
    return log, SensorSettings(id="G1", kind="gps", file=Path("/d/G1.csv"),
                               sigma=DEFAULT_SIGMAS["gps"])


def test_gps_run_of_wild_fixes_at_the_start_is_cut_from_the_longest_segment() -> None:
    lat = 35.0 + 1e-5 * np.arange(300)               # ~100 m/s northwards
    lat[:20] += 0.5                                  # 55 km off for 2 s
    lat[150:153] -= 0.2                              # a short corrupt stretch mid-flight
    log, s = gps_log(lat)
    _, bad = speed_spikes(log, s, Limits())
    assert np.flatnonzero(bad).tolist() == list(range(20)) + [150, 151, 152]


def test_gps_plausible_manoeuvre_is_not_cut() -> None:
    lat = 35.0 + 1e-5 * np.arange(300) + 1e-4 * (np.arange(300) > 150)   # 11 m step: noise
    log, s = gps_log(lat)
    _, bad = speed_spikes(log, s, Limits())
    assert not bad.any()
