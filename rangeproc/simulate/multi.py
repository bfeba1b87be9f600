"""Multi-object scenarios with truth: several aircraft, tracks that jump, plots and clutter.

``simulate_multi(out_dir, kind=..., seed=...)`` writes a run directory to the data contract
(section 2, several objects): sensor files whose radar/theodolite rows interleave several
objects (and clutter) in time, ``scenario.toml`` (contract keys only; ``[[targets]]`` are the
GPS carriers T1, T2, ...; objects without GPS, U1, U2, ..., are not declared: the processor
must discover them), ``truth.csv`` (every object, 100 Hz), ``truth_association.csv`` (per
radar/theodolite row: the true object, empty for clutter; ``wild`` = 1 where a wild error was
injected) and ``truth_events.json`` (crossings, splits, lock jumps, operator switches).

Kinds (object counts): ``crossing`` (2-3) aircraft crossing within a few hundred metres;
``formation`` (2-4) 100-300 m apart, splitting mid-flight; ``lock-jump`` (2-3) a radar track
that jumps to another object at a close pass; ``operator-switch`` (2-3) a theodolite operator
moving to another object; ``surveillance`` (3-5) a rotating radar's plots with clutter;
``phased-array`` (3-5) the plots of a phased-array radar PA1 that looks at each object every
2 s on the object's own schedule (random phase, +-10 % jitter), so its rows jump between
objects in no azimuth order, with clutter at random times; ``merged-feed`` (3-5) one plot
file PF1 merging two rotating radars at different sites (a scan every 4 s and every 5 s),
converted to the first radar's site, so the azimuths of a scan are not monotonic;
``mixed`` (2-5) a close pass, a split, a lock jump, an operator switch and SR1 at once,
with a ship radar and MISTRAM; ``scale`` (5-20, 10 unless ``n_objects`` is given) the
several-objects benchmark scenario (``make bench``; run it with ``duration=1800``): the
surveillance radar SR1 (a scan every 4 s, 20 clutter plots per scan), three fixed tracking
radars R1, R2, R3, each with two tracks at a time that may be handed over to another object
mid-flight (so each radar follows 2-4 objects), and GPS on exactly four objects (T1..T4; the
others U1.. are undeclared); ``harbour`` (3-4) a ferry's scanning radar, lidar and cameras
among a boat, a ship leaving a quay and moored boats with extended hulls, quays and sea
clutter, written like the Autoferry recordings (:mod:`rangeproc.simulate.harbour`: no GPS,
no R1, sensors on the ferry's INS platform; its own truth columns and files).

Every kind but ``harbour`` has GPS on some objects only, a fixed tracking radar R1 (20 Hz per
track, with track_id), missed detections, noise, wild points and empty cells as in the single-object
scenario, and one sensor with a known latency (``time_offset``). Randomness:
``default_rng(seed).spawn(3)``: geometry, flights (one stream per object), sensors (one stream
per sensor in config order). Even seeds stamp GPS in ISO-8601 (all times Unix seconds).
"""
from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rangeproc.errors import ConfigError
from rangeproc.simulate import multi_sensors as ms
from rangeproc.simulate import sensors as sn
from rangeproc.simulate.flights import (crossing_flights, event_time, formation_flights,
                                        pass_near)
from rangeproc.simulate.multi_files import (TRUTH_ASSOCIATION, TRUTH_EVENTS, MultiScenario,
                                             association_table, config_text, events_json,
                                             truth_table)
from rangeproc.simulate.files import atomic_write_table, atomic_write_text
from rangeproc.simulate.harbour import simulate_harbour
from rangeproc.simulate.scenario import (_ARCSEC, _ISO_EPOCH, _MRAD, LATENCY, _geo_at, _polar,
                                         _r, draw_ship)
from rangeproc.simulate.trajectory import Trajectory, plan_trajectory

log = logging.getLogger(__name__)

#: kind -> (fewest, most) objects
KINDS: dict[str, tuple[int, int]] = {
    "crossing": (2, 3), "formation": (2, 4), "lock-jump": (2, 3), "operator-switch": (2, 3),
    "surveillance": (3, 5), "phased-array": (3, 5), "merged-feed": (3, 5), "mixed": (2, 5),
    "scale": (5, 20), "harbour": (3, 4)}
#: kind -> object count when ``n_objects`` is not given (other kinds: drawn within KINDS)
DEFAULT_OBJECTS: dict[str, int] = {"scale": 10}
SCALE_GPS = 4  #: objects carrying GPS in kind ``scale``
SCALE_RADARS, SCALE_TRACKS = ("R1", "R2", "R3"), 2  #: its tracking radars, tracks per radar
MIN_DURATION = 30.0  #: s


@dataclass(frozen=True, slots=True)
class Draw:
    """What a kind's drawer gets: the geometry generator, one generator per object, the range
    origin, trajectory start t0 (s), flight duration (s) and the seed."""

    g: np.random.Generator
    rngs: list[np.random.Generator]
    origin: sn.Geo
    t0: float
    duration: float
    seed: int

    @property
    def span(self) -> float:
        """Trajectory span (s): the flight plus a margin for interpolation."""
        return self.duration + 0.5

    @property
    def end(self) -> float:
        """Range time (s) after the last sample: a track's end."""
        return self.t0 + self.duration + 1.0

    def at(self, lo: float, hi: float) -> float:
        """A range time (s) drawn lo..hi of the way into the flight."""
        return self.t0 + float(self.g.uniform(lo, hi)) * self.duration


@dataclass(frozen=True, slots=True)
class Layout:
    """A kind's drawing: trajectories (index = object), the sensors that see objects, events
    (object indices under ``objects``) and the objects that must carry GPS; ``gps_only``: the
    GPS carriers exactly (None: ``gps_must`` plus others drawn by :func:`gps_carriers`)."""

    flights: list[Trajectory]
    sensors: list[ms.Sensor]
    events: list[dict[str, Any]]
    gps_must: tuple[int, ...] = ()
    gps_only: tuple[int, ...] | None = None


# --------------------------------------------------------------------------------------------
# Sensor drawing
# --------------------------------------------------------------------------------------------

def _single(start: float, end: float, obj: int, track_id: int) -> ms.TrackPlan:
    return ms.TrackPlan((ms.Piece(start, end, obj, track_id),))


def tracking_radar(d: Draw, tracks: list[ms.TrackPlan], sid: str = "R1") -> ms.SiteSensor:
    """R1 (or ``sid``): fixed tracking radar 1.5-6 km from the origin, 20 Hz per track, range
    5-10 m, angles 0.2-1 mrad, range rate (0.05-0.2 m/s) on half the scenarios."""
    g = d.g
    site = _geo_at(d.origin, *_polar(g, 1.5e3, 6e3), d.origin.height + g.uniform(-30, 300))
    sigma = {"range": _r(g.uniform(5, 10)), "azimuth": _r(g.uniform(0.2, 1) * _MRAD, 6),
             "elevation": _r(g.uniform(0.2, 1) * _MRAD, 6)}
    if g.random() < 0.5:
        sigma["range_rate"] = _r(g.uniform(0.05, 0.2), 3)
    return ms.SiteSensor(sid, "radar", f"{sid}.csv", site, sigma, "deg", 20.0, tuple(tracks),
                         wild_fraction=float(g.uniform(0.005, 0.01)),
                         n_missing=int(g.integers(3, 15)))


def theodolite(d: Draw, near: np.ndarray, tracks: list[ms.TrackPlan]) -> ms.SiteSensor:
    """TH1: theodolite 4-10 km (horizontally) from ``near`` (3,) range ENU m, 10 or 20 Hz,
    10-20 arcsec, a 2-3 m laser range on half the scenarios; angle unit by seed."""
    g = d.g
    de, dn = _polar(g, 4e3, 10e3)
    site = _geo_at(d.origin, near[0] + de, near[1] + dn, d.origin.height + g.uniform(-30, 300))
    sigma = {"azimuth": _r(g.uniform(10, 20), 1) * _ARCSEC,
             "elevation": _r(g.uniform(10, 20), 1) * _ARCSEC}
    if g.random() < 0.5:
        sigma["range"] = _r(g.uniform(2, 3))
    return ms.SiteSensor("TH1", "theodolite", "TH1.parquet", site, sigma,
                         ("mil", "deg", "rad")[d.seed % 3], float(g.choice([10.0, 20.0])),
                         tuple(tracks), wild_fraction=float(g.uniform(0.005, 0.01)))


def surveillance_radar(d: Draw, sid: str = "SR1", *, period: float = 4.0,
                       around: sn.Geo | None = None,
                       distance: tuple[float, float] = (0.5e3, 3e3)) -> ms.Surveillance:
    """SR1 (or ``sid``): rotating surveillance radar ``distance`` (m, (lo, hi); default
    0.5-3 km) from the origin (or from ``around``) on a 5-40 m mast, a scan every ``period``
    s at a random phase; range 20-60 m, azimuth 1.5-3 mrad, elevation 3-6 mrad."""
    g = d.g
    site = _geo_at(around or d.origin, *_polar(g, *distance),
                   d.origin.height + g.uniform(5, 40))
    sigma = {"range": _r(g.uniform(20, 60)), "azimuth": _r(g.uniform(1.5, 3) * _MRAD, 6),
             "elevation": _r(g.uniform(3, 6) * _MRAD, 6)}
    return ms.Surveillance(sid, f"{sid}.csv", site, sigma, phase=float(g.uniform(0, period)),
                           period=period)


def phased_array_radar(d: Draw) -> ms.PhasedArray:
    """PA1: phased-array surveillance radar 0.5-3 km from the origin on a 5-40 m mast; each
    object revisited every 2 s (its own random phase, +-10 % jitter), Pd 0.9, 10 clutter
    plots per revisit period; range 10-30 m, azimuth 1-2 mrad, elevation 1.5-3 mrad."""
    g = d.g
    site = _geo_at(d.origin, *_polar(g, 0.5e3, 3e3), d.origin.height + g.uniform(5, 40))
    sigma = {"range": _r(g.uniform(10, 30)), "azimuth": _r(g.uniform(1, 2) * _MRAD, 6),
             "elevation": _r(g.uniform(1.5, 3) * _MRAD, 6)}
    return ms.PhasedArray("PA1", "PA1.csv", site, sigma, revisit=2.0, jitter=0.1, pd=0.9,
                          clutter=10.0)


def merged_feed(d: Draw) -> ms.MergedFeed:
    """PF1: one plot feed of two rotating surveillance radars drawn as SR1: A 0.5-3 km from
    the origin, a scan every 4 s, and B 3-8 km from A, a scan every 5 s, each at its own random
    phase with its own sigmas and 20 clutter plots per scan. The feed's declared site is A's
    (every plot is converted to it), its declared sigmas the larger of A's and B's per
    component (each radar's plots carry its own noise, see :class:`MergedFeed`)."""
    a = surveillance_radar(d, "PF1A", period=4.0)
    b = surveillance_radar(d, "PF1B", period=5.0, around=a.site, distance=(3e3, 8e3))
    sigma = {k: max(a.sigma[k], b.sigma[k]) for k in a.sigma}
    return ms.MergedFeed("PF1", "PF1.csv", a.site, sigma, (a, b))


def track_base(d: Draw) -> int:
    """First track number of a sensor (later tracks count up from it)."""
    return int(d.g.integers(1, 90))


def switch_plan(d: Draw, first: int, second: int, t_switch: float, *, gap: tuple[float, float]
                ) -> ms.TrackPlan:
    """A track on ``first`` until ``t_switch`` (s), then, after a gap of ``gap`` (s, (lo, hi);
    (0, 0) = a lock jump), on ``second``; the same track_id or (operator, half the time) the
    next one."""
    tid = track_base(d)
    slew = float(d.g.uniform(*gap)) if gap[1] > 0 else 0.0
    new = tid + 1 if slew > 0 and d.g.random() < 0.5 else tid
    return ms.TrackPlan((ms.Piece(d.at(0.0, 0.1), t_switch, first, tid),
                         ms.Piece(t_switch + slew, d.end, second, new)))


# --------------------------------------------------------------------------------------------
# Kinds
# --------------------------------------------------------------------------------------------

def _crossing(d: Draw, n: int) -> Layout:
    tau = event_time(d.g, d.duration)
    flights, point = crossing_flights(d.g, d.rngs, d.t0, d.span, tau=tau, miss=(150.0, 400.0),
                                      spread=(45.0, 135.0))
    base = track_base(d)
    r1 = tracking_radar(d, [_single(d.at(0.0, 0.1 if k == 0 else 0.25), d.end, k, base + k)
                            for k in range(n)])
    th = theodolite(d, point, [_single(d.at(0.05, 0.2), d.end, int(d.g.integers(n)),
                                       track_base(d))])
    return Layout(flights, [r1, th], [{"event": "crossing", "time": d.t0 + tau,
                                       "objects": list(range(n))}])


def _formation(d: Draw, n: int) -> Layout:
    tau = event_time(d.g, d.duration)
    flights = formation_flights(d.g, d.rngs, d.t0, d.span, tau=tau)
    base = track_base(d)
    split = d.t0 + tau
    r1 = tracking_radar(d, [_single(d.at(0.0, 0.1), d.end, 0, base),
                            _single(split + d.g.uniform(3.0, 10.0), d.end, 1, base + 1)])
    lead = flights[0].state(np.array([split]))[0][0]
    th = theodolite(d, lead, [_single(d.at(0.05, 0.2), d.end, 0, track_base(d))])
    return Layout(flights, [r1, th], [{"event": "split", "time": split,
                                       "objects": list(range(n))}])


def _close_pair(d: Draw) -> tuple[list[Trajectory], np.ndarray, float]:
    """Objects 0 and 1 passing 80-200 m apart at 20-50 deg: flights, pass point, time (s)."""
    tau = event_time(d.g, d.duration)
    flights, point = crossing_flights(d.g, d.rngs[:2], d.t0, d.span, tau=tau,
                                      miss=(80.0, 200.0), spread=(20.0, 50.0))
    return flights, point, d.t0 + tau


def _lock_jump(d: Draw, n: int) -> Layout:
    flights, point, t_pass = _close_pair(d)
    flights += [plan_trajectory(r, d.span, d.t0) for r in d.rngs[2:]]
    t_jump = t_pass + float(d.g.uniform(-1.0, 1.0))
    plan = switch_plan(d, 0, 1, t_jump, gap=(0.0, 0.0))
    back = t_jump + float(d.g.uniform(10.0, 25.0))
    if d.g.random() < 0.5 and back < d.t0 + d.duration - 10.0:  # re-acquired by the operator
        tid = plan.pieces[0].track_id
        p0, p1 = plan.pieces
        plan = ms.TrackPlan((p0, dataclasses.replace(p1, end=back),
                             ms.Piece(back + float(d.g.uniform(1.0, 3.0)), d.end, 0, tid)))
    tracks = [plan] + [_single(d.at(0.0, 0.2), d.end, k, plan.pieces[0].track_id + k)
                       for k in range(2, n)]
    th = theodolite(d, point, [_single(d.at(0.05, 0.2), d.end, 1, track_base(d))])
    return Layout(flights, [tracking_radar(d, tracks), th],
                  [{"event": "close_pass", "time": t_pass, "objects": [0, 1]}], gps_must=(0,))


def _operator_switch(d: Draw, n: int) -> Layout:
    tau = event_time(d.g, d.duration)
    a = plan_trajectory(d.rngs[0], d.span, d.t0)
    b = pass_near(d.g, d.rngs[1], d.t0, d.span, other=a, tau=tau, distance=(2e3, 5e3))
    flights = [a, b] + [plan_trajectory(r, d.span, d.t0) for r in d.rngs[2:]]
    t_s = d.t0 + tau
    mid = 0.5 * (a.state(np.array([t_s]))[0][0] + b.state(np.array([t_s]))[0][0])
    th = theodolite(d, mid, [switch_plan(d, 0, 1, t_s, gap=(1.0, 5.0))])
    base = track_base(d)
    r1 = tracking_radar(d, [_single(d.at(0.0, 0.3), d.end, k, base + k) for k in range(n)])
    return Layout(flights, [r1, th], [])


def _surveillance(d: Draw, n: int) -> Layout:
    return _plots(d, n, surveillance_radar)


def _phased_array(d: Draw, n: int) -> Layout:
    return _plots(d, n, phased_array_radar)


def _merged_feed(d: Draw, n: int) -> Layout:
    return _plots(d, n, merged_feed)


def _plots(d: Draw, n: int, plot_sensor: Callable[[Draw], ms.Sensor]) -> Layout:
    """n independent flights, the plot sensor (drawn by ``plot_sensor``) that sees them all
    and R1 tracking one or two of them."""
    flights = [plan_trajectory(r, d.span, d.t0) for r in d.rngs]
    sr = plot_sensor(d)
    seen = sorted(int(k) for k in d.g.choice(n, size=int(d.g.integers(1, 3)), replace=False))
    base = track_base(d)
    r1 = tracking_radar(d, [_single(d.at(0.0, 0.2), d.end, k, base + i)
                            for i, k in enumerate(seen)])
    return Layout(flights, [r1, sr], [])


def _mixed(d: Draw, n: int) -> Layout:
    flights, point, t_pass = _close_pair(d)
    events: list[dict[str, Any]] = [{"event": "close_pass", "time": t_pass, "objects": [0, 1]}]
    if n >= 4:
        tau = event_time(d.g, d.duration)
        flights += formation_flights(d.g, d.rngs[2:4], d.t0, d.span, tau=tau)
        events.append({"event": "split", "time": d.t0 + tau, "objects": [2, 3]})
    flights += [plan_trajectory(r, d.span, d.t0) for r in d.rngs[len(flights):]]
    jump = switch_plan(d, 0, 1, t_pass + float(d.g.uniform(-1.0, 1.0)), gap=(0.0, 0.0))
    tracks = [jump] + ([_single(d.at(0.0, 0.2), d.end, 2, jump.pieces[0].track_id + 1)]
                       if n >= 3 else [])
    t_s = min(t_pass + float(d.g.uniform(8.0, 20.0)), d.t0 + 0.85 * d.duration)
    th = theodolite(d, point, [switch_plan(d, 1, 0, t_s, gap=(1.0, 5.0))])
    sensors: list[ms.Sensor] = [tracking_radar(d, tracks), surveillance_radar(d), th]
    sensors += ship_sensors(d, n - 1)
    return Layout(flights, sensors, events)


def _scale(d: Draw, n: int) -> Layout:
    """The several-objects benchmark scenario: n independent flights, SR1, then R1..R3 (see
    :func:`handover_tracks`), then exactly ``SCALE_GPS`` GPS carriers."""
    flights = [plan_trajectory(r, d.span, d.t0) for r in d.rngs]
    sensors: list[ms.Sensor] = [surveillance_radar(d)]
    sensors += [tracking_radar(d, handover_tracks(d, n), sid) for sid in SCALE_RADARS]
    carriers = tuple(sorted(int(k) for k in d.g.choice(n, size=SCALE_GPS, replace=False)))
    return Layout(flights, sensors, [], gps_only=carriers)


def handover_tracks(d: Draw, n: int) -> list[ms.TrackPlan]:
    """``SCALE_TRACKS`` tracks of one radar on distinct objects (of n >= 2 SCALE_TRACKS),
    from early in the flight to its end. Track 0 is always handed over, the others half the
    time: at 30-70 % of the flight, after a 1-5 s slew, the track moves to an object the radar
    has not followed, under the next track_id or (half the time) the same one."""
    objs = [int(k) for k in d.g.choice(n, size=2 * SCALE_TRACKS, replace=False)]
    base = track_base(d)
    plans = []
    for c in range(SCALE_TRACKS):
        tid = base + 2 * c
        start = d.at(0.0, 0.05)
        if c == 0 or d.g.random() < 0.5:
            t_h = d.at(0.3, 0.7)
            slew = float(d.g.uniform(1.0, 5.0))
            new = tid + 1 if d.g.random() < 0.5 else tid
            plans.append(ms.TrackPlan((ms.Piece(start, t_h, objs[2 * c], tid),
                                       ms.Piece(t_h + slew, d.end, objs[2 * c + 1], new))))
        else:
            plans.append(_single(start, d.end, objs[2 * c], tid))
    return plans


def ship_sensors(d: Draw, obj: int) -> list[ms.Sensor]:
    """S1 (ship radar, 10 Hz, one track on ``obj``) and its SHIP_INS (50 Hz)."""
    g = d.g
    ship = draw_ship(g, d.origin, d.duration, north=False)
    lever = (_r(g.uniform(5, 20)), _r(g.uniform(-3, 3)), _r(g.uniform(-25, -10)))
    sigma = {"range": _r(g.uniform(5, 10)), "azimuth": _r(g.uniform(0.3, 1) * _MRAD, 6),
             "elevation": _r(g.uniform(0.3, 1) * _MRAD, 6)}
    s1 = ms.ShipRadar("S1", "S1.csv", ship, lever, sigma, 10.0,
                      (_single(d.at(0.0, 0.2), d.end, obj, track_base(d)),),
                      wild_fraction=float(g.uniform(0.005, 0.01)),
                      n_missing=int(g.integers(3, 15)))
    ins = ms.ShipIns("SHIP_INS", "SHIP_INS.csv", ship,
                     {"attitude": math.radians(0.005), "position": 0.1, "velocity": 0.02})
    return [s1, ins]


DRAWERS: dict[str, Callable[[Draw, int], Layout]] = {
    "crossing": _crossing, "formation": _formation, "lock-jump": _lock_jump,
    "operator-switch": _operator_switch, "surveillance": _surveillance,
    "phased-array": _phased_array, "merged-feed": _merged_feed, "mixed": _mixed,
    "scale": _scale}


# --------------------------------------------------------------------------------------------
# Scenario
# --------------------------------------------------------------------------------------------

def check_request(kind: str, duration: float, n_objects: int | None) -> None:
    """ConfigError naming the argument unless kind, duration (s) and n_objects are valid."""
    if kind not in KINDS:
        raise ConfigError(f"simulate: objects={kind!r}: unknown kind; choose from "
                          f"{', '.join(KINDS)}")
    if not duration >= MIN_DURATION or not math.isfinite(duration):
        raise ConfigError(f"simulate: duration={duration!r}: must be a number >= "
                          f"{MIN_DURATION:g} s with several objects")
    lo, hi = KINDS[kind]
    if n_objects is not None and (isinstance(n_objects, bool) or n_objects not in
                                  range(lo, hi + 1)):
        raise ConfigError(f"simulate: n_objects={n_objects!r}: kind {kind!r} has {lo}-{hi} "
                          "objects")


def draw_multi(kind: str, seed: int, duration: float, n_objects: int | None = None
               ) -> MultiScenario:
    """Draw scenario ``kind`` for ``seed``: objects, their ids, sensors and events (not
    ``harbour``: :func:`rangeproc.simulate.harbour.draw_harbour` draws that scene)."""
    check_request(kind, duration, n_objects)
    if kind not in DRAWERS:
        raise ConfigError(f"simulate: objects={kind!r}: drawn by its own module "
                          "(rangeproc.simulate.harbour.draw_harbour)")
    g, g_flights, _ = np.random.default_rng(seed).spawn(3)
    origin = sn.Geo(round(float((1.0 if g.random() < 0.5 else -1.0) * g.uniform(20, 60)), 6),
                    round(float(g.uniform(-180, 180)), 6), round(float(g.uniform(0, 300)), 1))
    iso = seed % 2 == 0
    t0 = round(float((_ISO_EPOCH if iso else 345600.0) + g.uniform(0, 7200)), 2)
    lo, hi = KINDS[kind]
    if n_objects is not None:
        n = int(n_objects)
    else:
        n = DEFAULT_OBJECTS[kind] if kind in DEFAULT_OBJECTS else int(g.integers(lo, hi + 1))
    d = Draw(g, g_flights.spawn(n), origin, t0, float(duration), int(seed))
    layout = DRAWERS[kind](d, n)
    carriers = (list(layout.gps_only) if layout.gps_only is not None
                else gps_carriers(g, n, layout.gps_must))
    ids = object_ids(n, carriers)
    sensors = track_unseen(d, list(layout.sensors), carriers, n)
    sensors += [gps_receiver(d, f"G{i + 1}", k) for i, k in enumerate(carriers)]
    if kind == "mixed":
        sensors.append(mistram(d, carriers[0]))
    sensors = with_latency(g, sensors)
    world = ms.World(origin, tuple(layout.flights), t0, float(duration), iso)
    events = layout.events + track_events(sensors)
    return MultiScenario(kind, int(seed), world, ids, tuple(sensors),
                         tuple(sorted(events, key=lambda e: e["time"])))


def gps_carriers(g: np.random.Generator, n: int, must: tuple[int, ...]) -> list[int]:
    """Objects carrying GPS (sorted): ``must`` plus random others, 1..n-1 in all."""
    count = max(int(g.integers(1, n)), len(must))
    others = [k for k in range(n) if k not in must]
    extra = g.choice(others, size=count - len(must), replace=False) if count > len(must) else []
    return sorted(set(must) | {int(k) for k in extra})


def track_unseen(d: Draw, sensors: list[ms.Sensor], carriers: list[int], n: int
                 ) -> list[ms.Sensor]:
    """The sensors, R1 given one more track on each object that nothing would see (no GPS,
    no track of any sensor, no plot sensor), so that every object is in the data."""
    if any(isinstance(s, ms.PLOT_SENSORS) for s in sensors):
        return sensors
    seen = set(carriers) | {pc.obj for s in sensors for plan in getattr(s, "tracks", ())
                            for pc in plan.pieces}
    i = next(i for i, s in enumerate(sensors) if s.sid == "R1")
    r1 = sensors[i]
    assert isinstance(r1, ms.SiteSensor)
    tid = max(pc.track_id for plan in r1.tracks for pc in plan.pieces)
    extra = tuple(_single(d.at(0.0, 0.3), d.end, k, tid + 1 + j)
                  for j, k in enumerate(k for k in range(n) if k not in seen))
    out = list(sensors)
    out[i] = dataclasses.replace(r1, tracks=r1.tracks + extra)
    return out


def object_ids(n: int, carriers: list[int]) -> tuple[str, ...]:
    """Object ids: T1, T2, ... for the GPS carriers (declared), U1, U2, ... for the others."""
    t_ids = {k: f"T{i + 1}" for i, k in enumerate(carriers)}
    u_ids = {k: f"U{i + 1}" for i, k in enumerate(k for k in range(n) if k not in t_ids)}
    return tuple(t_ids.get(k) or u_ids[k] for k in range(n))


def gps_receiver(d: Draw, sid: str, obj: int) -> ms.GpsReceiver:
    """GPS on object ``obj``: 10 Hz, 1-2 dropouts of 5-20 s, a x10 noise burst of 8-12 s."""
    g = d.g
    sigma = {"horizontal": _r(g.uniform(2, 4)), "vertical": _r(g.uniform(3, 5)),
             "velocity": _r(g.uniform(0.05, 0.15), 3)}
    drop = tuple((s, s + float(g.uniform(5, 20)))
                 for s in d.t0 + g.uniform(0.1, 0.9, int(g.integers(1, 3))) * d.duration)
    b0 = d.at(0.1, 0.9)
    return ms.GpsReceiver(sid, f"{sid}.csv", obj, sigma, drop, (b0, b0 + float(g.uniform(8, 12))))


def mistram(d: Draw, obj: int) -> ms.Mistram:
    """MISTRAM on object ``obj``: 4-8 stations 5-40 km from the origin, 20 Hz."""
    g = d.g
    n_st = int(g.integers(4, 9))
    angles = 2 * math.pi * (np.arange(n_st) + g.uniform(-0.3, 0.3, n_st)) / n_st
    dists = g.uniform(5e3, 40e3, n_st)
    stations = tuple((f"M{i + 1}", _geo_at(d.origin, r * math.sin(a), r * math.cos(a),
                                           d.origin.height + g.uniform(-20, 150)))
                     for i, (a, r) in enumerate(zip(angles, dists)))
    return ms.Mistram("MISTRAM", "MISTRAM.csv", obj, stations, _r(g.uniform(0.03, 0.1), 3))


def with_latency(g: np.random.Generator, sensors: list[ms.Sensor]) -> list[ms.Sensor]:
    """The sensors, one of them (not the INS) given the known latency ``time_offset``."""
    able = [i for i, s in enumerate(sensors) if not isinstance(s, ms.ShipIns)]
    i = able[int(g.integers(len(able)))]
    out = list(sensors)
    out[i] = dataclasses.replace(sensors[i], offset=LATENCY)  # type: ignore[arg-type]
    return out


def track_events(sensors: list[ms.Sensor]) -> list[dict[str, Any]]:
    """A ``track_change`` event wherever a track moves to another object: a lock jump (gap 0)
    or an operator re-acquiring (gap > 0), with the track ids before and after."""
    out: list[dict[str, Any]] = []
    for s in sensors:
        for plan in getattr(s, "tracks", ()):
            for a, b in zip(plan.pieces[:-1], plan.pieces[1:]):
                if a.obj != b.obj:
                    out.append({"event": "track_change", "time": b.start, "sensor": s.sid,
                                "gap": b.start - a.end, "from": a.obj, "to": b.obj,
                                "track_id_from": a.track_id, "track_id_to": b.track_id})
    return out


def simulate_multi(out_dir: Path, *, kind: str, seed: int, duration: float = 120.0,
                   n_objects: int | None = None, noise: bool = True) -> Path:
    """Write multi-object scenario ``kind`` (see :data:`KINDS`) into out_dir; return the config.

    duration: seconds of flight (>= 30). n_objects: how many objects (default: drawn within
    the kind's range; kind ``scale``: 10). noise=False writes exact measurements (no noise,
    wild points, empty cells or clutter-free changes: clutter, missed detections and gaps are
    kept) for tests.
    Writes the sensor files, scenario.toml, truth.csv, truth_association.csv and
    truth_events.json. A sensor that sees nothing (no rows) is left out. Kind ``harbour``:
    :func:`rangeproc.simulate.harbour.simulate_harbour` (also truth_platform.csv).
    """
    if kind == "harbour":
        check_request(kind, duration, n_objects)
        return simulate_harbour(Path(out_dir), seed=int(seed), duration=float(duration),
                                n_objects=n_objects, noise=noise)
    sc = draw_multi(kind, int(seed), float(duration), n_objects)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    streams = np.random.default_rng(int(seed)).spawn(3)[2].spawn(len(sc.sensors))
    tables = [(spec, ms.build(spec, sc.world, rng, noise)) for spec, rng in
              zip(sc.sensors, streams)]
    tables = [(spec, tab) for spec, tab in tables if tab.n_rows > 0]
    if any(isinstance(s, ms.ShipRadar) for s, _ in tables) and not any(
            isinstance(s, ms.ShipIns) for s, _ in tables):  # pragma: no cover (INS: always)
        tables = [(s, t) for s, t in tables if not isinstance(s, ms.ShipRadar)]
    for spec, tab in tables:
        atomic_write_table(out_dir / spec.file, tab.cols)
        log.info("simulate: wrote %s (%d rows)", spec.file, tab.n_rows)
    atomic_write_table(out_dir / "truth.csv", truth_table(sc), truth=True)
    atomic_write_table(out_dir / TRUTH_ASSOCIATION, association_table(sc, tables))
    atomic_write_text(out_dir / TRUTH_EVENTS, events_json(sc))
    cfg = out_dir / "scenario.toml"
    atomic_write_text(cfg, config_text(sc, [spec for spec, _ in tables]))
    return cfg


__all__ = ["KINDS", "TRUTH_ASSOCIATION", "TRUTH_EVENTS", "MultiScenario", "draw_multi",
           "simulate_multi"]
