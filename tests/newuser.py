"""Hand-made new-user files (not the simulator): a straight-and-level flight as a user writes it.

A 120 s flight at constant height above the WGS-84 ellipsoid, flying east at 150 m/s past one
fixed tracking radar (10 Hz, float time stamps on a chosen scale, three planted wild points)
and, optionally, the target's GPS (1 Hz, ISO-8601 UTC stamps). The geometry is computed with
pymap3d (an independent oracle of rangeproc's own frames), the noise with a seeded generator.
Every test of the "no wrong fact" checks builds its files here and then spoils one thing the way
a user would (radians in a degree file, a time scale, a missing offset).
"""
from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pymap3d

ORIGIN = (35.0, -117.5, 700.0)         #: range origin lat (deg), lon (deg), height (m)
SITE = (35.01, -117.45, 710.0)          #: radar site lat, lon, height
DAY = datetime(2026, 5, 11, tzinfo=timezone.utc)     #: the flight's UTC day
DAY_UNIX = DAY.timestamp()              #: 1778457600.0 s
START_SOD = 50400.0                     #: flight start, seconds of day (14:00:00 UTC)
DURATION = 120.0                        #: s
HEIGHT = 3000.0                         #: m above the ellipsoid, constant
SPEED = 150.0                           #: m/s toward east (constant course)
GPS_EPOCH_UNIX = 315964800.0            #: 1980-01-06T00:00:00Z
GPS_UTC_LEAP_S = 18.0                   #: GPS time minus UTC since 2017
WILD_ROWS = (200, 600, 1000)            #: 0-based radar data rows spoiled by +400 m in range
SIGMA_RANGE, SIGMA_ANGLE_DEG = 5.0, 0.01
SIGMA_GPS_H, SIGMA_GPS_V = 2.0, 3.0


def seconds_of_week(unix: np.ndarray) -> np.ndarray:
    """GPS seconds of week of Unix (UTC) times ``unix`` (GPS time is 18 s ahead of UTC)."""
    return (np.asarray(unix) + GPS_UTC_LEAP_S - GPS_EPOCH_UNIX) % (7 * 86400.0)


@dataclass(frozen=True)
class Flight:
    """Paths of one hand-made case and the truth it was made from."""

    folder: Path
    config: Path
    truth: Path           # time (ISO UTC), lat, lon, height
    radar_unix: np.ndarray  # (N,) true Unix times of the radar rows


def truth_at(unix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """lat, lon (deg), height (m) of the target at Unix times ``unix``: constant height, a
    straight east course through a point 4 km north of the origin at mid-flight."""
    t = np.asarray(unix, float) - (DAY_UNIX + START_SOD + DURATION / 2)
    e = SPEED * t
    lat0, lon0, _ = pymap3d.enu2geodetic(0.0, 4000.0, 0.0, *ORIGIN)
    # walk east along the parallel through (lat0, lon0): constant height above the ellipsoid
    lat, lon, _ = pymap3d.enu2geodetic(e, np.zeros_like(e), np.zeros_like(e),
                                       lat0, lon0, HEIGHT)
    return np.full_like(e, lat0), lon, np.full_like(e, HEIGHT)


def iso(unix: np.ndarray) -> list[str]:
    """ISO-8601 UTC strings with 'Z' and millisecond precision."""
    return [(datetime.fromtimestamp(float(u), timezone.utc)).isoformat(timespec="milliseconds")
            .replace("+00:00", "Z") for u in unix]


def make_flight(folder: Path, *, scale: str = "sod", radar_angles: str = "deg",
                angle_unit: str = "deg", with_gps: bool = True, time_offset: str | None = "auto",
                radar_phase: float = 0.0, config_site: tuple[float, float, float] = SITE,
                seed: int = 7) -> Flight:
    """Write R1.csv (and G1.csv), config.toml and truth.csv into ``folder``.

    Args:
        scale: the radar's float time scale: "sod" (seconds of day), "unix", "gpsweek".
        radar_angles: unit the azimuth/elevation values are actually written in ("deg", "rad",
            "mil").
        angle_unit: what the config claims for the radar.
        with_gps: also write a GPS with ISO stamps (Unix scale).
        time_offset: the radar's ``time_offset`` as written in the config: "auto" aligns the
            radar's scale with the Unix (ISO) scale as a float, "iso" as an ISO instant, None
            leaves it out.
        radar_phase: s added to every radar stamp (0.05 puts a 10 Hz radar exactly half an
            output interval off the 10 Hz output grid).
        config_site: the radar site written in the config (lat, lon, height); the data are
            always made from :data:`SITE`.
    """
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    t0 = DAY_UNIX + START_SOD
    unix = t0 + radar_phase + np.arange(0.0, DURATION + 1e-9, 0.1)
    lat, lon, h = truth_at(unix)
    az, el, rng_m = pymap3d.geodetic2aer(lat, lon, h, *SITE)  # deg, deg, m
    az, el = np.asarray(az), np.asarray(el)
    r = np.asarray(rng_m) + rng.normal(0.0, SIGMA_RANGE, unix.size)
    r[list(WILD_ROWS)] += 400.0
    a = az + rng.normal(0.0, SIGMA_ANGLE_DEG, unix.size)
    e = el + rng.normal(0.0, SIGMA_ANGLE_DEG, unix.size)
    if radar_angles != "deg":
        scale_to = {"rad": np.pi / 180.0, "mil": 6400.0 / 360.0}[radar_angles]
        a, e = a * scale_to, e * scale_to
    if scale == "sod":
        stamps, offset = unix - DAY_UNIX, DAY_UNIX
    elif scale == "unix":
        stamps, offset = unix, 0.0
    elif scale == "gpsweek":
        stamps = seconds_of_week(unix)
        offset = float(unix[0] - stamps[0])
    else:
        raise ValueError(scale)
    lines = ["time,range,azimuth,elevation"]
    lines += [f"{s:.6f},{ri:.3f},{ai:.8f},{ei:.8f}" for s, ri, ai, ei in zip(stamps, r, a, e)]
    (folder / "R1.csv").write_text("\n".join(lines) + "\n")
    sig_angle = SIGMA_ANGLE_DEG * {"deg": 1.0, "rad": np.pi / 180.0, "mil": 6400.0 / 360.0}[
        angle_unit]
    radar = [
        '[[sensors]]', 'id = "R1"', 'kind = "radar"', 'file = "R1.csv"',
        f'site = {{ lat = {config_site[0]}, lon = {config_site[1]}, height = {config_site[2]} }}',
        f'angle_unit = "{angle_unit}"',
        f'sigma = {{ range = {SIGMA_RANGE}, azimuth = {sig_angle}, elevation = {sig_angle} }}',
    ]
    if time_offset == "auto" and with_gps and offset != 0.0:
        radar.append(f"time_offset = {offset!r}")
    elif time_offset == "iso" and offset != 0.0:
        radar.append(f'time_offset = "{iso([offset])[0]}"')
    config = [
        "[range]", f"origin = {{ lat = {ORIGIN[0]}, lon = {ORIGIN[1]}, height = {ORIGIN[2]} }}",
        "", "[output]", 'dir = "out"', "rate_hz = 10.0", "", *radar, "",
    ]
    if with_gps:
        g_unix = t0 + np.arange(0.0, DURATION + 1e-9, 1.0)
        glat, glon, gh = truth_at(g_unix)
        de = rng.normal(0.0, SIGMA_GPS_H, g_unix.size)
        dn = rng.normal(0.0, SIGMA_GPS_H, g_unix.size)
        du = rng.normal(0.0, SIGMA_GPS_V, g_unix.size)
        plat, plon, ph = [], [], []
        for i in range(g_unix.size):
            la, lo, hh = pymap3d.enu2geodetic(de[i], dn[i], du[i], glat[i], glon[i], gh[i])
            plat.append(la), plon.append(lo), ph.append(hh)
        rows = ["time,lat,lon,height"]
        rows += [f"{s},{la:.9f},{lo:.9f},{hh:.3f}" for s, la, lo, hh
                 in zip(iso(g_unix), plat, plon, ph)]
        (folder / "G1.csv").write_text("\n".join(rows) + "\n")
        config += ['[[sensors]]', 'id = "G1"', 'kind = "gps"', 'file = "G1.csv"',
                   f'sigma = {{ horizontal = {SIGMA_GPS_H}, vertical = {SIGMA_GPS_V} }}', ""]
    (folder / "config.toml").write_text("\n".join(config))
    tt = t0 + np.arange(0.0, DURATION + 1e-9, 0.5)
    tlat, tlon, th = truth_at(tt)
    rows = ["time,lat,lon,height"]
    rows += [f"{s},{la:.10f},{lo:.10f},{hh:.4f}" for s, la, lo, hh in zip(iso(tt), tlat, tlon, th)]
    (folder / "truth.csv").write_text("\n".join(rows) + "\n")
    return Flight(folder, folder / "config.toml", folder / "truth.csv", unix)
