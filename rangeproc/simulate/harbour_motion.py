"""Motion and hull geometry of the harbour kind: boats, a ship leaving a quay, moored boats,
quays and the ferry's track, all on the sea surface (2-D, range ENU east/north, up = 0).

A :class:`SurfacePath` is a track integrated at ``DT`` s from speed and turn-rate legs
(:func:`steer`): heading = course (no crab angle), speed changed at a limited acceleration,
turns at a constant rate. A :class:`Hull` is a rectangle ``length`` x ``beam`` (m) centred on
the path, its long axis along the heading, with the GNSS antenna at ``lever`` (forward,
starboard; m, body frame) from the centre. Headings are radians clockwise from north; the
forward unit vector is (sin psi, cos psi) and the starboard one (cos psi, -sin psi) in
(east, north).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DT = 0.05  #: integration step of every path (s)


@dataclass(frozen=True, slots=True)
class SurfacePath:
    """A track sampled every ``DT`` s: times t (N,) s, centre pos (N, 2) east/north m,
    heading psi (N,) rad (unwrapped), speed (N,) m/s, turn rate omega (N,) rad/s."""

    t: np.ndarray
    pos: np.ndarray
    psi: np.ndarray
    speed: np.ndarray
    omega: np.ndarray

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Centre (M, 2) m, velocity (M, 2) m/s, heading (M,) rad and turn rate (M,) rad/s at
        times t (M,) s (linear interpolation; clamped to the sampled span)."""
        t = np.asarray(t, dtype=float)
        pos = np.column_stack([np.interp(t, self.t, self.pos[:, i]) for i in range(2)])
        psi = np.interp(t, self.t, self.psi)
        v = np.interp(t, self.t, self.speed)
        vel = np.column_stack((v * np.sin(psi), v * np.cos(psi)))
        return pos, vel, psi, np.interp(t, self.t, self.omega)


def still_path(t0: float, t1: float, pos: np.ndarray, psi: float) -> SurfacePath:
    """A path that never moves: centre ``pos`` (2,) m, heading ``psi`` rad, over [t0, t1] s."""
    t = np.array([t0, t1], dtype=float)
    return SurfacePath(t, np.tile(np.asarray(pos, float), (2, 1)), np.full(2, psi),
                       np.zeros(2), np.zeros(2))


@dataclass(frozen=True, slots=True)
class Manoeuvres:
    """Random legs of :func:`steer`: straight legs of ``leg`` s, then a turn of ``turn`` deg
    at ``turn_rate`` deg/s (each (lo, hi), drawn uniformly), a new target speed from
    ``speed`` m/s per leg reached at ``accel`` m/s^2. Beyond ``keep_in`` m from ``centre``
    (2,) m the next turn heads back towards the centre (+-30 deg)."""

    speed: tuple[float, float]
    accel: float
    turn_rate: tuple[float, float]
    turn: tuple[float, float]
    leg: tuple[float, float]
    centre: tuple[float, float]
    keep_in: float


@dataclass(frozen=True, slots=True)
class Leg:
    """A scripted leg: ``duration`` s at turn rate ``omega`` rad/s towards speed ``speed``."""

    duration: float
    omega: float
    speed: float


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _next_leg(rng: np.random.Generator, m: Manoeuvres, p: np.ndarray, psi: float,
              turning: bool) -> Leg:
    """After a turn a straight leg; after a straight leg a turn (towards the centre when
    beyond ``keep_in``, else either way)."""
    speed = float(rng.uniform(*m.speed))
    if turning:
        return Leg(float(rng.uniform(*m.leg)), 0.0, speed)
    rate = math.radians(float(rng.uniform(*m.turn_rate)))
    d = np.asarray(m.centre) - p
    if float(np.hypot(*d)) > m.keep_in:
        want = _wrap(math.atan2(d[0], d[1]) - psi + math.radians(float(rng.uniform(-30, 30))))
        angle = max(abs(want), math.radians(20.0))
        sign = 1.0 if want >= 0 else -1.0
    else:
        angle = math.radians(float(rng.uniform(*m.turn)))
        sign = 1.0 if rng.random() < 0.5 else -1.0
    return Leg(angle / rate, sign * rate, speed)


def steer(rng: np.random.Generator, t0: float, t1: float, p0: np.ndarray, psi0: float,
          v0: float, m: Manoeuvres, script: tuple[Leg, ...] = ()) -> SurfacePath:
    """Integrate a track over [t0, t1] s every ``DT`` s from centre ``p0`` (2,) m, heading
    ``psi0`` rad and speed ``v0`` m/s: first the ``script`` legs in order, then random legs
    (:class:`Manoeuvres`). Speed moves towards each leg's target at ``m.accel`` m/s^2;
    position advances by the mean of the step's start and end velocities."""
    n = int(math.ceil((t1 - t0) / DT)) + 1
    t = t0 + DT * np.arange(n)
    pos = np.zeros((n, 2))
    psi, speed, omega = np.zeros(n), np.zeros(n), np.zeros(n)
    p, h, v = np.asarray(p0, float).copy(), float(psi0), float(v0)
    queue = list(script)
    leg = queue.pop(0) if queue else _next_leg(rng, m, p, h, turning=True)
    left, turning = leg.duration, leg.omega != 0.0
    for i in range(n):
        pos[i], psi[i], speed[i], omega[i] = p, h, v, leg.omega
        v_new = v + float(np.clip(leg.speed - v, -m.accel * DT, m.accel * DT))
        h_new = h + leg.omega * DT
        p = p + 0.5 * DT * (v * np.array([math.sin(h), math.cos(h)])
                            + v_new * np.array([math.sin(h_new), math.cos(h_new)]))
        h, v = h_new, v_new
        left -= DT
        if left <= 1e-9:
            if queue:
                leg = queue.pop(0)
            else:
                leg = _next_leg(rng, m, p, h, turning)
            left, turning = leg.duration, leg.omega != 0.0
    return SurfacePath(t, pos, psi, speed, omega)


@dataclass(frozen=True, slots=True)
class Hull:
    """An object's hull: ``length`` x ``beam`` m, GNSS antenna at ``lever`` = (forward,
    starboard) m from the centre (body frame), its ``path``; ``oid`` its truth id and
    ``role`` (boat, ship, moored)."""

    oid: str
    role: str
    length: float
    beam: float
    lever: tuple[float, float]
    path: SurfacePath

    def antenna(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Antenna position (M, 2) m and velocity (M, 2) m/s at times t (M,) s: centre +
        R(psi) lever, velocity + omega x (R(psi) lever)."""
        c, v, psi, om = self.path.state(t)
        off = body_to_enu(psi, np.array(self.lever))
        return c + off, v + om[:, None] * np.column_stack((off[:, 1], -off[:, 0]))

    def corners(self, t: np.ndarray) -> np.ndarray:
        """(M, 4, 2) corners (bow-starboard, stern-starboard, stern-port, bow-port) m."""
        c, _, psi, _ = self.path.state(t)
        return hull_corners(c, psi, self.length, self.beam)


def body_to_enu(psi: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(M, 2) east/north of body vectors ``xy`` ((2,) or (M, 2): forward, starboard m) at
    headings psi (M,) rad."""
    xy = np.broadcast_to(xy, (np.size(psi), 2))
    s, c = np.sin(psi), np.cos(psi)
    return np.column_stack((xy[:, 0] * s + xy[:, 1] * c, xy[:, 0] * c - xy[:, 1] * s))


def hull_corners(c: np.ndarray, psi: np.ndarray, length: float, beam: float) -> np.ndarray:
    """(M, 4, 2) corners of rectangles centred at c (M, 2) m with headings psi (M,) rad:
    bow-starboard, stern-starboard, stern-port, bow-port."""
    body = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * np.array([length / 2, beam / 2])
    return c[:, None, :] + np.stack([body_to_enu(psi, b) for b in body], axis=1)


def _sides(corners: np.ndarray, sensor: np.ndarray
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Sides a[k] -> a[k] + edge[k] (M, 4, 2) of hulls (corners (M, 4, 2), clockwise), their
    unit outward normals (M, 4, 2) and whether each faces the sensor (M, 4) bool (the sensor
    (M, 2) lies on its outer side)."""
    a = corners
    edge = np.roll(corners, -1, axis=1) - a
    normal = np.stack((-edge[..., 1], edge[..., 0]), axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    facing = np.einsum("mkj,mkj->mk", sensor[:, None, :] - (a + 0.5 * edge), normal) > 0
    return a, edge, normal, facing


def outside(corners: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """(M,) bool: the sensor (M, 2) m lies outside the hull (corners (M, 4, 2)), so some side
    faces it. Tracks do not avoid each other: a ferry crossing a hull sees nothing of it
    while inside."""
    return _sides(corners, sensor)[3].any(axis=1)


def visible_points(rng: np.random.Generator, corners: np.ndarray, sensor: np.ndarray,
                   count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return points on the hull sides facing the sensor.

    corners (M, 4, 2) m (:func:`hull_corners`), sensor (M, 2) m, count (M,) returns per hull.
    A side is visible when the sensor lies on its outer side; a return picks a visible side
    with probability proportional to its width across the line of sight (side length x
    |outward normal . unit towards the sensor|), then a uniform point along it. A hull with
    the sensor inside gives none. Returns the points (N, 2) m and the index of the hull of
    each (N,)."""
    a, edge, normal, facing = _sides(corners, sensor)
    u = sensor - corners.mean(axis=1)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    width = np.linalg.norm(edge, axis=-1) * np.abs(np.einsum("mkj,mj->mk", normal, u))
    w = np.where(facing, width, 0.0)
    total = w.sum(axis=1, keepdims=True)
    seen = total[:, 0] > 0
    w = np.where(seen[:, None], w / np.where(seen[:, None], total, 1.0), 0.0)
    hull = np.repeat(np.arange(corners.shape[0]), np.where(seen, count, 0))
    cum = np.cumsum(w[hull], axis=1)
    side = np.minimum((rng.random(hull.size)[:, None] > cum).sum(axis=1), 3)
    frac = rng.random(hull.size)
    pts = a[hull, side] + frac[:, None] * edge[hull, side]
    return pts, hull


def silhouette_bearing(bearings: np.ndarray) -> np.ndarray:
    """(M,) centre of the angular extent of each hull: ``bearings`` (M, 4) rad of its
    corners from the sensor (any branch); the midpoint of the smallest and largest after
    unwrapping about the first corner, in [0, 2 pi)."""
    d = np.mod(bearings - bearings[:, :1] + math.pi, 2 * math.pi) - math.pi
    return np.mod(bearings[:, 0] + 0.5 * (d.min(axis=1) + d.max(axis=1)), 2 * math.pi)


@dataclass(frozen=True, slots=True)
class Quay:
    """A straight quay from ``a`` to ``b`` (2,) m (east, north); ``water`` (2,) the unit
    normal pointing to the harbour side; ``scatter`` (K, 2) m its fixed radar/lidar scatterers
    (bollards, corners, fenders) and their per-scan detection probabilities ``p_radar``,
    ``p_lidar`` (K,)."""

    qid: str
    a: np.ndarray
    b: np.ndarray
    water: np.ndarray
    scatter: np.ndarray
    p_radar: np.ndarray
    p_lidar: np.ndarray

    @property
    def length(self) -> float:
        """Length (m)."""
        return float(np.hypot(*(self.b - self.a)))

    @property
    def direction(self) -> np.ndarray:
        """(2,) unit vector from a to b."""
        return (self.b - self.a) / self.length
