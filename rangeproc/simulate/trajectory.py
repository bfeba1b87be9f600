"""Maneuvering aircraft truth for the scenario simulator.

The aircraft is flown in the range ENU frame (metres, seconds) with three smooth controls:
speed rate ``dV/dt`` (m/s^2), heading rate ``dpsi/dt`` (rad/s; heading ``psi`` clockwise from
north) and flight-path-angle rate ``dgamma/dt`` (rad/s; ``gamma`` positive climbing). Each
control is a sum of non-overlapping *smooth trapezoid pulses*: a rise over ``ramp`` seconds with
the C1 smoothstep ``s(u) = 3u^2 - 2u^3``, a hold, and a mirrored fall. Speed, heading and path
angle are the exact integrals of the pulses (piecewise polynomials), so velocity

    v = V [cos(gamma) sin(psi), cos(gamma) cos(psi), sin(gamma)]

and acceleration ``a = dv/dt`` are analytic at any time, with continuous jerk. Position is
integrated on a 100 Hz node grid with the fourth-order corrected trapezoid rule
``p1 = p0 + h/2 (v0 + v1) + h^2/12 (a0 - a1)`` (local error h^5/720 |v''''|, ~1e-10 m per step)
and evaluated between nodes with the quintic Hermite interpolant of (p, v, a) at the nodes.

Maneuvers: straight legs; level coordinated turns whose horizontal (kinematic) acceleration
``V * dpsi/dt`` holds at ``n_g * g`` with ``n_g`` in [3, 6] (load factor sqrt(n_g^2 + 1));
climbs/dives (pull-up, hold, push-over, net path-angle change zero); speed changes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

G0 = 9.80665  #: standard gravity, m/s^2
TURN_G = (3.0, 6.0)  #: horizontal acceleration of level turns, in g
ALTITUDE = (3500.0, 7500.0)  #: climb/dive target band of the ENU up coordinate, m
SPEED = (160.0, 290.0)  #: speed-change target band, m/s
_R_IN, _R_OUT = 15e3, 48e3  #: horizontal annulus (m) the planner keeps straight legs inside


@dataclass(frozen=True, slots=True)
class Pulses:
    """Non-overlapping smooth trapezoid pulses of one control channel, sorted by ``start``.

    All (K,) arrays: ``start`` (s, relative to the trajectory start), ``ramp`` rise/fall time
    (s, > 0), ``hold`` (s, >= 0), ``amp`` (control units).
    """

    start: np.ndarray
    ramp: np.ndarray
    hold: np.ndarray
    amp: np.ndarray

    @staticmethod
    def from_list(rows: list[tuple[float, float, float, float]]) -> Pulses:
        arr = np.asarray(rows, dtype=float).reshape(-1, 4)
        order = np.argsort(arr[:, 0], kind="stable")
        arr = arr[order]
        return Pulses(arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3])

    def evaluate(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Control value and its integral from 0, at times ``tau`` (s): two arrays shaped tau."""
        tau = np.asarray(tau, dtype=float)
        if self.start.size == 0:
            return np.zeros_like(tau), np.zeros_like(tau)
        k = np.searchsorted(self.start, tau, side="right") - 1
        kc = np.clip(k, 0, self.start.size - 1)
        full = self.amp * (self.ramp + self.hold)  # integral of one whole pulse
        before = np.concatenate(([0.0], np.cumsum(full)))[kc]
        r, hold, amp = self.ramp[kc], self.hold[kc], self.amp[kc]
        x = tau - self.start[kc]
        u_rise = np.clip(x / r, 0.0, 1.0)
        u_fall = np.clip((x - r - hold) / r, 0.0, 1.0)
        # value: A s(u_rise) - A s(u_fall); integral: A r S1(u) with S1(u) = u^3 - u^4/2
        value = amp * (_smooth(u_rise) - _smooth(u_fall))
        x_hold = np.clip(x - r, 0.0, hold)
        local = amp * (r * _smooth_int(u_rise) + x_hold + r * (u_fall - _smooth_int(u_fall)))
        outside = k < 0
        value = np.where(outside, 0.0, value)
        integral = np.where(outside, 0.0, before + local)
        return value, integral

    @property
    def end(self) -> np.ndarray:
        """(K,) end time of each pulse (s)."""
        return self.start + 2.0 * self.ramp + self.hold


def _smooth(u: np.ndarray) -> np.ndarray:
    return u * u * (3.0 - 2.0 * u)


def _smooth_int(u: np.ndarray) -> np.ndarray:
    return u**3 - 0.5 * u**4


@dataclass(frozen=True, slots=True)
class Segment:
    """One planned maneuver: ``kind`` in {straight, turn, climb, speed}; times relative (s);
    ``level`` the commanded acceleration in g (turn: horizontal; climb: normal; speed:
    tangential); ``turn`` the heading change (rad, turns only, positive right)."""

    kind: str
    start: float
    end: float
    level: float = 0.0
    turn: float = 0.0


@dataclass(frozen=True, slots=True)
class Trajectory:
    """Analytic aircraft truth, range ENU frame.

    t0: range time (s) of relative time 0; duration (s); v0 (speed m/s), psi0, gamma0 (rad);
    speed_rate, turn_rate, path_rate: control pulses; h: node spacing (s);
    node_p, node_v, node_a: (N+1, 3) position (m), velocity (m/s), acceleration (m/s^2) at
    relative times k*h; segments: the planned maneuvers.
    """

    t0: float
    duration: float
    v0: float
    psi0: float
    gamma0: float
    speed_rate: Pulses
    turn_rate: Pulses
    path_rate: Pulses
    h: float
    node_p: np.ndarray
    node_v: np.ndarray
    node_a: np.ndarray
    segments: tuple[Segment, ...]

    def kinematics(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact velocity and acceleration (M, 3) at relative times ``tau`` (M,) seconds."""
        return _kinematics(self.v0, self.psi0, self.gamma0,
                           (self.speed_rate, self.turn_rate, self.path_rate), tau)

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration, each (M, 3), at range times ``t`` (M,) seconds.

        Times outside [t0, t0 + duration] are extrapolated with the end polynomial (avoid).
        """
        tau = np.asarray(t, dtype=float) - self.t0
        v, a = self.kinematics(tau)
        n_int = self.node_p.shape[0] - 1
        k = np.clip(np.floor(tau / self.h).astype(np.int64), 0, n_int - 1)
        x = ((tau - k * self.h) / self.h)[:, None]
        h = self.h
        x3, x4, x5 = x**3, x**4, x**5
        # quintic Hermite basis on [0, 1] for (p0, h v0, h^2 a0, p1, h v1, h^2 a1)
        p = ((1 - 10 * x3 + 15 * x4 - 6 * x5) * self.node_p[k]
             + (x - 6 * x3 + 8 * x4 - 3 * x5) * (h * self.node_v[k])
             + 0.5 * (x * x - 3 * x3 + 3 * x4 - x5) * (h * h * self.node_a[k])
             + (10 * x3 - 15 * x4 + 6 * x5) * self.node_p[k + 1]
             + (-4 * x3 + 7 * x4 - 3 * x5) * (h * self.node_v[k + 1])
             + 0.5 * (x3 - 2 * x4 + x5) * (h * h * self.node_a[k + 1]))
        return p, v, a

    @property
    def node_time(self) -> np.ndarray:
        """(N+1,) range time of the nodes (s)."""
        return self.t0 + self.h * np.arange(self.node_p.shape[0])


def _kinematics(v0: float, psi0: float, gamma0: float, pulses: tuple[Pulses, Pulses, Pulses],
                tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration (M, 3), ENU, from the three control channels."""
    tau = np.atleast_1d(np.asarray(tau, dtype=float))
    (dv, iv), (dpsi, ipsi), (dgam, igam) = (p.evaluate(tau) for p in pulses)
    speed, psi, gam = v0 + iv, psi0 + ipsi, gamma0 + igam
    cg, sg, cp, sp = np.cos(gam), np.sin(gam), np.cos(psi), np.sin(psi)
    v = speed[:, None] * np.column_stack((cg * sp, cg * cp, sg))
    a = (dv[:, None] * np.column_stack((cg * sp, cg * cp, sg))
         + (speed * dpsi)[:, None] * np.column_stack((cg * cp, -cg * sp, np.zeros_like(cg)))
         + (speed * dgam)[:, None] * np.column_stack((-sg * sp, -sg * cp, cg)))
    return v, a


def integrate_nodes(v0: float, psi0: float, gamma0: float, pulses: tuple[Pulses, Pulses, Pulses],
                    p0: np.ndarray, duration: float, h: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Node position/velocity/acceleration (N+1, 3) on relative times k*h covering duration."""
    n = int(math.ceil(duration / h - 1e-9))
    tau = h * np.arange(n + 1)
    v, a = _kinematics(v0, psi0, gamma0, pulses, tau)
    step = 0.5 * h * (v[:-1] + v[1:]) + (h * h / 12.0) * (a[:-1] - a[1:])
    p = np.concatenate((np.asarray(p0, float)[None, :], np.asarray(p0, float) + np.cumsum(step, 0)))
    return p, v, a


def _straight_room(p: np.ndarray, d: np.ndarray) -> float:
    """Distance (m) along horizontal unit direction d from p before leaving the annulus."""
    b, c = float(p @ d), float(p @ p)
    s_out = -b + math.sqrt(max(b * b - c + _R_OUT**2, 0.0))
    disc_in = b * b - c + _R_IN**2
    if disc_in > 0 and -b - math.sqrt(disc_in) > 0:
        return max(0.0, min(s_out, -b - math.sqrt(disc_in)))
    return max(0.0, s_out)


def plan_trajectory(rng: np.random.Generator, duration: float, t0: float,
                    h: float = 0.01) -> Trajectory:
    """Draw a maneuver sequence covering ``duration`` s and integrate it on nodes every h s.

    The aircraft starts 22-35 km from the origin at 4-7 km up, 180-280 m/s, heading roughly
    tangential; turns steer toward waypoints 20-40 km from the origin and straight flight is
    kept inside a 15-48 km annulus, so the track stays roughly 10-60 km from the origin.
    """
    ang = rng.uniform(0, 2 * math.pi)
    radius = rng.uniform(22e3, 35e3)
    p_start = np.array([radius * math.cos(ang), radius * math.sin(ang),
                        rng.uniform(4000.0, 7000.0)])
    v0 = rng.uniform(180.0, 280.0)
    sense = 1.0 if rng.random() < 0.5 else -1.0
    # tangential heading (clockwise from north): direction (-sin a, cos a) * sense, +-30 deg
    psi0 = math.atan2(-sense * math.sin(ang), sense * math.cos(ang))
    psi0 += math.radians(rng.uniform(-30.0, 30.0))
    return fly(rng, duration, t0, p_start=p_start, v0=v0, psi0=psi0, h=h)


@dataclass(frozen=True, slots=True)
class Leg:
    """One scripted maneuver of :func:`fly`: ``kind`` 'straight' (``seconds`` of straight,
    level flight at constant speed) or 'turn' (a level coordinated turn by ``turn`` rad,
    positive right, at ``level`` g of horizontal acceleration, rising and falling over ``ramp``
    s, shortened for small turns)."""

    kind: str
    seconds: float = 0.0
    turn: float = 0.0
    level: float = 0.0
    ramp: float = 1.5


def script_rows(legs: tuple[Leg, ...] | list[Leg], speed: float
                ) -> tuple[dict[str, list[tuple[float, float, float, float]]], list[Segment],
                           float, float]:
    """Control pulses of scripted legs flown from relative time 0 at ``speed`` m/s.

    Returns the pulse rows per channel (see :func:`_pulses`), the segments, the script's end
    (relative s) and its total heading change (rad)."""
    rows: dict[str, list[tuple[float, float, float, float]]] = {"v": [], "psi": [], "gam": []}
    segments: list[Segment] = []
    tau, dpsi_total = 0.0, 0.0
    for leg in legs:
        if leg.kind == "straight":
            seg_t = max(0.0, leg.seconds)
            if seg_t > 0.0:
                segments.append(Segment("straight", tau, tau + seg_t))
        elif leg.kind == "turn":
            rate = leg.level * G0 / speed
            ramp = min(leg.ramp, 0.5 * abs(leg.turn) / rate)
            hold = abs(leg.turn) / rate - ramp  # integral of the pulse = rate * (ramp + hold)
            seg_t = 2 * ramp + hold
            rows["psi"].append((tau, ramp, hold, math.copysign(rate, leg.turn)))
            segments.append(Segment("turn", tau, tau + seg_t, leg.level, leg.turn))
            dpsi_total += leg.turn
        else:
            raise ValueError(f"unknown leg kind {leg.kind!r}")
        tau += seg_t
    return rows, segments, tau, dpsi_total


def fly(rng: np.random.Generator, duration: float, t0: float, *, p_start: np.ndarray,
        v0: float, psi0: float, legs: tuple[Leg, ...] | list[Leg] = (),
        h: float = 0.01) -> Trajectory:
    """Fly scripted ``legs`` from ``p_start`` (3,) m range ENU at speed v0 (m/s), heading psi0
    (rad), then random maneuvers (drawn from rng) until ``duration`` s; integrate on nodes
    every h s. Without legs this is the planner of :func:`plan_trajectory`."""
    rows, segments, tau, dpsi = script_rows(legs, v0)
    p, speed, psi = p_start.copy(), v0, psi0 + dpsi
    if legs:
        p = p + _displacement(v0, psi0, _pulses(rows), 0.0, tau)
    while tau < duration:
        room = _straight_room(p[:2], np.array([math.sin(psi), math.cos(psi)])) / speed
        kind = "straight" if not segments else str(
            rng.choice(["turn", "straight", "climb", "speed"], p=[0.4, 0.2, 0.2, 0.2]))
        if kind != "turn" and room < 15.0:
            kind = "turn"
        ramp = rng.uniform(1.0, 2.0)
        if kind == "straight":
            seg_t = max(1.0, min(rng.uniform(5.0, 25.0), room))
            segments.append(Segment("straight", tau, tau + seg_t))
        elif kind == "turn":
            dpsi, n_g = _plan_turn(rng, p, psi, speed, ramp)
            rate = n_g * G0 / speed
            hold = abs(dpsi) / rate - ramp  # integral of the pulse = rate * (ramp + hold)
            seg_t = 2 * ramp + hold
            rows["psi"].append((tau, ramp, hold, math.copysign(rate, dpsi)))
            segments.append(Segment("turn", tau, tau + seg_t, n_g, dpsi))
            psi += dpsi
        elif kind == "climb":
            seg_t, q_rows, n_v = _plan_climb(rng, float(p[2]), speed, ramp, room)
            rows["gam"].extend((tau + s, r, hld, a) for s, r, hld, a in q_rows)
            segments.append(Segment("climb", tau, tau + seg_t, n_v))
        else:
            target = rng.uniform(*SPEED)
            while abs(target - speed) < 20.0:
                target = rng.uniform(*SPEED)
            dv = target - speed
            acc = min(rng.uniform(3.0, 8.0), abs(dv) / (1.05 * ramp))
            hold = abs(dv) / acc - ramp
            seg_t = 2 * ramp + hold
            rows["v"].append((tau, ramp, hold, math.copysign(acc, dv)))
            segments.append(Segment("speed", tau, tau + seg_t, acc / G0))
            speed = target
        pulses = _pulses(rows)
        p = p + _displacement(v0, psi0, pulses, tau, tau + seg_t)
        tau += seg_t
    pulses = _pulses(rows)
    node_p, node_v, node_a = integrate_nodes(v0, psi0, 0.0, pulses, p_start, duration, h)
    return Trajectory(t0=float(t0), duration=float(duration), v0=v0, psi0=psi0, gamma0=0.0,
                      speed_rate=pulses[0], turn_rate=pulses[1], path_rate=pulses[2], h=h,
                      node_p=node_p, node_v=node_v, node_a=node_a, segments=tuple(segments))


def fly_through(rng: np.random.Generator, duration: float, t0: float, *, tau: float,
                p: np.ndarray, psi: float, speed: float, legs: tuple[Leg, ...] | list[Leg],
                h: float = 0.01) -> Trajectory:
    """:func:`fly` with the start solved so that the aircraft is at ``p`` (3,) m range ENU with
    heading ``psi`` (rad) at relative time ``tau`` (s), which must lie within the scripted legs
    (not inside a turn); speed (m/s) is constant through the legs."""
    rows, _, tau_end, _ = script_rows(legs, speed)
    if not 0.0 <= tau <= tau_end:
        raise ValueError(f"anchor time {tau!r} s outside the scripted legs (0..{tau_end:g} s)")
    pulses = _pulses(rows)
    psi0 = psi - float(pulses[1].evaluate(np.array([tau]))[1][0])
    p_start = np.asarray(p, float) - _displacement(speed, psi0, pulses, 0.0, tau)
    return fly(rng, duration, t0, p_start=p_start, v0=speed, psi0=psi0, legs=legs, h=h)


def _pulses(rows: dict[str, list[tuple[float, float, float, float]]]
            ) -> tuple[Pulses, Pulses, Pulses]:
    return (Pulses.from_list(rows["v"]), Pulses.from_list(rows["psi"]),
            Pulses.from_list(rows["gam"]))


def _displacement(v0: float, psi0: float, pulses: tuple[Pulses, Pulses, Pulses],
                  tau_a: float, tau_b: float) -> np.ndarray:
    """Planner's position change (3,) m between relative times tau_a and tau_b (Simpson)."""
    n = max(2, 2 * int(math.ceil((tau_b - tau_a) / 0.1)))
    tau = np.linspace(tau_a, tau_b, n + 1)
    v, _ = _kinematics(v0, psi0, 0.0, pulses, tau)
    w = np.ones(n + 1)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    return (tau_b - tau_a) / (3 * n) * (w @ v)


def _plan_turn(rng: np.random.Generator, p: np.ndarray, psi: float, speed: float,
               ramp: float) -> tuple[float, float]:
    """Heading change (rad, + right) toward a waypoint, and the turn level in g."""
    ang = math.atan2(p[1], p[0])
    vel = np.array([math.sin(psi), math.cos(psi)])
    sense = 1.0 if p[0] * vel[1] - p[1] * vel[0] >= 0 else -1.0  # counter-clockwise motion: +1
    wp_ang = ang + sense * math.radians(rng.uniform(40.0, 100.0))
    wp = rng.uniform(20e3, 40e3) * np.array([math.cos(wp_ang), math.sin(wp_ang)])
    want = math.atan2(wp[0] - p[0], wp[1] - p[1])
    dpsi = (want - psi + math.pi) % (2 * math.pi) - math.pi
    if rng.random() < 0.15:  # the long way round: a 180-360 deg turn
        dpsi -= math.copysign(2 * math.pi, dpsi)
    n_g = rng.uniform(*TURN_G)
    min_turn = 1.05 * n_g * G0 / speed * ramp  # a pulse with zero hold
    if abs(dpsi) < min_turn:
        dpsi = math.copysign(min_turn, dpsi if dpsi != 0 else 1.0)
    return dpsi, n_g


def _plan_climb(rng: np.random.Generator, up: float, speed: float, ramp: float, room: float
                ) -> tuple[float, list[tuple[float, float, float, float]], float]:
    """Pull-up/hold/push-over pulses (relative starts) toward a new altitude in ALTITUDE."""
    target = rng.uniform(*ALTITUDE)
    for _ in range(20):
        if abs(target - up) >= 700.0:
            break
        target = rng.uniform(*ALTITUDE)
    dh = target - up
    gam = math.radians(rng.uniform(5.0, 20.0))
    n_v = min(rng.uniform(1.0, 2.5), gam * speed / (1.2 * ramp * G0))  # normal accel, g
    q = n_v * G0 / speed
    hold_q = gam / q - ramp
    t_q = 2 * ramp + hold_q  # one transition; it climbs about V sin(gam) t_q / 2
    hold = abs(dh) / (speed * math.sin(gam)) - t_q
    hold = float(np.clip(hold, 0.0, max(0.0, room - 2 * t_q)))
    s = math.copysign(q, dh)
    q_rows = [(0.0, ramp, hold_q, s), (t_q + hold, ramp, hold_q, -s)]
    return 2 * t_q + hold, q_rows, n_v
