"""Sensors of the harbour kind: the ferry's INS, a scanning radar and a lidar whose returns
come from the hull sides facing them, and cameras whose bearing errors are AR(1).

Every sensor is on the ferry (:class:`Ferry`); its rows are computed with the data contract's
platform geometry (``sensors.platform_geometry``: deck angles in the body frame from the INS
reference point + lever arm), so a reader inverts them exactly. The world is the sea surface
(up = 0 in the range frame); radar and lidar write range and azimuth with the elevation cell
empty, cameras azimuth only, none a ``track_id`` (plots, as the Autoferry recordings).

Timing: a scanning sensor's scan k starts at t0 + phase + k * period; its beam passes deck
azimuth az at start + period * az / 2 pi, when the object is measured, but every row of the
scan is stamped with the scan's mid time (the recordings stamp all plots of a scan alike), so
a moving object's plot is up to period / 2 off in time. Camera frames are stamped exactly.

Each builder returns a :class:`HarbourTable`: the file's columns, and per row the object index
(-1 none), its source (``object``, a quay id, ``sea`` clutter, ``false`` camera detection)
and the true measurement time (s).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pymap3d as pm
from scipy.signal import lfilter

from rangeproc.simulate import sensors as sn
from rangeproc.simulate.harbour_motion import (Hull, Quay, SurfacePath, body_to_enu, outside,
                                               silhouette_bearing, visible_points)

DEG = math.pi / 180.0


@dataclass(frozen=True, slots=True)
class Ferry:
    """The own ship: its track ``path`` (INS reference point, range ENU, up 0) and attitude.

    ``north_up``: the recordings' form: yaw written 0 and every deck angle north-referenced
    (lever arms 0); otherwise yaw = heading + a small oscillation and deck angles relative to
    the bow. Roll, pitch and the yaw oscillation are sinusoids (amplitude rad, period s,
    phase rad)."""

    path: SurfacePath
    north_up: bool
    roll: tuple[float, float, float]
    pitch: tuple[float, float, float]
    yaw_osc: tuple[float, float, float]

    def attitude(self, t: np.ndarray) -> np.ndarray:
        """(M, 3) roll, pitch, yaw (rad) at times t (M,) s; yaw in [0, 2 pi)."""
        def osc(p: tuple[float, float, float]) -> np.ndarray:
            return p[0] * np.sin(2 * math.pi * t / p[1] + p[2])
        psi = self.path.state(t)[2]
        yaw = np.zeros(t.size) if self.north_up else np.mod(psi + osc(self.yaw_osc),
                                                            2 * math.pi)
        return np.column_stack((osc(self.roll), osc(self.pitch), yaw))

    def geodetic(self, t: np.ndarray, origin: sn.Geo) -> tuple[np.ndarray, ...]:
        """lat, lon (deg), height (m) of the INS reference point, each (M,)."""
        p = self.path.state(t)[0]
        lat, lon, h = pm.enu2geodetic(p[:, 0], p[:, 1], np.zeros(t.size), origin.lat,
                                      origin.lon, origin.height)
        return np.asarray(lat), np.asarray(lon), np.asarray(h)

    def sensor_xy(self, t: np.ndarray, lever: tuple[float, float, float]) -> np.ndarray:
        """(M, 2) east/north (m) of a sensor at ``lever`` (body FRD m) at times t (M,) s."""
        p = self.path.state(t)[0]
        if self.north_up:
            return p
        return p + body_to_enu(self.attitude(t)[:, 2], np.array(lever[:2]))


def deck_rae(ferry: Ferry, origin: sn.Geo, t: np.ndarray, pts: np.ndarray,
             lever: tuple[float, float, float]) -> tuple[np.ndarray, ...]:
    """Range (m), deck azimuth [0, 2 pi), deck elevation (rad) of sea-surface points pts
    (M, 2) m from the sensor at ``lever`` at times t (M,) s (contract platform geometry)."""
    lat, lon, h = ferry.geodetic(t, origin)
    p = np.column_stack((pts, np.zeros(len(pts))))
    lev = np.zeros(3) if ferry.north_up else np.array(lever, dtype=float)
    return sn.platform_geometry(p, origin, lat, lon, h, ferry.attitude(t), lev)


@dataclass(frozen=True, slots=True)
class ScanSensor:
    """A scanning radar or lidar on the ferry at ``lever`` (body FRD m): a scan every
    ``period`` s from ``phase`` s; ``sigma`` (SI) range m and azimuth rad of the generator's
    white noise; an object whose centre lies r_min..r_max m away is detected with ``pd`` per
    scan, giving 1 return (``per_return`` = 0) or 1 + Poisson(projected width / per_return)
    returns (at most ``max_returns``); ``sea`` sea-clutter plots per scan (Poisson, uniform
    over the coverage annulus); quay scatterers are seen with their own probability
    (``lidar``: Quay.p_lidar, else p_radar)."""

    sid: str
    file: str
    lever: tuple[float, float, float]
    period: float
    phase: float
    sigma: dict[str, float]
    pd: float
    r_min: float
    r_max: float
    sea: float
    per_return: float = 0.0
    max_returns: int = 1
    lidar: bool = False


@dataclass(frozen=True, slots=True)
class Camera:
    """An EO or IR camera on the ferry at ``lever``: frames at ``rate`` Hz from ``phase`` s;
    each object within ``r_max`` m is detected with ``pd`` per frame at the centre of its
    angular extent plus an AR(1) error per object (stationary sigma ``sigma`` rad, lag-1
    correlation ``rho`` frame to frame, advanced every frame seen or not); ``false`` false
    bearings per frame (Poisson, uniform in azimuth)."""

    sid: str
    file: str
    lever: tuple[float, float, float]
    rate: float
    phase: float
    sigma: float
    rho: float
    pd: float
    r_max: float
    false: float


@dataclass(frozen=True, slots=True)
class Ins:
    """The ferry's INS at ``rate`` Hz; white noise sigma ``attitude`` (rad), ``position``
    (m per ENU axis); angles written in ``unit``."""

    sid: str
    file: str
    rate: float
    attitude: float
    position: float
    unit: str


@dataclass(frozen=True, slots=True)
class HarbourTable:
    """A sensor file's columns (file units), and per row (M,): ``obj`` object index (-1
    none), ``source`` (object, quay id, sea, false) and ``t_true`` measurement time (s)."""

    cols: dict[str, np.ndarray]
    obj: np.ndarray | None = None
    source: np.ndarray | None = None
    t_true: np.ndarray | None = None

    @property
    def n_rows(self) -> int:
        """Rows of the file."""
        return int(self.cols["time"].size)


@dataclass(frozen=True, slots=True)
class World:
    """What the sensors see: origin, trajectory start t0 and duration (s), the ferry, the
    hulls (index = object) and the quays."""

    origin: sn.Geo
    t0: float
    duration: float
    ferry: Ferry
    hulls: tuple[Hull, ...]
    quays: tuple[Quay, ...]


def projected_width(psi: np.ndarray, los: np.ndarray, length: float, beam: float
                    ) -> np.ndarray:
    """(M,) width (m) across the line of sight ``los`` (M, 2) of a hull at heading psi."""
    u = los / np.linalg.norm(los, axis=1, keepdims=True)
    fwd = np.column_stack((np.sin(psi), np.cos(psi)))
    c = np.abs(np.einsum("ij,ij->i", u, fwd))
    return length * np.sqrt(np.clip(1 - c * c, 0, 1)) + beam * c


def _beam_times(spec: ScanSensor, w: World, start: np.ndarray, point_at) -> np.ndarray:
    """(K,) times the beam of scans starting at ``start`` (K,) s passes a point whose
    position at time t is ``point_at(t)`` (K, 2): fixed-point iteration from the mid time."""
    tb = start + 0.5 * spec.period
    for _ in range(3):
        az = deck_rae(w.ferry, w.origin, tb, point_at(tb), spec.lever)[1]
        tb = start + spec.period * az / (2 * math.pi)
    return tb


def scan_table(spec: ScanSensor, w: World, timing: np.random.Generator,
               nz: np.random.Generator, noise: bool) -> HarbourTable:
    """Rows of a scanning sensor: object returns, quay returns and sea clutter (above)."""
    k = np.arange(int(math.ceil(w.duration / spec.period)) + 1)
    start = w.t0 + spec.phase + k * spec.period
    mid = start + 0.5 * spec.period
    ok = (mid >= w.t0 + 0.1) & (mid <= w.t0 + w.duration - 0.1)
    start, mid = start[ok], mid[ok]
    pts, t_true, stamp, obj, src = [], [], [], [], []
    for j, hull in enumerate(w.hulls):
        tb = _beam_times(spec, w, start, lambda t, h=hull: h.path.state(t)[0])
        c, _, psi, _ = hull.path.state(tb)
        s_xy = w.ferry.sensor_xy(tb, spec.lever)
        dist = np.linalg.norm(c - s_xy, axis=1)
        det = (dist >= spec.r_min) & (dist <= spec.r_max) & (timing.random(tb.size) < spec.pd)
        n = np.ones(int(det.sum()), dtype=np.int64)
        if spec.per_return > 0:
            width = projected_width(psi[det], s_xy[det] - c[det], hull.length, hull.beam)
            n = np.minimum(1 + timing.poisson(width / spec.per_return), spec.max_returns)
        p, idx = visible_points(timing, hull.corners(tb[det]), s_xy[det], n)
        pts.append(p)
        t_true.append(tb[det][idx])
        stamp.append(mid[det][idx])
        obj.append(np.full(idx.size, j))
        src.append(np.full(idx.size, "object", dtype=object))
    for q in w.quays:
        prob = q.p_lidar if spec.lidar else q.p_radar
        for x, pq in zip(q.scatter, prob):
            tb = _beam_times(spec, w, start, lambda t, x=x: np.tile(x, (t.size, 1)))
            dist = np.linalg.norm(w.ferry.sensor_xy(tb, spec.lever) - x, axis=1)
            det = (dist >= spec.r_min) & (dist <= spec.r_max) & (timing.random(tb.size) < pq)
            pts.append(np.tile(x, (int(det.sum()), 1)))
            t_true.append(tb[det])
            stamp.append(mid[det])
            obj.append(np.full(int(det.sum()), -1))
            src.append(np.full(int(det.sum()), q.qid, dtype=object))
    t_true_a = np.concatenate(t_true)
    r, az, _ = deck_rae(w.ferry, w.origin, t_true_a, np.concatenate(pts), spec.lever)
    if noise:
        r = r + nz.normal(0.0, spec.sigma["range"], r.size)
        az = np.mod(az + nz.normal(0.0, spec.sigma["azimuth"], az.size), 2 * math.pi)
    n_sea = timing.poisson(spec.sea, start.size)
    az_sea = timing.uniform(0.0, 2 * math.pi, int(n_sea.sum()))
    r_sea = np.sqrt(timing.uniform(spec.r_min ** 2, spec.r_max ** 2, az_sea.size))
    t_sea = np.repeat(start, n_sea) + spec.period * az_sea / (2 * math.pi)
    stamp_all = np.concatenate(stamp + [np.repeat(mid, n_sea)])
    t_all = np.concatenate((t_true_a, t_sea))
    order = np.lexsort((t_all, stamp_all))
    cols = {"time": np.round(stamp_all, 6)[order],
            "range": np.concatenate((r, r_sea))[order],
            "azimuth": np.degrees(np.concatenate((az, az_sea)))[order],
            "elevation": np.full(order.size, np.nan)}
    return HarbourTable(cols, np.concatenate(obj + [np.full(az_sea.size, -1)])[order],
                        np.concatenate(src + [np.full(az_sea.size, "sea", dtype=object)])[order],
                        t_all[order])


def ar1(rng: np.random.Generator, n: int, sigma: float, rho: float) -> np.ndarray:
    """(n,) stationary AR(1): e_i = rho e_{i-1} + sqrt(1 - rho^2) sigma w_i, e_0 ~ N(0,
    sigma^2), w_i ~ N(0, 1)."""
    w = rng.normal(0.0, 1.0, n)
    if n == 0:
        return w
    e0 = sigma * w[0]
    rest = lfilter([math.sqrt(1 - rho * rho) * sigma], [1.0, -rho], w[1:], zi=[rho * e0])[0]
    return np.concatenate(([e0], rest))


def camera_table(spec: Camera, w: World, timing: np.random.Generator,
                 nz: np.random.Generator, noise: bool) -> HarbourTable:
    """Bearings of every object in view (centre of its angular extent + AR(1) error) and
    false bearings, frame by frame."""
    i = np.arange(int(math.floor((w.duration - 0.2 - spec.phase) * spec.rate)) + 1)
    f = w.t0 + 0.1 + spec.phase + i / spec.rate
    s_xy = w.ferry.sensor_xy(f, spec.lever)
    times, az, obj = [], [], []
    for j, hull in enumerate(w.hulls):
        corners = hull.corners(f)
        bear = deck_rae(w.ferry, w.origin, np.repeat(f, 4), corners.reshape(-1, 2),
                        spec.lever)[1].reshape(-1, 4)
        centre = silhouette_bearing(bear)
        err = ar1(nz, f.size, spec.sigma, spec.rho) if noise else np.zeros(f.size)
        dist = np.linalg.norm(corners.mean(axis=1) - s_xy, axis=1)
        det = ((dist <= spec.r_max) & (timing.random(f.size) < spec.pd)
               & outside(corners, s_xy))
        times.append(f[det])
        az.append(np.mod(centre + err, 2 * math.pi)[det])
        obj.append(np.full(int(det.sum()), j))
    n_false = timing.poisson(spec.false, f.size)
    times.append(np.repeat(f, n_false))
    az.append(timing.uniform(0.0, 2 * math.pi, int(n_false.sum())))
    obj.append(np.full(int(n_false.sum()), -1))
    t = np.concatenate(times)
    order = np.argsort(t, kind="stable")
    o = np.concatenate(obj)[order]
    cols = {"time": np.round(t[order], 6), "azimuth": np.degrees(np.concatenate(az))[order],
            "elevation": np.full(order.size, np.nan)}
    return HarbourTable(cols, o, np.where(o >= 0, "object", "false").astype(object), t[order])


def ins_table(spec: Ins, w: World, nz: np.random.Generator, noise: bool) -> HarbourTable:
    """INS rows time, roll, pitch, yaw (``spec.unit``), lat, lon (deg), height (m) at
    ``spec.rate`` Hz over the whole span; a north-up ferry's yaw is written 0 exactly."""
    t = w.t0 + np.arange(int(math.floor(w.duration * spec.rate)) + 1) / spec.rate
    p = w.ferry.path.state(t)[0]
    enu = np.column_stack((p, np.zeros(t.size)))
    att = w.ferry.attitude(t)
    if noise:
        enu = enu + nz.normal(0.0, spec.position, enu.shape)
        att = att + nz.normal(0.0, spec.attitude, att.shape)
        if w.ferry.north_up:
            att[:, 2] = 0.0
    lat, lon, h = pm.enu2geodetic(enu[:, 0], enu[:, 1], enu[:, 2], w.origin.lat, w.origin.lon,
                                  w.origin.height)
    scale = sn.ANGLE_SCALE[spec.unit]
    att[:, 2] = np.mod(att[:, 2], 2 * math.pi)
    return HarbourTable({"time": np.round(t, 6), "roll": att[:, 0] * scale,
                         "pitch": att[:, 1] * scale, "yaw": att[:, 2] * scale,
                         "lat": np.asarray(lat), "lon": np.asarray(lon),
                         "height": np.asarray(h)})


Spec = ScanSensor | Camera | Ins


def build(spec: Spec, w: World, rng: np.random.Generator, noise: bool) -> HarbourTable:
    """The file of sensor ``spec`` drawn from ``rng`` (split into timing and noise)."""
    timing, nz = rng.spawn(2)
    if isinstance(spec, ScanSensor):
        return scan_table(spec, w, timing, nz, noise)
    if isinstance(spec, Camera):
        return camera_table(spec, w, timing, nz, noise)
    return ins_table(spec, w, nz, noise)
