"""Scenario per seed: geometry, sensor files, ``scenario.toml`` and ``truth.csv``.

``simulate_scenario(out_dir, seed=..., duration=..., sensors=...)`` writes a complete run
directory written to the data contract. All randomness comes from
``numpy.random.default_rng(seed)``, split with ``spawn`` into independent streams (geometry,
trajectory, one per sensor) so that a reduced ``sensors`` subset gives the same scenario minus
the omitted files. ``rate_scale`` multiplies every sensor's sample rate (benchmarks: an hour
at scale 1 is ~0.64 M rows; rows grow linearly with it) without changing the geometry, error
parameters or random streams; scale 1 gives exactly the default files. Seed families: even
seeds write GPS times as ISO-8601 strings (then every file uses Unix seconds), odd seeds use
GPS seconds of week; the theodolite's angle unit cycles mil/deg/rad with ``seed % 3``;
``seed % 4 == 1`` puts the ship's heading near north (yaw wraps across 0/360); R1 measures
range rate on odd seeds; TH1 has a laser range on ``seed % 4 < 2``.

``faults`` injects systematic sensor errors with truth (names and signs of the data contract,
section 4; SI units): they change the noise-free measurements before noise is added, draw no
random numbers (the noise is the same as without faults) and are written as
``truth_calibration.json``. :data:`REGISTRATION_FAULTS` is the registration scenario's preset
(``rangeproc simulate --faults registration``).
"""
from __future__ import annotations

import dataclasses
import datetime as dt
import json
import logging
import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pymap3d as pm

from rangeproc.errors import ConfigError
from rangeproc.simulate import sensors as sn
from rangeproc.simulate.files import atomic_write_table, atomic_write_text
from rangeproc.simulate.recorded import read_recording, recorded_trajectory
from rangeproc.simulate.trajectory import Trajectory, plan_trajectory

log = logging.getLogger(__name__)

SENSOR_IDS = ("R1", "TH1", "S1", "SHIP_INS", "G1", "MISTRAM")
FILES = {"R1": "R1.csv", "TH1": "TH1.parquet", "S1": "S1.csv", "SHIP_INS": "SHIP_INS.csv",
         "G1": "G1.csv", "MISTRAM": "MISTRAM.csv"}
BASE_RATE = {"R1": 20.0, "S1": 10.0, "SHIP_INS": 50.0, "G1": 10.0,
             "MISTRAM": 20.0}  #: Hz at rate_scale 1 (TH1: 20 or 25 Hz, drawn per seed)
MAX_RATE_SCALE = 20.0  #: upper bound of ``rate_scale`` (INS at 1 kHz)
LATENCY = 0.05  #: s, the known latency of one sensor (config ``time_offset``)
TH_MIN_EL, TH_MAX_RANGE, LASER_MAX_RANGE = math.radians(3.0), 25e3, 15e3
_ISO_EPOCH = dt.datetime(2026, 5, 4, 10, 0, tzinfo=dt.timezone.utc).timestamp()
_MRAD, _ARCSEC = 1e-3, math.pi / (180.0 * 3600.0)

TRUTH_CALIBRATION = "truth_calibration.json"  #: faults written next to truth.csv
_MOUNT = ("mount_roll", "mount_pitch", "mount_yaw")
#: fault name -> (unit, sensors it applies to); names and signs of DATA_CONTRACT.md section 4:
#: range/azimuth/elevation = measured minus true; latency = time stamp minus true time of the
#: measurement; mount_* = sensor axes relative to the INS body axes, 3-2-1 (platform S1 only)
FAULTS: dict[str, tuple[str, tuple[str, ...]]] = {
    "range": ("m", ("R1", "TH1", "S1")),
    "azimuth": ("rad", ("R1", "TH1", "S1")),
    "elevation": ("rad", ("R1", "TH1", "S1")),
    "latency": ("s", ("R1", "TH1", "S1", "G1", "MISTRAM")),
    **{name: ("rad", ("S1",)) for name in _MOUNT},
}
#: largest |fault| per unit: catches degrees given for radians; the latency bound keeps
#: t - latency inside the trajectory (``sample_times`` leaves a 0.1 s margin)
FAULT_LIMIT = {"m": 1000.0, "rad": 0.1, "s": 0.1}
#: the sensor-registration scenario (preset ``registration``): R1 long and high, TH1
#: azimuth/elevation biases, S1 antenna yawed to starboard with its stamps 40 ms late
REGISTRATION_FAULTS: dict[str, dict[str, float]] = {
    "R1": {"range": 15.0, "azimuth": 0.5 * _MRAD, "elevation": 0.5 * _MRAD},
    "TH1": {"azimuth": 20.0 * _ARCSEC, "elevation": -20.0 * _ARCSEC},
    "S1": {"mount_yaw": math.radians(0.3), "latency": 0.040},
}
#: former name of :data:`REGISTRATION_FAULTS`, kept for existing scripts
ISSUE8_FAULTS = REGISTRATION_FAULTS
FAULT_PRESETS: dict[str, dict[str, dict[str, float]]] = {
    "none": {}, "registration": REGISTRATION_FAULTS}
#: preset names still accepted but not listed: former name -> preset
FAULT_PRESET_ALIASES = {"issue8": "registration"}


@dataclass(frozen=True, slots=True)
class Scenario:
    """Everything drawn for one seed. Sigmas are SI (m, rad, m/s); times are range times (s)."""

    seed: int
    duration: float
    origin: sn.Geo
    traj: Trajectory
    iso_gps: bool
    latency_sensor: str
    shuffled_sensor: str
    r1_site: sn.Geo
    r1_sigma: dict[str, float]
    th_site: sn.Geo
    th_sigma: dict[str, float]
    th_unit: str
    th_rate: float
    th_windows: list[tuple[float, float]]
    ship: sn.ShipMotion
    lever: tuple[float, float, float]
    s1_sigma: dict[str, float]
    ins_sigma: dict[str, float]
    g1_sigma: dict[str, float]
    g1_dropouts: list[tuple[float, float]]
    g1_burst: tuple[float, float]
    stations: list[tuple[str, sn.Geo]]
    mistram_sigma: float
    wild_fraction: float
    rate_scale: float = 1.0
    #: the sensors' streams (sampling, noise, wild points) from this seed instead of ``seed``
    noise_seed: int | None = None

    def rate(self, sid: str) -> float:
        """Sample rate of sensor ``sid`` (Hz): its base rate times ``rate_scale``."""
        base = self.th_rate if sid == "TH1" else BASE_RATE[sid]
        return base * self.rate_scale

    @property
    def t0(self) -> float:
        return self.traj.t0

    def offset(self, sid: str) -> float:
        """The ``time_offset`` of sensor ``sid`` (s)."""
        return LATENCY if sid == self.latency_sensor else 0.0


def _geo_at(origin: sn.Geo, e: float, n: float, height: float) -> sn.Geo:
    lat, lon, _ = pm.enu2geodetic(e, n, 0.0, origin.lat, origin.lon, origin.height)
    return sn.Geo(round(float(lat), 8), round(float(lon), 8), round(height, 2))


def _polar(rng: np.random.Generator, lo: float, hi: float) -> tuple[float, float]:
    r, a = rng.uniform(lo, hi), rng.uniform(0, 2 * math.pi)
    return r * math.sin(a), r * math.cos(a)


def draw_scenario(seed: int, duration: float, rate_scale: float = 1.0,
                  recording: tuple[np.ndarray, np.ndarray, np.ndarray | None] | None = None
                  ) -> Scenario:
    """Draw the geometry, trajectory and error parameters of scenario ``seed``.

    rate_scale multiplies every sensor's sample rate; it draws nothing (same scenario).
    recording: (times (M,) s, positions (M, 3) local ENU m, velocities (M, 3) m/s or None) of a
    recorded track to fly instead of a drawn trajectory (``simulate.recorded``); the flight
    then lasts at most its span."""
    g, traj_rng = np.random.default_rng(seed).spawn(2)
    origin = sn.Geo(round(float(_sign(g) * g.uniform(20, 60)), 6),
                    round(float(g.uniform(-180, 180)), 6), round(float(g.uniform(0, 300)), 1))
    iso = seed % 2 == 0
    t0 = round(float((_ISO_EPOCH if iso else 345600.0) + g.uniform(0, 7200)), 2)
    if recording is None:
        traj = plan_trajectory(traj_rng, duration + 0.5, t0)
    else:
        traj = recorded_trajectory(*recording, t0, duration + 0.5,
                                   float(traj_rng.uniform(0.0, 2.0 * math.pi)))
        duration = min(duration, traj.duration - 0.5)
    h0 = origin.height
    r1_site = _geo_at(origin, *_polar(g, 1.5e3, 6e3), h0 + g.uniform(-30, 300))
    r1_sigma = {"range": _r(g.uniform(5, 10)), "azimuth": _r(g.uniform(0.2, 1) * _MRAD, 6),
                "elevation": _r(g.uniform(0.2, 1) * _MRAD, 6)}
    rr_sigma = _r(g.uniform(0.05, 0.2), 3)
    if seed % 2 == 1:
        r1_sigma["range_rate"] = rr_sigma
    # theodolite near the ground track at a random time, limited coverage windows
    t_star = t0 + g.uniform(0.3, 0.7) * duration
    p_star = traj.state(np.array([t_star]))[0][0]
    de, dn = _polar(g, 4e3, 10e3)
    th_site = _geo_at(origin, p_star[0] + de, p_star[1] + dn, h0 + g.uniform(-30, 300))
    th_sigma = {"azimuth": _r(g.uniform(10, 20), 1) * _ARCSEC,
                "elevation": _r(g.uniform(10, 20), 1) * _ARCSEC}
    laser_sigma = _r(g.uniform(2, 3))
    if seed % 4 < 2:
        th_sigma["range"] = laser_sigma
    acq = t0 + g.uniform(0.05, 0.2) * duration
    gaps = sorted((s, s + g.uniform(3, 15)) for s in
                  acq + g.uniform(0, 1, int(g.integers(1, 3))) * (t0 + duration - acq))
    th_windows, start = [], acq
    for a, b in gaps:
        if a > start:
            th_windows.append((start, a))
        start = max(start, b)
    th_windows.append((start, t0 + duration + 1.0))
    north = seed % 4 == 1
    ship = draw_ship(g, origin, duration, north)
    lever = (round(g.uniform(5, 20), 2), round(g.uniform(-3, 3), 2), round(g.uniform(-25, -10), 2))
    s1_sigma = {"range": _r(g.uniform(5, 10)), "azimuth": _r(g.uniform(0.3, 1) * _MRAD, 6),
                "elevation": _r(g.uniform(0.3, 1) * _MRAD, 6)}
    ins_sigma = {"attitude": math.radians(0.005), "position": 0.1, "velocity": 0.02}
    g1_sigma = {"horizontal": _r(g.uniform(2, 4)), "vertical": _r(g.uniform(3, 5)),
                "velocity": _r(g.uniform(0.05, 0.15), 3)}
    drop = [(s, s + g.uniform(5, 20)) for s in
            t0 + g.uniform(0.1, 0.9, int(g.integers(1, 3))) * duration]
    b0 = t0 + g.uniform(0.1, 0.9) * duration
    burst = (b0, b0 + g.uniform(8, 12))
    n_st = int(g.integers(4, 9))
    angles = 2 * math.pi * (np.arange(n_st) + g.uniform(-0.3, 0.3, n_st)) / n_st
    dists = g.uniform(5e3, 40e3, n_st)
    stations = [(f"M{i + 1}", _geo_at(origin, d * math.sin(a), d * math.cos(a),
                                      h0 + g.uniform(-20, 150)))
                for i, (a, d) in enumerate(zip(angles, dists))]
    return Scenario(
        seed=seed, duration=duration, origin=origin, traj=traj, iso_gps=iso,
        latency_sensor=("R1", "TH1", "G1", "S1")[seed % 4],
        shuffled_sensor=("MISTRAM", "R1", "S1", "G1")[seed % 4],
        r1_site=r1_site, r1_sigma=r1_sigma, th_site=th_site, th_sigma=th_sigma,
        th_unit=("mil", "deg", "rad")[seed % 3], th_rate=float(g.choice([20.0, 25.0])),
        th_windows=th_windows, ship=ship, lever=lever, s1_sigma=s1_sigma, ins_sigma=ins_sigma,
        g1_sigma=g1_sigma, g1_dropouts=drop, g1_burst=burst, stations=stations,
        mistram_sigma=_r(g.uniform(0.03, 0.1), 3), wild_fraction=g.uniform(0.005, 0.01),
        rate_scale=float(rate_scale))


def draw_ship(g: np.random.Generator, origin: sn.Geo, duration: float, north: bool
              ) -> sn.ShipMotion:
    """A ship sailing 5-12 m/s for ``duration`` s, the middle of its track 15-30 km from the
    origin, with heave, roll, pitch and yaw oscillations; ``north``: course within 1 deg of
    north (its yaw wraps across 0/360)."""
    course = math.radians(g.uniform(-1, 1) if north else g.uniform(0, 360)) % (2 * math.pi)
    speed = g.uniform(5, 12)  # the middle of the ship's track is 15-30 km from the origin
    mid_e, mid_n = _polar(g, 15e3, 30e3)
    half = 0.5 * speed * duration
    return sn.ShipMotion(
        start=_geo_at(origin, mid_e - half * math.sin(course), mid_n - half * math.cos(course),
                      g.uniform(-30, 40)),
        course=course, speed=speed,
        heave=(g.uniform(0.3, 1.5), g.uniform(6, 12), g.uniform(0, 2 * math.pi)),
        roll=(math.radians(g.uniform(3, 8)), g.uniform(8, 14), g.uniform(0, 2 * math.pi)),
        pitch=(math.radians(g.uniform(1, 3)), g.uniform(5, 8), g.uniform(0, 2 * math.pi)),
        yaw=(math.radians(g.uniform(1.5 if north else 1, 2)), g.uniform(10, 20),
             g.uniform(0, 2 * math.pi)))


def _r(x: float, nd: int = 2) -> float:
    return round(float(x), nd)


def _sign(g: np.random.Generator) -> float:
    """Random sign +-1 (hemisphere)."""
    return 1.0 if g.random() < 0.5 else -1.0


def build_columns(sc: Scenario, sid: str, *, noise: bool = True,
                  faults: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
    """File columns of sensor ``sid`` (file units, rows in file order; NaN = empty cell).

    faults: this sensor's systematic errors (SI, see :data:`FAULTS`), applied to the exact
    measurement before noise: the row stamped t (after ``time_offset``) measures the truth at
    t - latency (target and, for S1, ship), seen through the mount rotation, plus the biases.
    """
    f = dict(faults or {})
    # child streams of default_rng(seed): 0 geometry, 1 trajectory, 2 + i sensor i (timing and
    # faults/noise split again) -> each file depends only on the seed and its own stream
    streams = sc.seed if sc.noise_seed is None else sc.noise_seed
    timing, nz = np.random.default_rng(streams).spawn(3 + SENSOR_IDS.index(sid))[-1].spawn(2)
    t0, dur, off = sc.t0, sc.duration, sc.offset(sid)
    t_true = sn.sample_times(timing, t0, dur, sc.rate(sid))
    if sid == "G1":
        t_true = t_true[~sn.in_intervals(t_true, sc.g1_dropouts)]
    t_file, t_meas = sn.file_times(t_true, off)
    if sid == "G1" and sc.iso_gps:
        t_file, t_meas = iso_file_times(t_true, off)
    t_geo = true_times(t_meas, f.get("latency", 0.0))
    cols: dict[str, np.ndarray]
    if sid == "MISTRAM":
        st = np.array([sn.site_enu(geo, sc.origin) for _, geo in sc.stations])
        cols = sn.mistram_columns(nz, t_file, sc.traj, t_geo, st, [s for s, _ in sc.stations],
                                  sc.mistram_sigma, noise=noise,
                                  n_wild=int(nz.integers(5, 21)))
    elif sid == "SHIP_INS":
        cols = sn.ins_columns(nz, t_file, t_meas - t0, sc.ship, sc.ins_sigma, noise=noise)
    else:
        p, v, _ = sc.traj.state(t_geo)
        if sid == "G1":
            cols = sn.gps_columns(nz, t_file, t_meas, p, v, sc.origin, sc.g1_sigma, noise=noise,
                                  burst=sc.g1_burst, n_wild=int(nz.integers(3, 9)))
        elif sid == "S1":
            lat, lon, h = sc.ship.geodetic(t_geo - t0)
            rae = sn.platform_geometry(p, sc.origin, lat, lon, h, sc.ship.attitude(t_geo - t0),
                                       np.array(sc.lever),
                                       mount=tuple(f.get(k, 0.0) for k in _MOUNT))
            rae = sn.add_biases(rae, f)
            cols = sn.rae_columns(nz, t_file, rae, sc.s1_sigma, "deg", noise=noise,
                                  wild_fraction=sc.wild_fraction,
                                  n_missing=int(nz.integers(3, 15)), missing="range")
        elif sid == "R1":
            r, az, el, rr = sn.fixed_site_geometry(p, v, sc.origin, sc.r1_site)
            rae = (r, az, el, rr) if "range_rate" in sc.r1_sigma else (r, az, el)
            rae = sn.add_biases(rae, f)
            cols = sn.rae_columns(nz, t_file, rae, sc.r1_sigma, "deg", noise=noise,
                                  wild_fraction=sc.wild_fraction,
                                  n_missing=int(nz.integers(3, 15)), missing="elevation")
            cols["track_id"] = np.full(t_file.size, 7, dtype=np.int64)
        else:  # TH1: limited coverage, optional laser range
            r, az, el, _ = sn.fixed_site_geometry(p, v, sc.origin, sc.th_site)
            vis = sn.in_intervals(t_geo, sc.th_windows) & (el > TH_MIN_EL) & (r < TH_MAX_RANGE)
            laser = np.where(r < LASER_MAX_RANGE, r, np.nan)[vis]
            rae = sn.add_biases((laser, az[vis], el[vis]), f)
            cols = sn.rae_columns(nz, t_file[vis], rae, sc.th_sigma,
                                  sc.th_unit, noise=noise, wild_fraction=sc.wild_fraction,
                                  n_missing=0, missing="azimuth")
            if "range" not in sc.th_sigma:
                del cols["range"]
    if sid == sc.shuffled_sensor:
        order = sn.shuffle_chunk(timing, cols["time"].size)
        cols = {k: val[order] for k, val in cols.items()}
    return cols


def iso_file_times(t_true: np.ndarray, offset: float) -> tuple[np.ndarray, np.ndarray]:
    """Timestamps as ISO-8601 UTC strings (Unix seconds ``t_true - offset`` to 1 us, 'Z') and
    the measurement times a reader reconstructs from them (s, written + offset)."""
    us = np.round((t_true - offset) * 1e6).astype(np.int64)
    t_meas = us / 1e6 + offset
    t_file = np.char.add(np.datetime_as_string(us.astype("datetime64[us]"), unit="us"), "Z")
    return t_file, t_meas


def true_times(t_meas: np.ndarray, latency: float) -> np.ndarray:
    """True times (s) of measurements stamped ``t_meas`` (after ``time_offset``) by a sensor
    whose stamps are ``latency`` s late: t_meas - latency (t_meas itself for no latency)."""
    return t_meas - latency if latency else t_meas


def truth_columns(sc: Scenario) -> dict[str, np.ndarray]:
    """truth.csv columns at the 100 Hz trajectory nodes inside [t0, t0 + duration]."""
    return trajectory_truth(sc.traj, "T1", sc.origin, sc.t0 + sc.duration)


def trajectory_truth(tr: Trajectory, target_id: str, origin: sn.Geo, t_end: float
                     ) -> dict[str, np.ndarray]:
    """truth.csv columns of one object at its 100 Hz nodes up to range time ``t_end`` (s):
    target_id, time, e, n, u, ve, vn, vu, ae, an, au (range ENU, m, m/s, m/s^2), lat, lon
    (deg), height (m)."""
    keep = tr.node_time <= t_end + 1e-9
    p, v, a = tr.node_p[keep], tr.node_v[keep], tr.node_a[keep]
    lat, lon, h = pm.enu2geodetic(p[:, 0], p[:, 1], p[:, 2], origin.lat, origin.lon,
                                  origin.height)
    cols: dict[str, np.ndarray] = {"target_id": np.full(p.shape[0], target_id),
                                   "time": np.round(tr.node_time[keep], 6)}
    for i, ax in enumerate("enu"):
        cols[ax] = p[:, i]
    for name, arr in (("v", v), ("a", a)):
        for i, ax in enumerate("enu"):
            cols[name + ax] = arr[:, i]
    cols.update(lat=np.asarray(lat), lon=np.asarray(lon), height=np.asarray(h))
    return cols


def config_text(sc: Scenario, ids: list[str], *, faulted: bool = False) -> str:
    """scenario.toml text with only the data contract's sections and keys (``faulted``: the
    header comment points to truth_calibration.json)."""
    o = sc.origin
    scaled = "" if sc.rate_scale == 1.0 else f", sample rates x{sc.rate_scale:g}"
    cal = f"; systematic sensor faults in {TRUTH_CALIBRATION}" if faulted else ""
    draw = "" if sc.noise_seed is None else f", sensor noise seed {sc.noise_seed}"
    lines = [f"# simulated scenario (rangeproc.simulate), seed {sc.seed}{draw}, "
             f"duration {sc.duration:g} s{scaled}; truth in truth.csv{cal}", "",
             "[range]", f"origin = {_geo_toml(o)}", "", "[output]", 'dir = "out"',
             "rate_hz = 10.0", "", "[[targets]]", 'id = "T1"']
    deg = 180.0 / math.pi
    for sid in ids:
        e: dict[str, object] = {"id": sid}
        if sid == "R1":
            e.update(kind="radar", file=FILES[sid], site=sc.r1_site, angle_unit="deg",
                     sigma=_sigma_units(sc.r1_sigma, deg))
        elif sid == "TH1":
            e.update(kind="theodolite", file=FILES[sid], site=sc.th_site, angle_unit=sc.th_unit,
                     sigma=_sigma_units(sc.th_sigma, sn.ANGLE_SCALE[sc.th_unit]))
        elif sid == "S1":
            e.update(kind="radar", file=FILES[sid], platform="SHIP_INS",
                     lever_arm=list(sc.lever), angle_unit="deg",
                     sigma=_sigma_units(sc.s1_sigma, deg))
        elif sid == "SHIP_INS":
            att = sc.ins_sigma["attitude"] * deg
            e.update(kind="ins", file=FILES[sid], angle_unit="deg",
                     sigma={"roll": att, "pitch": att, "yaw": att,
                            "position": sc.ins_sigma["position"]})
        elif sid == "G1":
            e.update(kind="gps", file=FILES[sid], target="T1", sigma=dict(sc.g1_sigma))
        else:
            e.update(kind="mistram", file=FILES[sid], sigma={"range_rate": sc.mistram_sigma},
                     stations=[{"id": s, "lat": g.lat, "lon": g.lon, "height": g.height}
                               for s, g in sc.stations])
        e["time_offset"] = sc.offset(sid)
        lines += ["", "[[sensors]]"] + [f"{k} = {_toml(val)}" for k, val in e.items()]
    return "\n".join(lines) + "\n"


def _sigma_units(sigma: dict[str, float], angle_scale: float) -> dict[str, float]:
    return {k: val * angle_scale if k in ("azimuth", "elevation") else val
            for k, val in sigma.items()}


def _geo_toml(g: sn.Geo) -> str:
    return _toml({"lat": g.lat, "lon": g.lon, "height": g.height})


def _toml(val: object) -> str:
    """TOML literal for str, float/int, list, dict (inline table) or Geo."""
    if isinstance(val, sn.Geo):
        return _geo_toml(val)
    if isinstance(val, str):
        return '"' + val.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(val, dict):
        return "{ " + ", ".join(f"{k} = {_toml(x)}" for k, x in val.items()) + " }"
    if isinstance(val, (list, tuple)):
        return "[" + ", ".join(_toml(x) for x in val) + "]"
    return repr(float(val))  # type: ignore[arg-type]


def parse_sensor_list(sensors: str) -> list[str]:
    """'all' or comma-separated ids -> ids in canonical order; ConfigError on bad input."""
    if sensors.strip().lower() == "all":
        return list(SENSOR_IDS)
    want = [s.strip() for s in sensors.split(",") if s.strip()]
    bad = [s for s in want if s not in SENSOR_IDS]
    if bad or not want:
        what = f"unknown id {bad[0]!r}" if bad else "no sensor id"
        raise ConfigError(f"simulate: sensors={sensors!r}: {what}; choose from "
                          f"{','.join(SENSOR_IDS)} or 'all'")
    if "S1" in want and "SHIP_INS" not in want:
        raise ConfigError(f"simulate: sensors={sensors!r}: S1 needs its platform SHIP_INS")
    return [s for s in SENSOR_IDS if s in want]


def validate_faults(faults: Mapping[str, Mapping[str, float]] | None
                    ) -> dict[str, dict[str, float]]:
    """Checked copy ``{sensor_id: {name: value}}`` of ``faults`` (SI units, see :data:`FAULTS`),
    sensors and names in canonical order; ConfigError naming the sensor and fault at fault."""
    if not faults:
        return {}
    if not isinstance(faults, Mapping):
        raise ConfigError(f"simulate: faults={faults!r}: must map sensor ids to "
                          "{fault name: value}")
    bad = [sid for sid in faults if sid not in SENSOR_IDS]
    if bad:
        raise ConfigError(f"simulate: faults: unknown sensor id {bad[0]!r}; choose from "
                          f"{','.join(SENSOR_IDS)}")
    out: dict[str, dict[str, float]] = {}
    for sid in SENSOR_IDS:
        if sid in faults:
            checked = _sensor_faults(sid, faults[sid])
            if checked:
                out[sid] = checked
    return out


def _sensor_faults(sid: str, given: object) -> dict[str, float]:
    """Checked faults of one sensor, names in :data:`FAULTS` order."""
    if not isinstance(given, Mapping):
        raise ConfigError(f"simulate: faults.{sid}={given!r}: must map fault names to values")
    for name in given:
        if name not in FAULTS:
            raise ConfigError(f"simulate: faults.{sid}: unknown fault {name!r}; choose from "
                              f"{', '.join(FAULTS)}")
        if sid not in FAULTS[name][1]:
            raise ConfigError(f"simulate: faults.{sid}.{name}: not applicable to {sid} "
                              f"({name} applies to {', '.join(FAULTS[name][1])})")
    out = {}
    for name, (unit, _) in FAULTS.items():
        if name not in given:
            continue
        val = given[name]
        limit = FAULT_LIMIT[unit]
        if (isinstance(val, bool) or not isinstance(val, numbers.Real)
                or not abs(float(val)) <= limit):  # also rejects NaN
            raise ConfigError(f"simulate: faults.{sid}.{name}={val!r}: must be a number in "
                              f"[-{limit:g}, {limit:g}] {unit} (SI units)")
        out[name] = float(val)
    return out


def resolve_faults(spec: str) -> dict[str, dict[str, float]]:
    """Faults named on the command line: a preset name (:data:`FAULT_PRESETS`, e.g. 'none',
    'registration'; also the former names of :data:`FAULT_PRESET_ALIASES`), a JSON object
    ``{sensor_id: {name: value_SI}}`` or the path of a JSON file holding one. Returns the
    mapping unchecked (:func:`simulate_scenario` checks it)."""
    key = spec.strip()
    name = FAULT_PRESET_ALIASES.get(key.lower(), key.lower())
    if name in FAULT_PRESETS:
        return FAULT_PRESETS[name]
    what = "JSON"
    try:
        if key.startswith("{"):
            text = key
        else:
            what = f"JSON file {key}"
            text = Path(key).read_text(encoding="utf-8")
        doc = json.loads(text)
    except FileNotFoundError:
        raise ConfigError(f"simulate: faults={spec!r}: not a preset "
                          f"({', '.join(FAULT_PRESETS)}), JSON object or JSON file") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"simulate: faults={spec!r}: unreadable {what}: {exc}") from None
    if not isinstance(doc, dict):
        raise ConfigError(f"simulate: faults={spec!r}: {what} must hold an object "
                          "{sensor_id: {name: value}}")
    return doc


def simulate_scenario(out_dir: Path, *, seed: int = 1, duration: float = 120.0,
                      sensors: str = "all", noise: bool = True, rate_scale: float = 1.0,
                      faults: Mapping[str, Mapping[str, float]] | None = None,
                      trajectory: Path | None = None, noise_seed: int | None = None) -> Path:
    """Write sensor files, ``scenario.toml`` and ``truth.csv`` into out_dir; return the config.

    duration: seconds of flight (>= 20). sensors: 'all' or e.g. 'R1,S1,SHIP_INS,G1'.
    rate_scale: factor in (0, 20] on every sensor's sample rate (INS included), e.g. for
    benchmarks; rows grow linearly with it, truth.csv stays at 100 Hz.
    noise=False writes exact measurements (no noise, wild points, bursts or empty cells; gaps,
    coverage limits, latency and row shuffling are kept) for tests.
    faults: ``{sensor_id: {name: value}}`` systematic errors in SI units with the data
    contract's names and signs (section 4; see :data:`FAULTS`), e.g. :data:`REGISTRATION_FAULTS`;
    applied with or without noise and written to ``truth_calibration.json`` (only the
    sensors written). None or {} writes exactly the fault-free files (and no such file).
    trajectory: a recorded track (``simulate.recorded``, the truth format of ``rangeproc
    evaluate``) to fly instead of the seed's drawn one, for at most ``duration`` seconds.
    noise_seed: draw the sensors' sampling times, noise, wild points and empty cells from this
    seed instead of ``seed``: the same flight, sites and sigmas measured again (Monte Carlo).
    """
    if not duration >= 20.0 or not math.isfinite(duration):
        raise ConfigError(f"simulate: duration={duration!r}: must be a number >= 20 s")
    if not 0.0 < rate_scale <= MAX_RATE_SCALE:  # also rejects NaN
        raise ConfigError(f"simulate: rate_scale={rate_scale!r}: must be a number in "
                          f"(0, {MAX_RATE_SCALE:g}]")
    ids = parse_sensor_list(sensors)
    checked = validate_faults(faults)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    recording = read_recording(trajectory) if trajectory is not None else None
    sc = draw_scenario(int(seed), float(duration), float(rate_scale), recording)
    if noise_seed is not None:
        sc = dataclasses.replace(sc, noise_seed=int(noise_seed))
    for sid in ids:
        cols = build_columns(sc, sid, noise=noise, faults=checked.get(sid))
        atomic_write_table(out_dir / FILES[sid], cols)
        log.info("simulate: wrote %s (%d rows)", FILES[sid], cols["time"].size)
    atomic_write_table(out_dir / "truth.csv", truth_columns(sc), truth=True)
    # a latency fault is injected after the sensor's known time_offset: stamp + offset minus
    # the latency is the true time, so the contract's (residual) latency is the fault itself
    write_truth_calibration(out_dir, {sid: dict(f) for sid, f in checked.items() if sid in ids},
                            given=bool(faults))
    cfg = out_dir / "scenario.toml"
    atomic_write_text(cfg, config_text(sc, ids, faulted=bool(faults)))
    return cfg


def write_truth_calibration(out_dir: Path, faults: dict[str, dict[str, float]], *,
                            given: bool) -> None:
    """Write ``truth_calibration.json`` = ``{sensor_id: {name: value_SI}}`` if faults were
    ``given``; otherwise remove a stale one left by an earlier faulted run in out_dir."""
    path = out_dir / TRUTH_CALIBRATION
    if not given:
        path.unlink(missing_ok=True)
        return
    atomic_write_text(path, json.dumps(faults, indent=2) + "\n")
