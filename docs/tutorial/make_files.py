"""Write the getting-started tutorial's input files (radar.csv, gps.csv, truth.csv).

The files in this folder were made once by this script and are committed; rerun it only to
change them (``.venv/bin/python docs/tutorial/make_files.py``). It writes what a user would
export from a range: an aircraft flying 90 s past one tracking radar, with a GPS receiver on
board.

* ``radar.csv``: 5 Hz, ``time`` in float seconds of the day (UTC), slant range (m), azimuth and
  elevation (degrees) from the radar site, track number 1; noise 5 m and 0.02 degrees, and
  two wild ranges a radar sometimes reports.
* ``gps.csv``: 2 Hz, ``time`` as ISO-8601 UTC stamps, WGS-84 latitude, longitude (degrees) and
  height above the ellipsoid (m); noise 2 m horizontally, 4 m vertically.
* ``truth.csv``: the true path at 5 Hz (ISO stamps, latitude, longitude, height, and the
  velocity in the local east, north, up at the point), for ``rangeproc evaluate``.

The path is built in the range's east-north-up frame (straight and level at 180 m/s, a
90-degree turn to the left at 3 degrees a second, straight again) and converted with pymap3d.
"""
from __future__ import annotations

from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pymap3d as pm

HERE = Path(__file__).resolve().parent
ORIGIN = (35.05, -117.60, 700.0)           # [range] origin: lat, lon (deg), height (m)
RADAR_SITE = (35.08, -117.55, 720.0)       # the radar's site, as in config.toml
DAY = datetime(2024, 3, 14, tzinfo=timezone.utc)
START = 10 * 3600.0                        # 10:00:00 UTC, in seconds of the day
DURATION = 90.0
SPEED = 180.0                              # m/s
TURN_START, TURN_RATE, TURN_ANGLE = 30.0, np.radians(3.0), np.radians(90.0)


def path(t: np.ndarray) -> np.ndarray:
    """Range ENU position (m), (N, 3), at ``t`` seconds after the start."""
    t = np.asarray(t, dtype=float)
    heading0 = np.radians(90.0)                      # flying east, course measured from north
    turn_time = TURN_ANGLE / TURN_RATE
    radius = SPEED / TURN_RATE
    p0 = np.array([-9000.0, -3000.0, 3000.0])
    out = np.empty((t.size, 3))
    for i, ti in enumerate(t):
        s1 = min(ti, TURN_START)                     # first straight leg
        e = p0[0] + SPEED * s1 * np.sin(heading0)
        n = p0[1] + SPEED * s1 * np.cos(heading0)
        if ti > TURN_START:                          # left turn: heading decreases
            s2 = min(ti - TURN_START, turn_time)
            h = heading0 - TURN_RATE * s2
            e += radius * (np.cos(h) - np.cos(heading0))      # integral of V sin(h)
            n -= radius * (np.sin(h) - np.sin(heading0))      # integral of V cos(h)
            if ti > TURN_START + turn_time:          # second straight leg
                s3 = ti - TURN_START - turn_time
                e += SPEED * s3 * np.sin(h)
                n += SPEED * s3 * np.cos(h)
        out[i] = (e, n, p0[2] + 2.0 * ti)            # climbing at 2 m/s
    return out


def iso(seconds_of_day: np.ndarray) -> list[str]:
    """ISO-8601 UTC stamps with milliseconds and ``Z``."""
    return [(DAY + timedelta(seconds=float(s))).strftime("%Y-%m-%dT%H:%M:%S.%f")[:-3] + "Z"
            for s in seconds_of_day]


def geodetic(enu: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return pm.enu2geodetic(enu[:, 0], enu[:, 1], enu[:, 2], *ORIGIN)


def main() -> None:
    rng = np.random.default_rng(7)

    # radar: 5 Hz, stamps in seconds of the day with a small jitter
    t = np.arange(0.0, DURATION, 0.2) + 0.013
    lat, lon, h = geodetic(path(t))
    az, el, rng_m = pm.geodetic2aer(lat, lon, h, *RADAR_SITE)
    rng_m = rng_m + rng.normal(0.0, 5.0, t.size)
    az = (az + rng.normal(0.0, 0.02, t.size)) % 360.0
    el = el + rng.normal(0.0, 0.02, t.size)
    rng_m[[57, 301]] += (850.0, -1200.0)             # two wild ranges
    with open(HERE / "radar.csv", "w") as f:
        f.write("time,range,azimuth,elevation,track_id\n")
        for row in zip(START + t, rng_m, az, el):
            f.write("{:.3f},{:.1f},{:.4f},{:.4f},1\n".format(*row))

    # GPS: 2 Hz, ISO stamps, noise in the receiver's local east, north, up
    t = np.arange(0.0, DURATION, 0.5) + 0.1
    enu = path(t)
    enu[:, :2] += rng.normal(0.0, 2.0, (t.size, 2))
    enu[:, 2] += rng.normal(0.0, 4.0, t.size)
    lat, lon, h = geodetic(enu)
    with open(HERE / "gps.csv", "w") as f:
        f.write("time,lat,lon,height\n")
        for stamp, row in zip(iso(START + t), zip(lat, lon, h)):
            f.write("{},{:.7f},{:.7f},{:.1f}\n".format(stamp, *row))

    # truth: 5 Hz over the whole flight; velocity in the local east, north, up at the point
    t = np.arange(0.0, DURATION + 0.01, 0.2)
    lat, lon, h = geodetic(path(t))
    v = (path(t + 1e-3) - path(t - 1e-3)) / 2e-3                  # range ENU, m/s
    u, vv, w = pm.enu2uvw(v[:, 0], v[:, 1], v[:, 2], ORIGIN[0], ORIGIN[1])
    ve, vn, vu = pm.uvw2enu(u, vv, w, lat, lon)
    with open(HERE / "truth.csv", "w") as f:
        f.write("time,lat,lon,height,ve,vn,vu\n")
        for stamp, row in zip(iso(START + t), zip(lat, lon, h, ve, vn, vu)):
            f.write("{},{:.8f},{:.8f},{:.2f},{:.3f},{:.3f},{:.3f}\n".format(stamp, *row))


if __name__ == "__main__":
    main()
