"""Measurement generation: sensor geometry, noise, wild points and gaps.

Independent of ``rangeproc.frames``/``models``: geometry uses pymap3d and
``scipy.spatial.transform.Rotation`` directly, following the data contract's conventions:

- fixed sites: azimuth clockwise from true north and elevation in the site's own local ENU;
- platform sensors: unstabilised deck angles in the body FRD frame; sensor position = INS
  reference point + C_bn @ lever_arm with C_bn = Rz(yaw) Ry(pitch) Rx(roll) (body -> local NED
  at the platform); azimuth = atan2(y, x), elevation = atan2(-z, hypot(x, y));
- GPS: noise drawn in the receiver's local ENU; velocity in the receiver's local ENU;
- MISTRAM: range rate d/dt |p_target - p_station| (positive receding).

Arrays: times (M,) s; ENU positions/velocities (M, 3) in the range frame; angles in radians.
Every builder returns the file's columns in file units (angles in the sensor's angle unit,
metres, m/s, lat/lon degrees) as a dict of (M,) arrays, NaN = empty cell.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d as pm
from scipy.spatial.transform import Rotation

from rangeproc.simulate.trajectory import Trajectory

WGS84_A = 6378137.0  #: semi-major axis, m
WGS84_E2 = 6.69437999014e-3  #: first eccentricity squared
ANGLE_SCALE = {"deg": 180.0 / math.pi, "rad": 1.0, "mil": 3200.0 / math.pi}  #: rad -> unit


@dataclass(frozen=True, slots=True)
class Geo:
    """WGS-84 point: lat, lon (deg), height (m)."""

    lat: float
    lon: float
    height: float


@dataclass(frozen=True, slots=True)
class ShipMotion:
    """Ship reference-point track and attitude, as functions of relative time tau (s).

    The ship sails a constant course at constant speed with lat, lon linear in time (exact
    velocity below), heaves sinusoidally, and rolls/pitches/yaws sinusoidally about
    (0, 0, course). Amplitudes in rad (attitude) and m (heave); periods in s; phases in rad.
    """

    start: Geo
    course: float
    speed: float
    heave: tuple[float, float, float]
    roll: tuple[float, float, float]
    pitch: tuple[float, float, float]
    yaw: tuple[float, float, float]

    def _rates(self) -> tuple[float, float]:
        lat0 = math.radians(self.start.lat)
        m0, n0 = radii(np.array(self.start.lat))
        dlat = self.speed * math.cos(self.course) / (float(m0) + self.start.height)
        dlon = self.speed * math.sin(self.course) / ((float(n0) + self.start.height)
                                                     * math.cos(lat0))
        return math.degrees(dlat), math.degrees(dlon)

    def geodetic(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """lat, lon (deg), height (m), each (M,)."""
        dlat, dlon = self._rates()
        amp, per, ph = self.heave
        return (self.start.lat + dlat * tau, self.start.lon + dlon * tau,
                self.start.height + amp * np.sin(2 * math.pi * tau / per + ph))

    def velocity(self, tau: np.ndarray) -> np.ndarray:
        """(M, 3) exact ve, vn, vu (m/s) in the ship's local ENU."""
        dlat, dlon = self._rates()
        lat, _, h = self.geodetic(tau)
        m, n = radii(lat)
        amp, per, ph = self.heave
        vu = amp * 2 * math.pi / per * np.cos(2 * math.pi * tau / per + ph)
        return np.column_stack(((n + h) * np.cos(np.radians(lat)) * math.radians(dlon),
                                (m + h) * math.radians(dlat), vu))

    def attitude(self, tau: np.ndarray) -> np.ndarray:
        """(M, 3) roll, pitch, yaw (rad), yaw wrapped to [0, 2 pi)."""
        def osc(p: tuple[float, float, float]) -> np.ndarray:
            return p[0] * np.sin(2 * math.pi * tau / p[1] + p[2])
        yaw = np.mod(self.course + osc(self.yaw), 2 * math.pi)
        return np.column_stack((osc(self.roll), osc(self.pitch), yaw))


def radii(lat_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Meridian (M) and prime-vertical (N) radii of curvature (m) at geodetic latitude."""
    s2 = np.sin(np.radians(lat_deg)) ** 2
    w = np.sqrt(1.0 - WGS84_E2 * s2)
    return WGS84_A * (1.0 - WGS84_E2) / w**3, WGS84_A / w


def enu_to_ecef(p: np.ndarray, origin: Geo) -> np.ndarray:
    """(M, 3) range-frame ENU (m) -> (M, 3) ECEF (m)."""
    return np.column_stack(pm.enu2ecef(p[:, 0], p[:, 1], p[:, 2],
                                       origin.lat, origin.lon, origin.height))


def site_enu(site: Geo, origin: Geo) -> np.ndarray:
    """(3,) position of a geodetic point in the range ENU frame (m)."""
    return np.array(pm.geodetic2enu(site.lat, site.lon, site.height,
                                    origin.lat, origin.lon, origin.height), dtype=float)


def fixed_site_geometry(p: np.ndarray, v: np.ndarray, origin: Geo, site: Geo
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Slant range (m), azimuth in [0, 2 pi), elevation (rad) at the site's own local ENU,
    and range rate (m/s) of targets p, v (M, 3) range ENU."""
    x = enu_to_ecef(p, origin)
    az, el, rng = pm.ecef2aer(x[:, 0], x[:, 1], x[:, 2], math.radians(site.lat),
                              math.radians(site.lon), site.height, deg=False)
    d = p - site_enu(site, origin)
    rate = np.einsum("ij,ij->i", d, v) / np.linalg.norm(d, axis=1)
    return np.asarray(rng), np.mod(az, 2 * math.pi), np.asarray(el), rate


def platform_geometry(p: np.ndarray, origin: Geo, ship_lat: np.ndarray, ship_lon: np.ndarray,
                      ship_h: np.ndarray, att: np.ndarray, lever: np.ndarray,
                      mount: tuple[float, float, float] = (0.0, 0.0, 0.0)
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range (m), deck azimuth [0, 2 pi) and deck elevation (rad) of targets p (M, 3) range ENU
    from a platform sensor; ship reference point geodetic (M,), att (M, 3) roll, pitch, yaw.

    mount: (roll, pitch, yaw) rad, the rotation of the sensor's own axes relative to the body
    axes in the attitude's 3-2-1 sense, M = Rz(yaw) Ry(pitch) Rx(roll) (sensor -> body); the
    angles are measured from d_sensor = M^T d_body (a +yaw mount gives smaller azimuths)."""
    x = enu_to_ecef(p, origin)
    tgt_ned = np.column_stack(pm.ecef2ned(x[:, 0], x[:, 1], x[:, 2], ship_lat, ship_lon, ship_h))
    c_bn = Rotation.from_euler("ZYX", att[:, ::-1])  # intrinsic: Rz(yaw) Ry(pitch) Rx(roll)
    los_ned = tgt_ned - c_bn.apply(lever)
    b = c_bn.apply(los_ned, inverse=True)  # C_bn^T: NED -> body FRD
    if any(mount):
        b = mount_rotation(mount).apply(b, inverse=True)  # M^T: body -> sensor axes
    rng = np.linalg.norm(b, axis=1)
    az = np.mod(np.arctan2(b[:, 1], b[:, 0]), 2 * math.pi)
    el = np.arctan2(-b[:, 2], np.hypot(b[:, 0], b[:, 1]))
    return rng, az, el


def mount_rotation(mount: tuple[float, float, float]) -> Rotation:
    """Sensor -> body rotation M = Rz(yaw) Ry(pitch) Rx(roll) of mount (roll, pitch, yaw) rad."""
    roll, pitch, yaw = mount
    return Rotation.from_euler("ZYX", [yaw, pitch, roll])


def add_biases(rae: tuple[np.ndarray, ...], biases: dict[str, float]) -> tuple[np.ndarray, ...]:
    """Add systematic biases (measured minus true) to true (range, azimuth, elevation[, ...]).

    biases: any of ``range`` (m), ``azimuth``, ``elevation`` (rad); other keys are ignored.
    The azimuth is re-wrapped to [0, 2 pi); NaN (not measured) stays NaN; further entries of
    rae (range rate) are returned unchanged. Without biases, rae itself is returned."""
    names = ("range", "azimuth", "elevation")
    if not any(biases.get(k, 0.0) for k in names):
        return rae
    out = [val + biases.get(k, 0.0) for k, val in zip(names, rae)]
    out[1] = np.mod(out[1], 2 * math.pi)
    return (*out, *rae[3:])


def sample_times(rng: np.random.Generator, t0: float, duration: float, rate: float,
                 margin: float = 0.1) -> np.ndarray:
    """Regular true sample times (s) at ``rate`` Hz with a random phase, inside the span."""
    phase = rng.uniform(0.0, 1.0 / rate)
    n = int(math.floor((duration - 2 * margin - phase) * rate)) + 1
    return t0 + margin + phase + np.arange(n) / rate


def file_times(t_true: np.ndarray, offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Timestamps as written (true - offset, rounded to 1 us) and the measurement times a
    reader reconstructs from them (written + offset)."""
    written = np.round(t_true - offset, 6)
    return written, written + offset


def in_intervals(t: np.ndarray, intervals: list[tuple[float, float]]) -> np.ndarray:
    """(M,) bool: t inside any [start, end) interval."""
    mask = np.zeros(t.shape, dtype=bool)
    for a, b in intervals:
        mask |= (t >= a) & (t < b)
    return mask


def pick_rows(rng: np.random.Generator, n: int, count: int) -> np.ndarray:
    """Up to ``count`` distinct row indices out of n, sorted."""
    return np.sort(rng.choice(n, size=min(count, n), replace=False)) if n else np.zeros(0, int)


def signed_uniform(rng: np.random.Generator, lo: float, hi: float, size: int) -> np.ndarray:
    """Magnitudes U(lo, hi) with random signs, (size,)."""
    return rng.uniform(lo, hi, size) * rng.choice([-1.0, 1.0], size)


def rae_columns(rng: np.random.Generator, t_file: np.ndarray, rae: tuple[np.ndarray, ...],
                sigma: dict[str, float], unit: str, *, noise: bool, wild_fraction: float,
                n_missing: int, missing: str) -> dict[str, np.ndarray]:
    """Columns time, range, azimuth, elevation[, range_rate] of a radar/theodolite.

    rae: true (range, azimuth, elevation[, range_rate]) in m, rad, rad, m/s; NaN range = not
    ranged. sigma (SI) keys: range, azimuth, elevation, range_rate (those measured). With
    noise: Gaussian noise, wild points on a ``wild_fraction`` of rows (range +-100..500 m,
    angles +-3..20 mrad) and ``n_missing`` empty cells in column ``missing``.
    """
    return rae_columns_wild(rng, t_file, rae, sigma, unit, noise=noise,
                            wild_fraction=wild_fraction, n_missing=n_missing,
                            missing=missing)[0]


def rae_columns_wild(rng: np.random.Generator, t_file: np.ndarray, rae: tuple[np.ndarray, ...],
                     sigma: dict[str, float], unit: str, *, noise: bool, wild_fraction: float,
                     n_missing: int, missing: str) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """:func:`rae_columns` and the (M,) bool mask of the rows given a wild error."""
    names = ("range", "azimuth", "elevation", "range_rate")[: len(rae)]
    cols = {k: np.array(val, dtype=float) for k, val in zip(names, rae)}
    m = t_file.size
    wild = np.zeros(m, dtype=bool)
    if noise:
        for k in names:
            cols[k] += rng.normal(0.0, sigma.get(k, 0.0), m)
        rows = pick_rows(rng, m, int(round(wild_fraction * m)))
        mode = rng.integers(0, 3, rows.size)  # 0 range, 1 angles, 2 both
        hit_r, hit_a = rows[mode != 1], rows[mode != 0]
        cols["range"][hit_r] += signed_uniform(rng, 100.0, 500.0, hit_r.size)
        wild[hit_r[np.isfinite(cols["range"][hit_r])]] = True  # (not ranged: no error)
        for k in ("azimuth", "elevation"):
            sel = hit_a[rng.random(hit_a.size) < 0.7]
            cols[k][sel] += signed_uniform(rng, 3e-3, 20e-3, sel.size)
            wild[sel] = True
        cols[missing][pick_rows(rng, m, n_missing)] = np.nan
    cols["azimuth"] = np.mod(cols["azimuth"], 2 * math.pi)
    scale = ANGLE_SCALE[unit]
    out = {"time": t_file}
    for k in names:
        out[k] = cols[k] * scale if k in ("azimuth", "elevation") else cols[k]
    return out, wild


def ins_columns(rng: np.random.Generator, t_file: np.ndarray, tau: np.ndarray, ship: ShipMotion,
                sigma: dict[str, float], *, noise: bool) -> dict[str, np.ndarray]:
    """Columns time, roll, pitch, yaw (deg, yaw in [0, 360)), lat, lon, height, ve, vn, vu.

    sigma keys (SI): attitude (rad), position (m per local ENU axis), velocity (m/s)."""
    lat, lon, h = ship.geodetic(tau)
    att = ship.attitude(tau)
    vel = ship.velocity(tau)
    m = tau.size
    if noise:
        att = att + rng.normal(0.0, sigma["attitude"], (m, 3))
        d = rng.normal(0.0, sigma["position"], (m, 3))
        lat, lon, h = pm.enu2geodetic(d[:, 0], d[:, 1], d[:, 2], lat, lon, h)
        vel = vel + rng.normal(0.0, sigma["velocity"], (m, 3))
    deg = np.degrees(att)
    return {"time": t_file, "roll": deg[:, 0], "pitch": deg[:, 1],
            "yaw": np.mod(deg[:, 2], 360.0), "lat": np.asarray(lat), "lon": np.asarray(lon),
            "height": np.asarray(h), "ve": vel[:, 0], "vn": vel[:, 1], "vu": vel[:, 2]}


def gps_columns(rng: np.random.Generator, t_file: np.ndarray, t_meas: np.ndarray, p: np.ndarray,
                v: np.ndarray, origin: Geo, sigma: dict[str, float], *, noise: bool,
                burst: tuple[float, float], n_wild: int) -> dict[str, np.ndarray]:
    """Columns time, lat, lon, height, ve, vn, vu of a GPS receiver on the target.

    sigma keys: horizontal, vertical (m), velocity (m/s). Noise (receiver local ENU) is scaled
    x10 inside ``burst`` = (start, end) range times; ``n_wild`` rows get +-50..200 m on one axis.
    """
    lat, lon, h = pm.enu2geodetic(p[:, 0], p[:, 1], p[:, 2], origin.lat, origin.lon,
                                  origin.height)
    uvw = pm.enu2uvw(v[:, 0], v[:, 1], v[:, 2], origin.lat, origin.lon)
    vel = np.column_stack(pm.uvw2enu(*uvw, lat, lon))
    m = t_meas.size
    if noise:
        scale = np.where((t_meas >= burst[0]) & (t_meas < burst[1]), 10.0, 1.0)[:, None]
        sig = np.array([sigma["horizontal"], sigma["horizontal"], sigma["vertical"]])
        d = rng.normal(0.0, 1.0, (m, 3)) * sig * scale
        rows = pick_rows(rng, m, n_wild)
        d[rows, rng.integers(0, 3, rows.size)] += signed_uniform(rng, 50.0, 200.0, rows.size)
        lat, lon, h = pm.enu2geodetic(d[:, 0], d[:, 1], d[:, 2], lat, lon, h)
        vel = vel + rng.normal(0.0, sigma["velocity"], (m, 3)) * scale
    return {"time": t_file, "lat": np.asarray(lat), "lon": np.asarray(lon),
            "height": np.asarray(h), "ve": vel[:, 0], "vn": vel[:, 1], "vu": vel[:, 2]}


def mistram_range_rate(p: np.ndarray, v: np.ndarray, stations: np.ndarray) -> np.ndarray:
    """(M, S) range rate (m/s) of targets p, v (M, 3) from fixed stations (S, 3), range ENU."""
    d = p[:, None, :] - stations[None, :, :]
    return np.einsum("msk,mk->ms", d, v) / np.linalg.norm(d, axis=2)


def mistram_columns(rng: np.random.Generator, t_file: np.ndarray, traj: Trajectory,
                    t_meas: np.ndarray, stations: np.ndarray, station_ids: list[str],
                    sigma: float, *, noise: bool, n_wild: int) -> dict[str, np.ndarray]:
    """Columns time, station, range_rate: one row per station per epoch (epoch-major)."""
    p, v, _ = traj.state(t_meas)
    rr = mistram_range_rate(p, v, stations).ravel()
    if noise:
        rr = rr + rng.normal(0.0, sigma, rr.size)
        rows = pick_rows(rng, rr.size, n_wild)
        rr[rows] += signed_uniform(rng, 2.0, 10.0, rows.size)
    s = len(station_ids)
    return {"time": np.repeat(t_file, s), "station": np.tile(np.array(station_ids), t_file.size),
            "range_rate": rr}


def shuffle_chunk(rng: np.random.Generator, n: int) -> np.ndarray:
    """Row order (n,) that permutes one contiguous chunk of ~2-5 % of the rows."""
    order = np.arange(n)
    size = min(n, max(20, int(n * rng.uniform(0.02, 0.05))))
    start = int(rng.integers(0, n - size + 1)) if n else 0
    order[start:start + size] = start + rng.permutation(size)
    return order
