"""Sensors of a multi-object scenario: tracks that follow (and jump between) objects,
surveillance plots with clutter, and the per-target GPS, MISTRAM and ship files.

A tracking sensor (fixed-site radar or theodolite, ship radar) reports :class:`TrackPlan` s:
each a sequence of :class:`Piece` s, spans of range time in which its rows measure one object
under one ``track_id``. A lock jump is two pieces without a gap; an operator moving to another
object leaves a gap (the slew). A surveillance radar rotates and reports plots (no track_id)
of every object in its coverage, with detection probability ``pd``, plus Poisson clutter
uniform over the coverage volume. Two plot sensors report out of azimuth order: a phased-array
radar (:class:`PhasedArray`) looks at each object on the object's own schedule, and a merged
plot feed (:class:`MergedFeed`) interleaves the plots of two rotating radars at different
sites, converted to one reference site.

Every builder returns a :class:`SensorTable`: the file's columns in file units, rows sorted by
time (see :mod:`rangeproc.simulate.sensors`), and for radars/theodolites the true object of
each row (index into ``World.flights``, -1 = clutter) and whether a wild error was injected.
Times are range times (s); geometry is computed at the measurement time a reader reconstructs
(file stamp + ``time_offset``), as in the single-object scenario.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pyarrow as pa
import pymap3d as pm

from rangeproc.simulate import sensors as sn
from rangeproc.simulate.files import int_column
from rangeproc.simulate.scenario import (LASER_MAX_RANGE, TH_MAX_RANGE, TH_MIN_EL,
                                         iso_file_times)
from rangeproc.simulate.trajectory import Trajectory

RADAR_MIN_EL, RADAR_MAX_RANGE = math.radians(0.5), 150e3  #: tracking radar coverage (rad, m)
SHIP_MAX_RANGE = 100e3  #: ship radar coverage (m)
MISSED = (0.01, 0.03)  #: fraction of a track's rows missed at random (lo, hi)


@dataclass(frozen=True, slots=True)
class World:
    """What every sensor sees: range origin, the objects' trajectories (index = object),
    trajectory start t0 (s) and flight duration (s); ``iso_gps``: GPS stamps as ISO strings."""

    origin: sn.Geo
    flights: tuple[Trajectory, ...]
    t0: float
    duration: float
    iso_gps: bool


@dataclass(frozen=True, slots=True)
class Piece:
    """Range times [start, end) (s) in which a track measures object ``obj`` as ``track_id``."""

    start: float
    end: float
    obj: int
    track_id: int


@dataclass(frozen=True, slots=True)
class TrackPlan:
    """One tracking channel of a sensor: pieces in time order (rows at one rate and phase)."""

    pieces: tuple[Piece, ...]


@dataclass(frozen=True, slots=True)
class SiteSensor:
    """Fixed-site tracking radar or theodolite (``kind``) at ``site``; sigma SI (keys =
    components measured: a theodolite with ``range`` has a laser, a radar with
    ``range_rate`` measures it); angles written in ``unit``; ``rate`` Hz per track."""

    sid: str
    kind: str
    file: str
    site: sn.Geo
    sigma: dict[str, float]
    unit: str
    rate: float
    tracks: tuple[TrackPlan, ...]
    offset: float = 0.0
    wild_fraction: float = 0.0075
    n_missing: int = 0


@dataclass(frozen=True, slots=True)
class ShipRadar:
    """Radar on the ship ``ship`` (INS reference point + ``lever`` body FRD, m); deck angles."""

    sid: str
    file: str
    ship: sn.ShipMotion
    lever: tuple[float, float, float]
    sigma: dict[str, float]
    rate: float
    tracks: tuple[TrackPlan, ...]
    offset: float = 0.0
    wild_fraction: float = 0.0075
    n_missing: int = 0


@dataclass(frozen=True, slots=True)
class Surveillance:
    """Rotating surveillance radar: one revolution per ``period`` s, clockwise from north at
    range time t0 + ``phase``; plots of objects inside the coverage (range r_min..r_max m,
    elevation el_min..el_max rad, at most ``ceiling`` m above the site) with probability
    ``pd``, and Poisson clutter of mean ``clutter`` plots per scan uniform over that volume."""

    sid: str
    file: str
    site: sn.Geo
    sigma: dict[str, float]
    phase: float
    period: float = 4.0
    pd: float = 0.9
    clutter: float = 20.0
    r_min: float = 1e3
    r_max: float = 80e3
    el_min: float = math.radians(0.5)
    el_max: float = math.radians(60.0)
    ceiling: float = 15e3
    offset: float = 0.0
    wild_fraction: float = 0.005


@dataclass(frozen=True, slots=True)
class PhasedArray:
    """Phased-array surveillance radar (faces all round: every azimuth). Each object inside
    the coverage (range r_min..r_max m, elevation el_min..el_max rad, at most ``ceiling`` m
    above the site) is looked at every ``revisit`` s on its own schedule: a random phase per
    object and a random jitter of up to +-``jitter`` revisits per look; a look detects it with
    probability ``pd``. Poisson clutter of mean ``clutter`` plots per revisit period, uniform
    over the coverage volume, each at a uniformly random time. Every plot carries its own time
    stamp, so consecutive rows jump between objects in no azimuth order."""

    sid: str
    file: str
    site: sn.Geo
    sigma: dict[str, float]
    revisit: float = 2.0
    jitter: float = 0.1
    pd: float = 0.9
    clutter: float = 10.0
    r_min: float = 1e3
    r_max: float = 80e3
    el_min: float = math.radians(0.5)
    el_max: float = math.radians(60.0)
    ceiling: float = 15e3
    offset: float = 0.0
    wild_fraction: float = 0.005


@dataclass(frozen=True, slots=True)
class MergedFeed:
    """One plot feed of several rotating radars (``radars``: each a :class:`Surveillance` with
    its own site, period, phase, coverage, pd, clutter and sigmas; their ``sid``, ``file`` and
    ``offset`` are not used), merged in time order. Every plot, clutter included, is converted
    to range, azimuth and elevation at the feed's reference ``site`` (the declared site; the
    first radar's). Noise: each radar's own sigmas, drawn in the reference site's polar frame
    (as if the feed's converter kept each radar's stated accuracy); ``sigma`` (declared) is
    the larger of the radars' sigmas per component, so it covers every plot. Within a scan the
    file's azimuths are not monotonic: the radars' sweeps interleave."""

    sid: str
    file: str
    site: sn.Geo
    sigma: dict[str, float]
    radars: tuple[Surveillance, ...]
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class GpsReceiver:
    """GPS on object ``obj``; dropouts and a x10 noise burst in range times (s)."""

    sid: str
    file: str
    obj: int
    sigma: dict[str, float]
    dropouts: tuple[tuple[float, float], ...]
    burst: tuple[float, float]
    rate: float = 10.0
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class ShipIns:
    """The ship's INS; sigma keys attitude (rad), position (m), velocity (m/s)."""

    sid: str
    file: str
    ship: sn.ShipMotion
    sigma: dict[str, float]
    rate: float = 50.0


@dataclass(frozen=True, slots=True)
class Mistram:
    """MISTRAM range rates of object ``obj`` at ground stations (id, site)."""

    sid: str
    file: str
    obj: int
    stations: tuple[tuple[str, sn.Geo], ...]
    sigma: float
    rate: float = 20.0
    offset: float = 0.0


Sensor = (SiteSensor | ShipRadar | Surveillance | PhasedArray | MergedFeed | GpsReceiver
          | ShipIns | Mistram)
#: sensors that report plots (rows without track_id) of every object in coverage
PLOT_SENSORS = (Surveillance, PhasedArray, MergedFeed)
Coverage = Surveillance | PhasedArray  #: a plot radar's coverage volume


@dataclass(frozen=True, slots=True)
class SensorTable:
    """A sensor file's columns (file units; pa.Array for columns with empty cells), and for
    radars/theodolites per row: ``obj`` (M,) true object index (-1 clutter), ``wild`` (M,)."""

    cols: dict[str, np.ndarray | pa.Array]
    obj: np.ndarray | None = None
    wild: np.ndarray | None = None
    n_rows: int = field(default=0)


def build(spec: Sensor, world: World, rng: np.random.Generator, noise: bool) -> SensorTable:
    """The file of sensor ``spec`` drawn from ``rng`` (timing and noise split from it)."""
    timing, nz = rng.spawn(2)
    if isinstance(spec, SiteSensor):
        return _site_table(spec, world, timing, nz, noise)
    if isinstance(spec, ShipRadar):
        return _ship_table(spec, world, timing, nz, noise)
    if isinstance(spec, Surveillance):
        return _surveillance_table(spec, world, timing, nz, noise)
    if isinstance(spec, PhasedArray):
        return _phased_array_table(spec, world, timing, nz, noise)
    if isinstance(spec, MergedFeed):
        return _merged_feed_table(spec, world, timing, nz, noise)
    if isinstance(spec, GpsReceiver):
        return _gps_table(spec, world, timing, nz, noise)
    if isinstance(spec, ShipIns):
        t_file, t_meas = sn.file_times(
            sn.sample_times(timing, world.t0, world.duration, spec.rate), 0.0)
        cols = sn.ins_columns(nz, t_file, t_meas - world.t0, spec.ship, spec.sigma, noise=noise)
        return SensorTable(dict(cols), n_rows=t_file.size)
    t_file, t_meas = sn.file_times(
        sn.sample_times(timing, world.t0, world.duration, spec.rate), spec.offset)
    st = np.array([sn.site_enu(geo, world.origin) for _, geo in spec.stations])
    cols = sn.mistram_columns(nz, t_file, world.flights[spec.obj], t_meas, st,
                              [s for s, _ in spec.stations], spec.sigma, noise=noise,
                              n_wild=int(nz.integers(5, 21)))
    return SensorTable(dict(cols), n_rows=cols["time"].size)


def track_samples(rng: np.random.Generator, plan: TrackPlan, rate: float, world: World
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True times (M,) s, object index (M,) and track_id (M,) of one track's rows: ``rate`` Hz
    with a random phase inside its pieces, less missed detections (``MISSED`` of the rows at
    random and 0-2 fades of 0.5-3 s)."""
    t = sn.sample_times(rng, world.t0, world.duration, rate)
    obj = np.full(t.size, -1, dtype=np.int64)
    tid = np.full(t.size, -1, dtype=np.int64)
    for pc in plan.pieces:
        m = (t >= pc.start) & (t < pc.end)
        obj[m], tid[m] = pc.obj, pc.track_id
    start, end = plan.pieces[0].start, plan.pieces[-1].end
    fades = [(s, s + rng.uniform(0.5, 3.0))
             for s in rng.uniform(start, end, int(rng.integers(0, 3)))]
    missed = rng.random(t.size) < rng.uniform(*MISSED)
    keep = (obj >= 0) & ~sn.in_intervals(t, fades) & ~missed
    return t[keep], obj[keep], tid[keep]


def _tracks(rng: np.random.Generator, tracks: tuple[TrackPlan, ...], rate: float, world: World
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows of all tracks interleaved in time (stable): times (M,) s, objects, track_ids."""
    parts = [track_samples(rng, plan, rate, world) for plan in tracks]
    t, obj, tid = (np.concatenate([p[i] for p in parts]) for i in range(3))
    order = np.argsort(t, kind="stable")
    return t[order], obj[order], tid[order]


def object_states(world: World, t: np.ndarray, obj: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity (M, 3), range ENU, of object obj[i] at range time t[i] (s)."""
    p, v = np.zeros((t.size, 3)), np.zeros((t.size, 3))
    for k in np.unique(obj):
        m = obj == k
        p[m], v[m], _ = world.flights[int(k)].state(t[m])
    return p, v


def _site_table(spec: SiteSensor, world: World, timing: np.random.Generator,
                nz: np.random.Generator, noise: bool) -> SensorTable:
    t_true, obj, tid = _tracks(timing, spec.tracks, spec.rate, world)
    t_file, t_meas = sn.file_times(t_true, spec.offset)
    p, v = object_states(world, t_meas, obj)
    r, az, el, rr = sn.fixed_site_geometry(p, v, world.origin, spec.site)
    theo = spec.kind == "theodolite"
    vis = (el > TH_MIN_EL) & (r < TH_MAX_RANGE) if theo else \
        (el > RADAR_MIN_EL) & (r < RADAR_MAX_RANGE)
    t_file, obj, tid, r, az, el, rr = (a[vis] for a in (t_file, obj, tid, r, az, el, rr))
    rae: tuple[np.ndarray, ...]
    if theo:
        laser = "range" in spec.sigma
        rae = (np.where(r < LASER_MAX_RANGE, r, np.nan) if laser else np.full(r.size, np.nan),
               az, el)
    else:
        rae = (r, az, el, rr) if "range_rate" in spec.sigma else (r, az, el)
    cols, wild = sn.rae_columns_wild(nz, t_file, rae, spec.sigma, spec.unit, noise=noise,
                                     wild_fraction=spec.wild_fraction, n_missing=spec.n_missing,
                                     missing="azimuth" if theo else "elevation")
    if theo and "range" not in spec.sigma:
        del cols["range"]
    out: dict[str, np.ndarray | pa.Array] = dict(cols)
    out["track_id"] = int_column(tid, tid >= 0)
    return SensorTable(out, obj, wild, t_file.size)


def _ship_table(spec: ShipRadar, world: World, timing: np.random.Generator,
                nz: np.random.Generator, noise: bool) -> SensorTable:
    t_true, obj, tid = _tracks(timing, spec.tracks, spec.rate, world)
    t_file, t_meas = sn.file_times(t_true, spec.offset)
    p, _ = object_states(world, t_meas, obj)
    tau = t_meas - world.t0
    lat, lon, h = spec.ship.geodetic(tau)
    r, az, el = sn.platform_geometry(p, world.origin, lat, lon, h, spec.ship.attitude(tau),
                                     np.array(spec.lever))
    vis = r < SHIP_MAX_RANGE
    cols, wild = sn.rae_columns_wild(nz, t_file[vis], (r[vis], az[vis], el[vis]), spec.sigma,
                                     "deg", noise=noise, wild_fraction=spec.wild_fraction,
                                     n_missing=spec.n_missing, missing="range")
    out: dict[str, np.ndarray | pa.Array] = dict(cols)
    out["track_id"] = int_column(tid[vis], tid[vis] >= 0)
    return SensorTable(out, obj[vis], wild, int(vis.sum()))


def sweep_times(flight: Trajectory, spec: Surveillance, world: World, scans: np.ndarray
                ) -> np.ndarray:
    """(K,) range times (s) at which the beam of scan k (``scans`` (K,) int) points at the
    object: t = t0 + phase + period (k + azimuth(t) / 2 pi), by fixed-point iteration (the
    object's azimuth moves little in one revolution). Clipped to the trajectory's span."""
    t_ref = world.t0 + spec.phase
    hi = world.t0 + flight.duration - 0.05
    t = np.clip(t_ref + spec.period * (scans + 0.5), world.t0, hi)
    for _ in range(4):
        p, v, _ = flight.state(t)
        az = sn.fixed_site_geometry(p, v, world.origin, spec.site)[1]
        t = np.clip(t_ref + spec.period * (scans + az / (2 * math.pi)), world.t0, hi)
    return t


def in_coverage(spec: Coverage, r: np.ndarray, el: np.ndarray) -> np.ndarray:
    """(M,) bool: slant range r (m), elevation el (rad) inside the radar's coverage volume."""
    return ((r >= spec.r_min) & (r <= spec.r_max) & (el >= spec.el_min) & (el <= spec.el_max)
            & (r * np.sin(el) <= spec.ceiling))


def clutter_range_elevation(rng: np.random.Generator, spec: Coverage, n: int
                            ) -> tuple[np.ndarray, np.ndarray]:
    """(n,) slant ranges (m) and elevations (rad) uniform over the coverage volume
    (volume element r^2 cos(el) dr d(el) d(az): r^3 and sin(el) uniform, then the ceiling)."""
    r_out, el_out = np.zeros(0), np.zeros(0)
    while r_out.size < n:
        m = 4 * (n - r_out.size) + 16
        r = np.cbrt(rng.uniform(spec.r_min**3, spec.r_max**3, m))
        el = np.arcsin(rng.uniform(math.sin(spec.el_min), math.sin(spec.el_max), m))
        ok = in_coverage(spec, r, el)
        r_out, el_out = np.concatenate((r_out, r[ok])), np.concatenate((el_out, el[ok]))
    return r_out[:n], el_out[:n]


def scan_detections(spec: Surveillance, world: World, timing: np.random.Generator
                    ) -> tuple[np.ndarray, ...]:
    """A rotating radar's detections of the objects: true times (M,) s (the beam on the
    object), object indices (M,) and range (m), azimuth, elevation (rad) at its site, object
    by object; each scan's look detects an object inside the coverage with probability pd."""
    t_lo, t_hi = world.t0 + 0.1, world.t0 + world.duration - 0.1
    scans = np.arange(-1, int(math.ceil(world.duration / spec.period)) + 1)
    parts = []
    for k, flight in enumerate(world.flights):
        t = sweep_times(flight, spec, world, scans)
        p, v, _ = flight.state(t)
        r, az, el, _ = sn.fixed_site_geometry(p, v, world.origin, spec.site)
        seen = (in_coverage(spec, r, el) & (t >= t_lo) & (t <= t_hi)
                & (timing.random(t.size) < spec.pd))
        parts.append((t[seen], np.full(int(seen.sum()), k), r[seen], az[seen], el[seen]))
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(5))


def scan_clutter(spec: Surveillance, world: World, timing: np.random.Generator
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A rotating radar's clutter: Poisson, mean ``clutter`` per scan, uniform over the
    coverage volume, each plot at the time the beam passes its azimuth. True times (M,) s,
    range (m), azimuth, elevation (rad) at its site."""
    t_lo, t_hi = world.t0 + 0.1, world.t0 + world.duration - 0.1
    scans = np.arange(-1, int(math.ceil(world.duration / spec.period)) + 1)
    n_c = timing.poisson(spec.clutter, scans.size)
    az_c = timing.uniform(0.0, 2 * math.pi, int(n_c.sum()))
    t_c = world.t0 + spec.phase + spec.period * (np.repeat(scans, n_c) + az_c / (2 * math.pi))
    r_c, el_c = clutter_range_elevation(timing, spec, az_c.size)
    keep = (t_c >= t_lo) & (t_c <= t_hi)
    return t_c[keep], r_c[keep], az_c[keep], el_c[keep]


def clutter_columns(t_file: np.ndarray, r: np.ndarray, az: np.ndarray, el: np.ndarray
                    ) -> dict[str, np.ndarray]:
    """Clutter rows' columns time, range, azimuth, elevation (deg), as written (no noise)."""
    deg = sn.ANGLE_SCALE["deg"]
    return {"time": t_file, "range": r, "azimuth": az * deg, "elevation": el * deg}


def plot_table(parts: list[tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]]
               ) -> SensorTable:
    """The table of a plot sensor: the parts' rows (columns, objects (-1 clutter), wild)
    concatenated in order, then sorted by time (stable); track_id cells all empty."""
    cols = {k: np.concatenate([c[k] for c, _, _ in parts]) for k in parts[0][0]}
    obj = np.concatenate([o for _, o, _ in parts]).astype(np.int64)
    wild = np.concatenate([w for _, _, w in parts]).astype(bool)
    order = np.argsort(cols["time"], kind="stable")
    out: dict[str, np.ndarray | pa.Array] = {k: val[order] for k, val in cols.items()}
    out["track_id"] = int_column(np.zeros(order.size), np.zeros(order.size, dtype=bool))
    return SensorTable(out, obj[order], wild[order], order.size)


def _surveillance_table(spec: Surveillance, world: World, timing: np.random.Generator,
                        nz: np.random.Generator, noise: bool) -> SensorTable:
    t_obj, obj, r, az, el = scan_detections(spec, world, timing)
    f_obj = sn.file_times(t_obj, spec.offset)[0]
    cols, wild = sn.rae_columns_wild(nz, f_obj, (r, az, el), spec.sigma, "deg", noise=noise,
                                     wild_fraction=spec.wild_fraction,
                                     n_missing=int(nz.integers(0, 4)), missing="elevation")
    t_c, r_c, az_c, el_c = scan_clutter(spec, world, timing)
    clutter = clutter_columns(sn.file_times(t_c, spec.offset)[0], r_c, az_c, el_c)
    return plot_table([(cols, obj, wild),
                       (clutter, np.full(t_c.size, -1), np.zeros(t_c.size, dtype=bool))])


def _phased_array_table(spec: PhasedArray, world: World, timing: np.random.Generator,
                        nz: np.random.Generator, noise: bool) -> SensorTable:
    """Looks every ``revisit`` s per object (own phase, jitter), then clutter at random
    times; geometry at the measurement time a reader reconstructs."""
    t_lo, t_hi = world.t0 + 0.1, world.t0 + world.duration - 0.1
    looks = np.arange(int(math.ceil(world.duration / spec.revisit)) + 1)
    parts = []
    for k, flight in enumerate(world.flights):
        phase = timing.uniform(0.0, spec.revisit)
        jitter = timing.uniform(-spec.jitter, spec.jitter, looks.size)
        t = world.t0 + phase + spec.revisit * (looks + jitter)
        t_file, t_meas = sn.file_times(t, spec.offset)
        p, v, _ = flight.state(np.clip(t_meas, world.t0, world.t0 + flight.duration - 0.05))
        r, az, el, _ = sn.fixed_site_geometry(p, v, world.origin, spec.site)
        seen = (in_coverage(spec, r, el) & (t >= t_lo) & (t <= t_hi)
                & (timing.random(t.size) < spec.pd))
        parts.append((t_file[seen], np.full(int(seen.sum()), k), r[seen], az[seen], el[seen]))
    f_obj, obj, r, az, el = (np.concatenate([p[i] for p in parts]) for i in range(5))
    cols, wild = sn.rae_columns_wild(nz, f_obj, (r, az, el), spec.sigma, "deg", noise=noise,
                                     wild_fraction=spec.wild_fraction,
                                     n_missing=int(nz.integers(0, 4)), missing="elevation")
    n_c = int(timing.poisson(spec.clutter * (t_hi - t_lo) / spec.revisit))
    t_c = timing.uniform(t_lo, t_hi, n_c)
    az_c = timing.uniform(0.0, 2 * math.pi, n_c)
    r_c, el_c = clutter_range_elevation(timing, spec, n_c)
    clutter = clutter_columns(sn.file_times(t_c, spec.offset)[0], r_c, az_c, el_c)
    return plot_table([(cols, obj, wild),
                       (clutter, np.full(n_c, -1), np.zeros(n_c, dtype=bool))])


def to_reference(site: sn.Geo, ref: sn.Geo, r: np.ndarray, az: np.ndarray, el: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points at range r (m), azimuth, elevation (rad) from ``site`` as range (m), azimuth in
    [0, 2 pi), elevation (rad) from ``ref`` (geodetic, WGS-84)."""
    x, y, z = pm.aer2ecef(az, el, r, math.radians(site.lat), math.radians(site.lon),
                          site.height, deg=False)
    az2, el2, r2 = pm.ecef2aer(x, y, z, math.radians(ref.lat), math.radians(ref.lon),
                               ref.height, deg=False)
    return np.asarray(r2), np.mod(az2, 2 * math.pi), np.asarray(el2)


def _merged_feed_table(spec: MergedFeed, world: World, timing: np.random.Generator,
                       nz: np.random.Generator, noise: bool) -> SensorTable:
    """Each radar's detections and clutter (timing and coverage at its own site), converted
    to the reference site; noise with the radar's own sigmas; merged in time order."""
    parts = []
    for radar in spec.radars:
        t_obj, obj, _, _, _ = scan_detections(radar, world, timing)
        f_obj, t_meas = sn.file_times(t_obj, spec.offset)
        p, v = object_states(world, t_meas, obj)
        r, az, el, _ = sn.fixed_site_geometry(p, v, world.origin, spec.site)
        cols, wild = sn.rae_columns_wild(nz, f_obj, (r, az, el), radar.sigma, "deg",
                                         noise=noise, wild_fraction=radar.wild_fraction,
                                         n_missing=int(nz.integers(0, 3)), missing="elevation")
        parts.append((cols, obj, wild))
        t_c, r_c, az_c, el_c = scan_clutter(radar, world, timing)
        clutter = clutter_columns(sn.file_times(t_c, spec.offset)[0],
                                  *to_reference(radar.site, spec.site, r_c, az_c, el_c))
        parts.append((clutter, np.full(t_c.size, -1), np.zeros(t_c.size, dtype=bool)))
    return plot_table(parts)


def _gps_table(spec: GpsReceiver, world: World, timing: np.random.Generator,
               nz: np.random.Generator, noise: bool) -> SensorTable:
    t_true = sn.sample_times(timing, world.t0, world.duration, spec.rate)
    t_true = t_true[~sn.in_intervals(t_true, list(spec.dropouts))]
    if world.iso_gps:
        t_file, t_meas = iso_file_times(t_true, spec.offset)
    else:
        t_file, t_meas = sn.file_times(t_true, spec.offset)
    p, v, _ = world.flights[spec.obj].state(t_meas)
    cols = sn.gps_columns(nz, t_file, t_meas, p, v, world.origin, spec.sigma, noise=noise,
                          burst=spec.burst, n_wild=int(nz.integers(3, 9)))
    return SensorTable(dict(cols), n_rows=t_true.size)
