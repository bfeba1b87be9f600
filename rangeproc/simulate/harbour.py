"""The harbour kind: a ferry's radar, lidar and cameras among boats, a departing ship, moored
boats, quays and sea clutter, written like the Autoferry recordings (``tools/autoferry.py``).

``simulate_harbour(out_dir, seed=...)`` (``rangeproc simulate OUT --objects harbour``) writes
``FERRY.csv`` (kind ``ins``), ``RADAR.csv`` and ``LIDAR.csv`` (kind ``radar``: range,
azimuth, elevation empty, no ``track_id``), ``EO.csv`` and, on about half the seeds,
``IR.csv`` (kind ``theodolite``: azimuth only), all on platform ``FERRY``; ``scenario.toml``
(no ``[[targets]]``: every object is for rangeproc to discover); ``truth.csv`` (per object,
10 Hz: ``e, n, u, ve, vn, vu`` of its GNSS antenna, the recordings' truth, then
``hull_e, hull_n, heading`` of its hull centre, deg clockwise from north);
``truth_platform.csv`` (the ferry: ``time, e, n, u, roll, pitch, yaw`` true, deg);
``truth_association.csv`` (per radar/lidar/camera row: ``sensor, row, target_id`` (empty for
clutter), ``wild`` (always 0), ``source`` (``object``, a quay id, ``sea``, ``false``),
``true_time`` s) and ``truth_events.json`` (objects with dimensions and antenna lever arms,
the quay departure, quays, every generator parameter and the stated sigmas).

Objects (truth ids): ``B1`` a boat moving about the whole time; ``B2`` a ship lying at quay
``Q1`` that leaves at ``depart`` s; ``M1`` (and ``M2`` with 4 objects) moored boats that never
move. Hulls are rectangles along the heading; radar and lidar returns lie on the sides facing
the sensor (``harbour_motion.visible_points``), camera bearings point at the centre of the
hull's angular extent; the truth is the antenna, off the centre by its lever arm.

Parameters (drawn uniformly in the ranges per seed; ``L`` length, ``B`` beam):

- range origin: latitude +-35..65 deg, longitude -180..180 deg, height 0..50 m
- start: Unix time 2026-05-04 10:00 UTC + 0..2 h
- ferry: starts within 30 m of the origin, 1-3 m/s (0.1 m/s^2), legs of 15-40 s, turns of 20-90
  deg at 1.5-4 deg/s, back towards the origin beyond 120 m; roll 0.3-1.2 deg (period 3-6 s),
  pitch 0.1-0.5 deg (3-6 s), yaw wobble 0.1-0.4 deg (6-15 s)
- ferry form: half the seeds north-up (the recordings' form: yaw written 0, deck angles north-
  referenced, lever arms 0, INS in rad); the others yaw = heading (INS in deg) with sensor lever
  arms 0.5-2.5 m forward
- B1 boat: L 10-14 m, B 0.30-0.38 L; 120-280 m from the origin; 2.5-6.5 m/s (0.4 m/s^2), legs
  8-25 s, turns 30-150 deg at 4-10 deg/s, back towards the origin beyond 220 m
- B2 ship: L 27-33 m, B 0.20-0.26 L, alongside Q1 (1 m off), leaves 40-50 s after the start:
  12-18 s ahead to 3-5 m/s (0.2 m/s^2), a 50-90 deg turn away from the quay at 2-4 deg/s, then
  legs as the boat's at 2.5-5 m/s, 1.5-3 deg/s, back beyond 250 m
- M1, M2 moored: L 7-15 m, B 0.30-0.40 L, alongside Q2 (or Q3), 0.8 m off; never move
- antennas: lever arm forward -0.35..0.15 L (boat), -0.4..0.3 L (ship), -0.3..0.3 L (moored);
  starboard -0.35..0.35 B
- quays: Q1 90-160 m long, centre 120-220 m from the origin; Q2 60-200 m, 100-300 m on the other
  side; Q3 (half the seeds) 50-150 m, 150-350 m; fixed scatterers every 30-60 m and at both
  ends, each seen per scan with p 0.15-0.4 (radar), 0.05-0.15 (lidar)
- RADAR: a scan every 2-3 s, Pd 0.9 per object, one return per object, range 15-500 m, noise
  range 1.5-3 m, azimuth 0.5-1 deg; sea clutter 0.5-2 plots per scan (Poisson, uniform in area
  over 15-500 m and all azimuths)
- LIDAR: 10 Hz, Pd 0.95, 1 + Poisson(width / 8 m) returns per object (at most 6), range 2-150 m,
  noise range 0.05-0.2 m, azimuth 0.1-0.3 deg; clutter 0.02 plots per scan
- EO: 5 Hz, Pd 0.9 within 600 m, AR(1) bearing error sigma 1-2 deg with lag-1 correlation
  0.8-0.9 per frame; 0.02 false bearings per frame
- IR (half the seeds): 8.57 Hz, Pd 0.85 within 400 m, AR(1) sigma 1.5-2.5 deg, lag-1 correlation
  0.8-0.9; 0.02 false bearings per frame
- FERRY INS: 20 Hz, white noise attitude 0.01-0.02 deg, position 0.05-0.2 m per axis

Stated sigmas: each radar, lidar and camera's range and azimuth sigma in ``scenario.toml``
is its residuals' robust spread (1.4826 x MAD) against the true antenna track, at the file's
time stamps, from the ferry's true pose (as a user calibrates a sensor against GNSS), over
the rows of every object. Elevation cells are empty; the stated elevation sigma is, as in the
recordings' conversion, 2 deg for the radar and lidar and the azimuth's for a camera. A
sensor that saw no object keeps its generator sigma. Nothing models occlusion, multipath or
wakes, and tracks do not avoid each other: a ferry whose track crosses a hull sees nothing of
it while inside. Randomness: ``default_rng(seed).spawn(3)``: geometry, paths (one stream per
object, the ferry last), sensors (one per sensor in config order).
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rangeproc.simulate import harbour_sensors as hs
from rangeproc.simulate import sensors as sn
from rangeproc.simulate.files import atomic_write_table, atomic_write_text, text_column
from rangeproc.simulate.harbour_motion import (DT, Hull, Leg, Manoeuvres, Quay, still_path,
                                               steer)
from rangeproc.simulate.scenario import _ISO_EPOCH, _geo_toml, _r, _toml

log = logging.getLogger(__name__)

TRUTH_ASSOCIATION, TRUTH_EVENTS = "truth_association.csv", "truth_events.json"
TRUTH_PLATFORM = "truth_platform.csv"
TRUTH_RATE = 10.0  #: truth.csv rows per second
OUTPUT_RATE = 5.0  #: the config's [output] rate_hz, as the recordings' conversion
PLATFORM = "FERRY"
MOORED_MAX = 2  #: moored boats (objects beyond the boat and the ship)
#: stated elevation sigma (deg) of the radar and lidar, whose elevation cells are empty: the
#: recordings' conversion's value (``tools/autoferry.py``)
NO_ELEVATION_DEG = 2.0


@dataclass(frozen=True, slots=True)
class HarbourScene:
    """Everything drawn for one seed: the world, the sensors in config order and the time
    (s) the ship leaves its quay."""

    seed: int
    world: hs.World
    sensors: tuple[hs.Spec, ...]
    departure: float


def _u(g: np.random.Generator, lo: float, hi: float) -> float:
    return float(g.uniform(lo, hi))


def _heading(v: np.ndarray) -> float:
    return math.atan2(float(v[0]), float(v[1]))


def _quay(g: np.random.Generator, qid: str, bearing: float, dist: tuple[float, float],
          length: tuple[float, float]) -> Quay:
    """A quay whose centre lies ``dist`` m from the origin at ``bearing`` rad, running
    roughly across that bearing (+-30 deg), its water side towards the origin."""
    r = _u(g, *dist)
    mid = r * np.array([math.sin(bearing), math.cos(bearing)])
    along = bearing + math.pi / 2 + math.radians(_u(g, -30, 30))
    d = np.array([math.sin(along), math.cos(along)])
    half = 0.5 * _u(g, *length)
    a, b = mid - half * d, mid + half * d
    water = np.array([-d[1], d[0]])
    if water @ -mid < 0:
        water = -water
    spacing = _u(g, 30, 60)
    n_mid = max(0, int(round(2 * half / spacing)) - 1)
    frac = np.concatenate(([0.0, 1.0], np.sort(g.uniform(0.0, 1.0, n_mid))))
    scatter = np.round(a + frac[:, None] * (b - a), 2)
    return Quay(qid, a, b, water, scatter, np.round(g.uniform(0.15, 0.4, frac.size), 3),
                np.round(g.uniform(0.05, 0.15, frac.size), 3))


def _alongside(g: np.random.Generator, q: Quay, length: float, beam: float, gap: float,
               at: tuple[float, float] = (0.0, 1.0)) -> tuple[np.ndarray, float]:
    """Centre (2,) m and heading (rad, either way along the quay) of a hull lying alongside
    quay q ``gap`` m off, its centre in the fraction ``at`` of the quay's usable length."""
    usable = max(q.length - length - 4.0, 0.0)
    s = 2.0 + 0.5 * length + usable * _u(g, *at)
    c = q.a + s * q.direction + (0.5 * beam + gap) * q.water
    psi = _heading(q.direction if g.random() < 0.5 else -q.direction)
    return c, psi


def draw_harbour(seed: int, duration: float, n_objects: int | None = None) -> HarbourScene:
    """Draw the harbour scene of ``seed`` (module docstring); ``n_objects`` 3 or 4 (default
    drawn). The caller checks the arguments (``multi.check_request``)."""
    g, g_paths, _ = np.random.default_rng(seed).spawn(3)
    lat = (1.0 if g.random() < 0.5 else -1.0) * _u(g, 35, 65)
    origin = sn.Geo(round(lat, 6), round(_u(g, -180, 180), 6), round(_u(g, 0, 50), 1))
    t0 = round(_ISO_EPOCH + _u(g, 0, 7200), 2)
    n = int(n_objects) if n_objects is not None else int(g.integers(3, 3 + MOORED_MAX))
    rngs = g_paths.spawn(n + 1)
    t_lo, t_hi = t0 - 1.0, t0 + duration + 1.0
    b1 = _u(g, 0, 2 * math.pi)
    quays = [_quay(g, "Q1", b1, (120, 220), (90, 160)),
             _quay(g, "Q2", b1 + math.radians(_u(g, 90, 270)), (100, 300), (60, 200))]
    if g.random() < 0.5:
        quays.append(_quay(g, "Q3", _u(g, 0, 2 * math.pi), (150, 350), (50, 150)))
    # B1: the boat
    length = _u(g, 10, 14)
    beam = length * _u(g, 0.30, 0.38)
    lever = (_r(length * _u(g, -0.35, 0.15)), _r(beam * _u(g, -0.35, 0.35)))
    r0, a0 = _u(g, 120, 280), _u(g, 0, 2 * math.pi)
    boat_m = Manoeuvres((2.5, 6.5), 0.4, (4, 10), (30, 150), (8, 25), (0.0, 0.0), 220.0)
    path = steer(rngs[0], t_lo, t_hi, r0 * np.array([math.sin(a0), math.cos(a0)]),
                 _u(g, 0, 2 * math.pi), _u(g, 3, 6), boat_m)
    hulls = [Hull("B1", "boat", _r(length), _r(beam), lever, path)]
    # B2: the ship at Q1, leaving
    length = _u(g, 27, 33)
    beam = length * _u(g, 0.20, 0.26)
    lever = (_r(length * _u(g, -0.4, 0.3)), _r(beam * _u(g, -0.35, 0.35)))
    c, psi = _alongside(g, quays[0], length, beam, 1.0, (0.2, 0.8))
    wait = DT * round((t0 + _u(g, 40, 50) - t_lo) / DT)  # on the path's time grid
    depart = round(t_lo + wait, 6)
    starboard = np.array([math.cos(psi), -math.sin(psi)])
    sign = 1.0 if starboard @ quays[0].water > 0 else -1.0
    rate = math.radians(_u(g, 2, 4))
    v_dep = _u(g, 3, 5)
    script = (Leg(wait, 0.0, 0.0), Leg(_u(g, 12, 18), 0.0, v_dep),
              Leg(math.radians(_u(g, 50, 90)) / rate, sign * rate, v_dep))
    ship_m = Manoeuvres((2.5, 5.0), 0.2, (1.5, 3), (20, 70), (15, 40), (0.0, 0.0), 250.0)
    path = steer(rngs[1], t_lo, t_hi, c, psi, 0.0, ship_m, script)
    hulls.append(Hull("B2", "ship", _r(length), _r(beam), lever, path))
    # M1, M2: moored
    for i in range(n - 2):
        q = quays[1 + i] if len(quays) > 2 else quays[1]
        at = (0.0, 1.0) if len(quays) > 2 else ((0.0, 0.4), (0.6, 1.0))[i]
        length = _u(g, 7, 15)
        beam = length * _u(g, 0.30, 0.40)
        lever = (_r(length * _u(g, -0.3, 0.3)), _r(beam * _u(g, -0.35, 0.35)))
        c, psi = _alongside(g, q, length, beam, 0.8, at)
        hulls.append(Hull(f"M{i + 1}", "moored", _r(length), _r(beam), lever,
                          still_path(t_lo, t_hi, c, psi)))
    ferry = _ferry(g, rngs[n], t_lo, t_hi)
    w = hs.World(origin, t0, float(duration), ferry, tuple(hulls), tuple(quays))
    return HarbourScene(int(seed), w, _sensors(g, ferry), depart)


def _ferry(g: np.random.Generator, rng: np.random.Generator, t_lo: float, t_hi: float
           ) -> hs.Ferry:
    m = Manoeuvres((1.0, 3.0), 0.1, (1.5, 4), (20, 90), (15, 40), (0.0, 0.0), 120.0)
    path = steer(rng, t_lo, t_hi, g.uniform(-30, 30, 2), _u(g, 0, 2 * math.pi), _u(g, 1, 3),
                 m)

    def osc(lo: float, hi: float, p_lo: float, p_hi: float) -> tuple[float, float, float]:
        return (math.radians(_u(g, lo, hi)), _u(g, p_lo, p_hi), _u(g, 0, 2 * math.pi))
    north_up = bool(g.random() < 0.5)
    return hs.Ferry(path, north_up, osc(0.3, 1.2, 3, 6), osc(0.1, 0.5, 3, 6),
                    osc(0.1, 0.4, 6, 15))


def _lever(g: np.random.Generator, north_up: bool, fwd: tuple[float, float],
           stbd: tuple[float, float]) -> tuple[float, float, float]:
    if north_up:
        return (0.0, 0.0, 0.0)
    return (_r(_u(g, *fwd)), _r(_u(g, *stbd)), 0.0)


def _sensors(g: np.random.Generator, ferry: hs.Ferry) -> tuple[hs.Spec, ...]:
    """FERRY, RADAR, LIDAR, EO and (half the seeds) IR (module docstring). The INS writes
    degrees unless every angle it writes would also fit radians (a north-up ferry's yaw is
    0 throughout), which rangeproc would rightly question."""
    north_up = ferry.north_up
    yaw = np.mod(np.degrees(ferry.path.psi), 360.0)
    unit = "rad" if north_up or bool(np.all(yaw <= 2 * math.pi)) else "deg"
    ins = hs.Ins(PLATFORM, f"{PLATFORM}.csv", 20.0, math.radians(_u(g, 0.01, 0.02)),
                 _u(g, 0.05, 0.2), unit)
    period = _u(g, 2, 3)
    radar = hs.ScanSensor("RADAR", "RADAR.csv", _lever(g, north_up, (0.5, 1.5), (0, 0)),
                          period, _u(g, 0, period),
                          {"range": _u(g, 1.5, 3.0), "azimuth": math.radians(_u(g, 0.5, 1.0))},
                          0.9, 15.0, 500.0, _u(g, 0.5, 2))
    lidar = hs.ScanSensor("LIDAR", "LIDAR.csv", _lever(g, north_up, (1.5, 2.5), (-0.3, 0.3)),
                          0.1, _u(g, 0, 0.1),
                          {"range": _u(g, 0.05, 0.2),
                           "azimuth": math.radians(_u(g, 0.1, 0.3))},
                          0.95, 2.0, 150.0, 0.02, per_return=8.0, max_returns=6, lidar=True)
    eo = hs.Camera("EO", "EO.csv", _lever(g, north_up, (-0.5, 0.5), (-0.5, 0.5)), 5.0,
                   _u(g, 0, 0.2), math.radians(_u(g, 1.0, 2.0)), _u(g, 0.8, 0.9), 0.9, 600.0,
                   0.02)
    out: list[hs.Spec] = [ins, radar, lidar, eo]
    if g.random() < 0.5:
        out.append(hs.Camera("IR", "IR.csv", _lever(g, north_up, (-0.5, 0.5), (-0.5, 0.5)),
                             1 / 0.1167, _u(g, 0, 0.1167), math.radians(_u(g, 1.5, 2.5)),
                             _u(g, 0.8, 0.9), 0.85, 400.0, 0.02))
    return tuple(out)


# --------------------------------------------------------------------------------- truth

def truth_table(w: hs.World) -> dict[str, Any]:
    """truth.csv columns: per object (by id) at ``TRUTH_RATE`` Hz over [t0, t0 + duration]:
    target_id, time, e, n, u, ve, vn, vu of its antenna, hull_e, hull_n, heading (deg)."""
    t = w.t0 + np.arange(int(math.floor(w.duration * TRUTH_RATE + 1e-9)) + 1) / TRUTH_RATE
    parts = []
    for h in sorted(w.hulls, key=lambda h: h.oid):
        p, v = h.antenna(t)
        c, _, psi, _ = h.path.state(t)
        z = np.zeros(t.size)
        parts.append({"target_id": np.full(t.size, h.oid), "time": np.round(t, 6),
                      "e": p[:, 0], "n": p[:, 1], "u": z, "ve": v[:, 0], "vn": v[:, 1],
                      "vu": z, "hull_e": c[:, 0], "hull_n": c[:, 1],
                      "heading": np.mod(np.degrees(psi), 360.0)})
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def platform_truth(w: hs.World, rate: float = 20.0) -> dict[str, np.ndarray]:
    """truth_platform.csv: the ferry's true INS reference point (e, n, u m) and attitude
    (roll, pitch, yaw deg, as written in its deck convention) at ``rate`` Hz."""
    t = w.t0 + np.arange(int(math.floor(w.duration * rate + 1e-9)) + 1) / rate
    p = w.ferry.path.state(t)[0]
    att = np.degrees(w.ferry.attitude(t))
    return {"time": np.round(t, 6), "e": p[:, 0], "n": p[:, 1], "u": np.zeros(t.size),
            "roll": att[:, 0], "pitch": att[:, 1], "yaw": att[:, 2]}


def robust_spread(x: np.ndarray) -> float:
    """1.4826 x median absolute deviation from the median (NaN when empty)."""
    x = x[np.isfinite(x)]
    return float(1.4826 * np.median(np.abs(x - np.median(x)))) if x.size else float("nan")


def stated_sigma(spec: hs.ScanSensor | hs.Camera, tab: hs.HarbourTable, w: hs.World
                 ) -> dict[str, float]:
    """The sigma a user would state (SI): robust spreads of the object rows' residuals
    against the true antenna at their time stamps (ferry true pose); range (radar/lidar)
    and azimuth; the generator's sigma where no object was seen."""
    own = {"azimuth": spec.sigma} if isinstance(spec, hs.Camera) else dict(spec.sigma)
    assert tab.obj is not None
    rows = np.flatnonzero(tab.obj >= 0)
    if rows.size < 10:
        return own
    t = tab.cols["time"][rows]
    ant = np.zeros((rows.size, 2))
    for j, h in enumerate(w.hulls):
        m = tab.obj[rows] == j
        ant[m] = h.antenna(t[m])[0]
    r, az, _ = hs.deck_rae(w.ferry, w.origin, t, ant, spec.lever)
    d_az = np.mod(np.radians(tab.cols["azimuth"][rows]) - az + math.pi, 2 * math.pi) - math.pi
    out = {"azimuth": robust_spread(d_az)}
    if "range" in tab.cols:
        out = {"range": robust_spread(tab.cols["range"][rows] - r), **out}
    return out


# --------------------------------------------------------------------------------- files

def config_text(sc: HarbourScene, written: list[tuple[hs.Spec, dict[str, float]]]) -> str:
    """scenario.toml in the recordings' conversion form (no [[targets]]); ``written``:
    each sensor with its stated sigma (SI)."""
    w = sc.world
    form = "north-up (yaw 0)" if w.ferry.north_up else "deck angles (yaw = heading)"
    lines = [f"# simulated harbour scene (rangeproc.simulate), seed {sc.seed}, duration "
             f"{w.duration:g} s, ferry {form}; truth in truth.csv, {TRUTH_PLATFORM}, "
             f"{TRUTH_ASSOCIATION} and {TRUTH_EVENTS}",
             "# (no [[targets]]: every object is undeclared, for rangeproc to discover)", "",
             "[range]", f"origin = {_geo_toml(w.origin)}", "", "[output]", 'dir = "out"',
             f"rate_hz = {OUTPUT_RATE!r}"]
    for spec, sigma in written:
        e: dict[str, object] = {"id": spec.sid}
        if isinstance(spec, hs.Ins):
            s = sn.ANGLE_SCALE[spec.unit]
            e.update(kind="ins", file=spec.file, angle_unit=spec.unit,
                     sigma={"roll": _r(spec.attitude * s, 8), "pitch": _r(spec.attitude * s, 8),
                            "yaw": _r(spec.attitude * s, 8), "position": _r(spec.position, 3)})
        else:
            az = _r(sigma["azimuth"] * sn.ANGLE_SCALE["deg"], 3)
            scan = isinstance(spec, hs.ScanSensor)
            stated = ({"range": _r(sigma["range"], 3), "azimuth": az,
                       "elevation": NO_ELEVATION_DEG} if scan
                      else {"azimuth": az, "elevation": az})
            e.update(kind="radar" if scan else "theodolite", file=spec.file, platform=PLATFORM,
                     lever_arm=list(spec.lever), angle_unit="deg", sigma=stated)
        lines += ["", "[[sensors]]"] + [f"{k} = {_toml(val)}" for k, val in e.items()]
    return "\n".join(lines) + "\n"


def association_table(sc: HarbourScene, tables: list[tuple[hs.Spec, hs.HarbourTable]]
                      ) -> dict[str, Any]:
    """truth_association.csv columns (module docstring)."""
    ids = [h.oid for h in sc.world.hulls]
    sid: list[str] = []
    tid: list[str | None] = []
    rows, src, t_true = [], [], []
    for spec, tab in tables:
        if tab.obj is None or tab.source is None or tab.t_true is None:
            continue
        sid += [spec.sid] * tab.n_rows
        tid += [ids[k] if k >= 0 else None for k in tab.obj]
        rows.append(np.arange(tab.n_rows, dtype=np.int64))
        src += list(tab.source)
        t_true.append(tab.t_true)
    row = np.concatenate(rows)
    return {"sensor": text_column(sid), "row": row, "target_id": text_column(tid),
            "wild": np.zeros(row.size, dtype=np.int64), "source": text_column(src),
            "true_time": np.concatenate(t_true)}


def events_json(sc: HarbourScene, written: list[tuple[hs.Spec, dict[str, float]]]) -> str:
    """truth_events.json: objects (undeclared; role, hull, antenna lever arm, moving span),
    the quay departure, quays, the ferry and every sensor's generator and stated values."""
    w = sc.world
    objects = {}
    for h in w.hulls:
        moved = np.flatnonzero(np.any(h.path.pos != h.path.pos[0], axis=1))
        first = float(h.path.t[moved[0] - 1]) if moved.size else math.inf
        span = [max(first, w.t0), w.t0 + w.duration] if first < w.t0 + w.duration else None
        objects[h.oid] = {"declared": False, "role": h.role, "length_m": h.length,
                          "beam_m": h.beam, "antenna_lever_arm_m": list(h.lever),
                          "antenna_lever_arm_axes": "forward, starboard (body frame)",
                          "moving": span}
    sensors = {}
    for spec, sigma in written:
        d = _spec_dict(spec)
        if not isinstance(spec, hs.Ins):
            d["stated_sigma"] = {k: (math.degrees(v) if k == "azimuth" else v)
                                 for k, v in sigma.items()}
        sensors[spec.sid] = d
    f = w.ferry
    doc = {"kind": "harbour", "seed": sc.seed,
           "objects": objects,
           "events": [{"event": "quay_departure", "time": sc.departure, "objects": ["B2"],
                       "quay": "Q1"}],
           "quays": {q.qid: {"a": q.a.round(3).tolist(), "b": q.b.round(3).tolist(),
                             "water_normal": q.water.round(6).tolist(),
                             "scatterers": q.scatter.tolist(), "p_radar": q.p_radar.tolist(),
                             "p_lidar": q.p_lidar.tolist()} for q in w.quays},
           "ferry": {"north_up": f.north_up,
                     "roll_deg_period_s": [math.degrees(f.roll[0]), f.roll[1]],
                     "pitch_deg_period_s": [math.degrees(f.pitch[0]), f.pitch[1]],
                     "yaw_wobble_deg_period_s": [math.degrees(f.yaw_osc[0]), f.yaw_osc[1]]},
           "sensors": sensors,
           "units": "angles deg, distances m, times s, rates Hz"}
    return json.dumps(doc, indent=2) + "\n"


def _spec_dict(spec: hs.Spec) -> dict[str, Any]:
    """A sensor's generator parameters, angles in deg (for truth_events.json)."""
    if isinstance(spec, hs.Ins):
        return {"rate": spec.rate, "sigma_attitude": math.degrees(spec.attitude),
                "sigma_position": spec.position, "angle_unit": spec.unit}
    if isinstance(spec, hs.Camera):
        return {"rate": spec.rate, "lever_arm": list(spec.lever),
                "sigma_azimuth": math.degrees(spec.sigma), "rho": spec.rho, "pd": spec.pd,
                "r_max": spec.r_max, "false_per_frame": spec.false}
    return {"period": spec.period, "lever_arm": list(spec.lever),
            "sigma_range": spec.sigma["range"],
            "sigma_azimuth": math.degrees(spec.sigma["azimuth"]), "pd": spec.pd,
            "r_min": spec.r_min, "r_max": spec.r_max, "sea_clutter_per_scan": spec.sea,
            "metres_per_return": spec.per_return or None, "max_returns": spec.max_returns}


def simulate_harbour(out_dir: Path, *, seed: int, duration: float = 120.0,
                     n_objects: int | None = None, noise: bool = True) -> Path:
    """Write the harbour scene of ``seed`` into out_dir (module docstring); return the
    config path. noise=False: no measurement, AR(1) or INS noise (clutter, missed detections
    and the hull returns' spread over the visible sides are kept), for tests."""
    sc = draw_harbour(int(seed), float(duration), n_objects)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    streams = np.random.default_rng(int(seed)).spawn(3)[2].spawn(len(sc.sensors))
    tables = [(spec, hs.build(spec, sc.world, rng, noise))
              for spec, rng in zip(sc.sensors, streams)]
    tables = [(s, t) for s, t in tables if t.n_rows > 0]
    written = [(s, {} if isinstance(s, hs.Ins) else stated_sigma(s, t, sc.world))
               for s, t in tables]
    for spec, tab in tables:
        atomic_write_table(out_dir / spec.file, tab.cols)
        log.info("simulate: wrote %s (%d rows)", spec.file, tab.n_rows)
    atomic_write_table(out_dir / "truth.csv", truth_table(sc.world), truth=True)
    atomic_write_table(out_dir / TRUTH_PLATFORM, platform_truth(sc.world), truth=True)
    atomic_write_table(out_dir / TRUTH_ASSOCIATION,
                       association_table(sc, [(s, t) for s, t in tables
                                              if not isinstance(s, hs.Ins)]))
    atomic_write_text(out_dir / TRUTH_EVENTS, events_json(sc, written))
    cfg = out_dir / "scenario.toml"
    atomic_write_text(cfg, config_text(sc, written))
    return cfg
