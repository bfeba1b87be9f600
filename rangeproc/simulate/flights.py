"""Flight geometry of several objects: crossings, close passes, formations that split.

Built on :func:`~rangeproc.simulate.trajectory.fly` / :func:`fly_through`: each object flies
scripted legs (straight, level, constant speed through its event) and random maneuvers after
them. Positions are range ENU (m), headings clockwise from north (rad), times relative to the
trajectory start ``t0`` (s) unless named ``t_``. ``g`` draws the geometry; each object's random
maneuvers come from its own generator in ``rngs``.
"""
from __future__ import annotations

import math

import numpy as np

from rangeproc.simulate.trajectory import Leg, Trajectory, fly, fly_through, script_rows

#: seconds of straight, level flight scripted after an event (crossing, close pass)
CLEAR = 12.0
#: formation slots (right, back, up) ranges in m, relative to the leader's initial heading
_SLOTS = (((120.0, 220.0), (80.0, 180.0), (-30.0, 30.0)),
          ((-220.0, -120.0), (80.0, 180.0), (-30.0, 30.0)),
          ((-20.0, 20.0), (220.0, 300.0), (-60.0, -20.0)))
#: break turns (deg) of the wingmen at the split: right, left, a reversal to either side
_BREAKS = ((40.0, 80.0, 1.0), (40.0, 80.0, -1.0), (130.0, 180.0, 0.0))


def event_time(g: np.random.Generator, duration: float) -> float:
    """Relative time (s) of a scenario's key event: 35-60 % into the flight (of at most the
    first 150 s, so that long flights do not fly straight for minutes before it)."""
    return float(g.uniform(0.35, 0.6) * min(duration, 150.0))


def _sign(g: np.random.Generator) -> float:
    return 1.0 if g.random() < 0.5 else -1.0


def approach_legs(g: np.random.Generator, tau: float, speed: float) -> list[Leg]:
    """Legs reaching relative time ``tau`` (s) straight and level and holding it ``CLEAR`` s
    beyond: an early turn of 30-90 deg at 3-5 g first when there are over 35 s to go."""
    if tau <= 35.0:
        return [Leg("straight", tau + CLEAR)]
    first = g.uniform(3.0, tau - 25.0)
    turn = Leg("turn", turn=_sign(g) * math.radians(g.uniform(30.0, 90.0)),
               level=g.uniform(3.0, 5.0))
    turn_t = script_rows([turn], speed)[2]
    return [Leg("straight", first), turn, Leg("straight", tau + CLEAR - first - turn_t)]


def miss_vector(g: np.random.Generator, w: np.ndarray, distance: float) -> np.ndarray:
    """(3,) offset (m) of length ``distance`` perpendicular to the relative velocity w (3,)
    (horizontal), at a random angle about it: a linear close pass at that distance."""
    u1 = np.array([w[1], -w[0], 0.0]) / math.hypot(w[0], w[1])
    u2 = np.array([0.0, 0.0, 1.0])
    phi = g.uniform(0.0, 2.0 * math.pi)
    return distance * (math.cos(phi) * u1 + math.sin(phi) * u2)


def crossing_flights(g: np.random.Generator, rngs: list[np.random.Generator], t0: float,
                     span: float, *, tau: float, miss: tuple[float, float],
                     spread: tuple[float, float]) -> tuple[list[Trajectory], np.ndarray]:
    """One aircraft per generator in ``rngs`` crossing a point C at relative time ``tau`` (s).

    C is 10-25 km from the origin, 4-7 km up. The first aircraft passes through C; every other
    one, heading ``spread`` (deg, (lo, hi)) to alternate sides of the first, passes it at
    ``miss`` (m, (lo, hi)) perpendicular to their relative velocity, so the closest approach
    to the first is at tau. Speeds 180-280 m/s; straight and level around the crossing.
    Returns the trajectories (covering ``span`` s from t0) and C (3,)."""
    ang, rad = g.uniform(0.0, 2.0 * math.pi), g.uniform(10e3, 25e3)
    c = np.array([rad * math.sin(ang), rad * math.cos(ang), g.uniform(4000.0, 7000.0)])
    psi_a, side = g.uniform(0.0, 2.0 * math.pi), _sign(g)
    flights, v_a = [], np.zeros(3)
    for k, rng in enumerate(rngs):
        psi = psi_a if k == 0 else psi_a + side * (-1) ** k * math.radians(g.uniform(*spread))
        speed = float(g.uniform(180.0, 280.0))
        v = speed * np.array([math.sin(psi), math.cos(psi), 0.0])
        if k == 0:
            p, v_a = c, v
        else:
            p = c + miss_vector(g, v - v_a, g.uniform(*miss))
        flights.append(fly_through(rng, span, t0, tau=tau, p=p, psi=psi, speed=speed,
                                   legs=approach_legs(g, tau, speed)))
    return flights, c


def pass_near(g: np.random.Generator, rng: np.random.Generator, t0: float, span: float, *,
              other: Trajectory, tau: float, distance: tuple[float, float]) -> Trajectory:
    """An aircraft passing ``distance`` (m, (lo, hi)) horizontally from ``other`` at relative
    time ``tau`` (s), within 800 m of its height, on a random heading at 180-280 m/s."""
    p_other = other.state(np.array([t0 + tau]))[0][0]
    ang, d = g.uniform(0.0, 2.0 * math.pi), g.uniform(*distance)
    up = float(np.clip(p_other[2] + g.uniform(-800.0, 800.0), 3500.0, 7500.0))
    p = np.array([p_other[0] + d * math.sin(ang), p_other[1] + d * math.cos(ang), up])
    psi, speed = g.uniform(0.0, 2.0 * math.pi), float(g.uniform(180.0, 280.0))
    return fly_through(rng, span, t0, tau=tau, p=p, psi=psi, speed=speed,
                       legs=approach_legs(g, tau, speed))


def formation_flights(g: np.random.Generator, rngs: list[np.random.Generator], t0: float,
                      span: float, *, tau: float) -> list[Trajectory]:
    """A leader and up to three wingmen (one per generator in ``rngs``) in close formation
    (slots 100-300 m apart) until relative time ``tau`` (s), when they split: the leader holds
    its course 5-10 s, the wingmen break right, left and into a reversal at 4-6 g.

    The formation starts 18-30 km from the origin, 4-7 km up, 180-250 m/s on a roughly
    tangential heading, with one 30-90 deg turn at 2-3.5 g before the split when time allows.
    Each wingman is a translated copy of the leader until the split (identical velocity)."""
    ang, rad = g.uniform(0.0, 2.0 * math.pi), g.uniform(18e3, 30e3)
    p0 = np.array([rad * math.sin(ang), rad * math.cos(ang), g.uniform(4000.0, 7000.0)])
    speed = float(g.uniform(180.0, 250.0))
    # tangential (either sense) +-30 deg: the position's bearing is ang
    psi0 = (math.atan2(math.cos(ang), -math.sin(ang)) + (0.0 if g.random() < 0.5 else math.pi)
            + math.radians(g.uniform(-30.0, 30.0)))
    common: list[Leg] = [Leg("straight", tau)]
    if tau > 30.0:
        first = g.uniform(5.0, 10.0)
        turn = Leg("turn", turn=_sign(g) * math.radians(g.uniform(30.0, 90.0)),
                   level=g.uniform(2.0, 3.5))
        common = [Leg("straight", first), turn,
                  Leg("straight", tau - first - script_rows([turn], speed)[2])]
    fwd = np.array([math.sin(psi0), math.cos(psi0), 0.0])
    right = np.array([math.cos(psi0), -math.sin(psi0), 0.0])
    flights = [fly(rngs[0], span, t0, p_start=p0, v0=speed, psi0=psi0,
                   legs=common + [Leg("straight", g.uniform(5.0, 10.0))])]
    for k, rng in enumerate(rngs[1:4]):
        (r_lo, r_hi), (b_lo, b_hi), (u_lo, u_hi) = _SLOTS[k]
        off = (g.uniform(r_lo, r_hi) * right - g.uniform(b_lo, b_hi) * fwd
               + np.array([0.0, 0.0, g.uniform(u_lo, u_hi)]))
        lo, hi, side = _BREAKS[k]
        brk = Leg("turn", turn=(side or _sign(g)) * math.radians(g.uniform(lo, hi)),
                  level=g.uniform(4.0, 6.0))
        flights.append(fly(rng, span, t0, p_start=p0 + off, v0=speed, psi0=psi0,
                           legs=common + [brk]))
    return flights
