"""Hand-made files of a short flight seen by several sensors, for the "every row accounted for"
checks (not the simulator; geometry by pymap3d, an independent oracle of rangeproc's frames).

The target flies a straight east course (constant height, 150 m/s) as in :mod:`newuser`, at
another place (:data:`ORIGIN`). Seen
by a fixed tracking radar R1 (10 Hz), a GPS G1 on the target (1 Hz) and, on request, a
theodolite TH1 (10 Hz, azimuth and elevation) and a ship radar S1 (10 Hz) on a ship whose INS
(SHIP, 20 Hz, a gentle roll and pitch, heading 20 deg, sailing north at 5 m/s) gives its
position and attitude. Each case then spoils one thing the way a user's files do.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d

from newuser import DAY_UNIX, START_SOD

#: Range origin (lat, lon deg, height m): a place where latitude and longitude swapped are
#: still valid numbers (a swapped site is no config error there).
ORIGIN = (45.0, 10.0, 100.0)


def _at(e: float, n: float, u: float) -> tuple[float, float, float]:
    lat, lon, h = pymap3d.enu2geodetic(e, n, u, *ORIGIN)
    return round(float(lat), 7), round(float(lon), 7), round(float(h), 2)


SITE = _at(4000.0, 1100.0, 10.0)         #: tracking radar lat, lon, height
THEO_SITE = _at(-2700.0, 2200.0, 5.0)    #: theodolite lat, lon, height
SHIP_START = _at(4500.0, -3000.0, -100.0)  #: ship position at the start (lat, lon, height)
HEIGHT, SPEED = 3000.0, 150.0            #: target m above the ellipsoid, m/s east


def truth_at(unix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Target lat, lon (deg), height (m) at Unix times: constant height, a straight east
    course through a point 4 km north of the origin 60 s after the start."""
    t = np.asarray(unix, float) - (DAY_UNIX + START_SOD + 60.0)
    lat0, lon0, _ = pymap3d.enu2geodetic(0.0, 4000.0, 0.0, *ORIGIN)
    lat, lon, _ = pymap3d.enu2geodetic(SPEED * t, np.zeros_like(t), np.zeros_like(t),
                                       lat0, lon0, HEIGHT)
    return np.full_like(t, lat0), np.asarray(lon), np.full_like(t, HEIGHT)
SHIP_SPEED = 5.0                          #: m/s north
SHIP_HEADING = 20.0                       #: deg
SIGMA_RANGE, SIGMA_ANGLE = 5.0, 0.01      #: m, deg (radars)
SIGMA_THEO = 0.003                        #: deg


@dataclass(frozen=True)
class Case:
    """The folder of one hand-made case and its config."""

    folder: Path
    config: Path


def _csv(path: Path, header: str, columns: list[np.ndarray], fmt: str) -> None:
    lines = [header] + [fmt.format(*vals) for vals in zip(*columns)]
    path.write_text("\n".join(lines) + "\n")


def _site(site: tuple[float, float, float]) -> str:
    return f"{{ lat = {site[0]}, lon = {site[1]}, height = {site[2]} }}"


def _ship(unix: np.ndarray) -> tuple[np.ndarray, ...]:
    """Ship lat, lon, height (deg, deg, m) and roll, pitch, yaw (deg) at Unix times."""
    t = unix - (DAY_UNIX + START_SOD)
    lat, lon, h = pymap3d.enu2geodetic(np.zeros_like(t), SHIP_SPEED * t, np.zeros_like(t),
                                       *SHIP_START)
    roll = 2.0 * np.sin(2 * np.pi * t / 9.0)
    pitch = 1.0 * np.sin(2 * np.pi * t / 7.0 + 0.5)
    yaw = np.full_like(t, SHIP_HEADING)
    return np.asarray(lat), np.asarray(lon), np.asarray(h), roll, pitch, yaw


def _deck_angles(unix: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Deck azimuth, elevation (deg) and range (m) of the target seen from the ship (lever arm
    zero): body FRD from NED by yaw-pitch-roll, deck azimuth from the bow to starboard,
    elevation above the deck."""
    lat, lon, h = truth_at(unix)
    slat, slon, sh, roll, pitch, yaw = _ship(unix)
    e, n, u = pymap3d.geodetic2enu(lat, lon, h, slat, slon, sh)
    ned = np.column_stack([n, e, -np.asarray(u)])
    r, p, y = np.radians(roll), np.radians(pitch), np.radians(yaw)
    out = np.empty_like(ned)
    for k in range(ned.shape[0]):
        cz, sz, cy, sy, cx, sx = np.cos(y[k]), np.sin(y[k]), np.cos(p[k]), np.sin(p[k]), \
            np.cos(r[k]), np.sin(r[k])
        rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        out[k] = (rz @ ry @ rx).T @ ned[k]                 # NED -> body FRD
    rng = np.linalg.norm(out, axis=1)
    az = np.degrees(np.arctan2(out[:, 1], out[:, 0])) % 360.0
    el = np.degrees(np.arcsin(-out[:, 2] / rng))
    return az, el, rng


def make_case(folder: Path, *, duration: float = 120.0, theodolite: bool = False,
              ship: bool = False, ins_short: float = 0.0,
              theo_config_site: tuple[float, float, float] | None = None,
              radar_config_site: tuple[float, float, float] | None = None,
              radar_range_scale: float = 1.0, duplicate_rows: int = 0,
              stuck_rows: int = 0, extra: str = "", seed: int = 11) -> Case:
    """Write the sensor files and config.toml of one case into ``folder``.

    Args:
        duration: s of flight (every sensor covers it).
        theodolite, ship: add TH1, and S1 with its INS SHIP.
        ins_short: s the INS log ends before the ship radar's last row.
        theo_config_site, radar_config_site: the site written in the config (the data are
            made from the true sites).
        radar_range_scale: factor on R1's written ranges (1e-3: kilometres in a metre column).
        duplicate_rows: this many R1 rows, from the middle, written twice (the copies right
            after the originals, as a logger that wrote a block again).
        stuck_rows: this many consecutive R1 rows (from a third of the flight) stamped with the
            time of the row before them (a stuck clock).
        extra: text appended to the config (e.g. ``[processing]`` keys).
    """
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    t0 = DAY_UNIX + START_SOD
    unix = t0 + np.arange(0.0, duration + 1e-9, 0.1)
    n = unix.size
    lat, lon, h = truth_at(unix)
    az, el, r = (np.asarray(v) for v in pymap3d.geodetic2aer(lat, lon, h, *SITE))
    r = (r + rng.normal(0.0, SIGMA_RANGE, n)) * radar_range_scale
    a = az + rng.normal(0.0, SIGMA_ANGLE, n)
    e = el + rng.normal(0.0, SIGMA_ANGLE, n)
    stamps = unix - DAY_UNIX
    if stuck_rows:
        k0 = n // 3
        stamps = stamps.copy()
        stamps[k0:k0 + stuck_rows] = stamps[k0 - 1]
    order = np.arange(n)
    if duplicate_rows:
        k0 = n // 2
        block = np.arange(k0, k0 + duplicate_rows)
        order = np.concatenate([order[:k0 + duplicate_rows], block, order[k0 + duplicate_rows:]])
    _csv(folder / "R1.csv", "time,range,azimuth,elevation",
         [stamps[order], r[order], a[order], e[order]], "{:.6f},{:.3f},{:.8f},{:.8f}")
    radar_site = radar_config_site or SITE
    config = [
        "[range]", f"origin = {_site(ORIGIN)}", "", "[output]", 'dir = "out"', "rate_hz = 10.0",
        "", "[[sensors]]", 'id = "R1"', 'kind = "radar"', 'file = "R1.csv"',
        f"site = {_site(radar_site)}", 'angle_unit = "deg"', f"time_offset = {DAY_UNIX!r}",
        f"sigma = {{ range = {SIGMA_RANGE}, azimuth = {SIGMA_ANGLE}, elevation = {SIGMA_ANGLE} }}",
        ""]
    g_unix = t0 + np.arange(0.0, duration + 1e-9, 1.0)
    glat, glon, gh = truth_at(g_unix)
    de, dn, du = (rng.normal(0.0, s, g_unix.size) for s in (2.0, 2.0, 3.0))
    plat, plon, ph = pymap3d.enu2geodetic(de, dn, du, glat, glon, gh)
    _csv(folder / "G1.csv", "time,lat,lon,height", [g_unix - DAY_UNIX, plat, plon, ph],
         "{:.3f},{:.9f},{:.9f},{:.3f}")
    config += ["[[sensors]]", 'id = "G1"', 'kind = "gps"', 'file = "G1.csv"',
               f"time_offset = {DAY_UNIX!r}", "sigma = { horizontal = 2.0, vertical = 3.0 }", ""]
    if theodolite:
        taz, tel, _ = (np.asarray(v) for v in pymap3d.geodetic2aer(lat, lon, h, *THEO_SITE))
        taz = taz + rng.normal(0.0, SIGMA_THEO, n)
        tel = tel + rng.normal(0.0, SIGMA_THEO, n)
        _csv(folder / "TH1.csv", "time,azimuth,elevation", [unix - DAY_UNIX + 0.03, taz, tel],
             "{:.6f},{:.8f},{:.8f}")
        config += ["[[sensors]]", 'id = "TH1"', 'kind = "theodolite"', 'file = "TH1.csv"',
                   f"site = {_site(theo_config_site or THEO_SITE)}", 'angle_unit = "deg"',
                   f"time_offset = {DAY_UNIX!r}",
                   f"sigma = {{ azimuth = {SIGMA_THEO}, elevation = {SIGMA_THEO} }}", ""]
    if ship:
        s_unix = unix + 0.04
        saz, sel, sr = _deck_angles(s_unix)
        _csv(folder / "S1.csv", "time,range,azimuth,elevation",
             [s_unix - DAY_UNIX, sr + rng.normal(0.0, SIGMA_RANGE, n),
              saz + rng.normal(0.0, SIGMA_ANGLE, n), sel + rng.normal(0.0, SIGMA_ANGLE, n)],
             "{:.6f},{:.3f},{:.8f},{:.8f}")
        i_unix = t0 - 1.0 + np.arange(0.0, duration + 2.0 - ins_short + 1e-9, 0.05)
        ilat, ilon, ih, roll, pitch, yaw = _ship(i_unix)
        _csv(folder / "SHIP.csv", "time,roll,pitch,yaw,lat,lon,height",
             [i_unix - DAY_UNIX, roll, pitch, yaw, ilat, ilon, ih],
             "{:.3f},{:.5f},{:.5f},{:.5f},{:.9f},{:.9f},{:.3f}")
        config += ["[[sensors]]", 'id = "S1"', 'kind = "radar"', 'file = "S1.csv"',
                   'platform = "SHIP"', "lever_arm = [0.0, 0.0, 0.0]", 'angle_unit = "deg"',
                   f"time_offset = {DAY_UNIX!r}",
                   f"sigma = {{ range = {SIGMA_RANGE}, azimuth = {SIGMA_ANGLE}, "
                   f"elevation = {SIGMA_ANGLE} }}", "",
                   "[[sensors]]", 'id = "SHIP"', 'kind = "ins"', 'file = "SHIP.csv"',
                   'angle_unit = "deg"', f"time_offset = {DAY_UNIX!r}",
                   "sigma = { roll = 0.01, pitch = 0.01, yaw = 0.01, position = 0.5 }", ""]
    (folder / "config.toml").write_text("\n".join(config) + "\n" + extra)
    return Case(folder, folder / "config.toml")
