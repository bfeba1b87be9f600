"""Plots without a track number (a surveillance radar, a plot feed): telling plots from
one instrument's track, their positions, and the constant-velocity helpers.

Rows without ``track_id`` are plots of anything in view, clutter included (DATA_CONTRACT
section 2); ``tracking.plot_tracker`` tracks them per sensor in the range ENU frame.

* **Plots or one instrument's track** (:func:`several_objects`). A file of rows without
  ``track_id`` is taken as one instrument following one object only when its consecutive rows
  could be one object: a step between consecutive rows longer than an object at
  ``INITIATION_SPEED`` (or a line of sight turning faster than ``ANGULAR_RATE``) could travel,
  plus ``JUMP_SIGMAS`` of the two rows' noise, is a jump, and a file with more than
  ``JUMP_SHARE`` of its steps jumps holds several objects. Wild points of a tracking
  instrument make a few percent of such steps; plots of several objects and clutter make most
  of them. A radar that sweeps in azimuth (:func:`is_rotating`) or stamps whole scans with one
  time (:func:`is_framed`) is a plot sensor whatever its steps.
Positions come from the plots' range, azimuth and elevation; a plot without elevation (a 2-D
radar) is placed at elevation 0 with ``NO_ELEVATION_SIGMA`` of uncertainty.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rangeproc.fusion.assemble import PLANE_ELEVATION_SIGMA
from rangeproc.models.motion import cv_predict

#: White-acceleration PSD ((m/s^2)^2/s) of the single CV model of ``tracking.plot_swaps`` (a
#: 3 g manoeuvre over a few seconds stays inside its gate).
ACCELERATION_PSD = 400.0
#: Gate probability of a plot-to-track distance (3 degrees of freedom).
GATE_PROBABILITY = 0.9999
#: Fastest object a new track may be (m/s); its second plot must be reachable.
INITIATION_SPEED = 1500.0
#: A young track's plots compared over this many scans (``tracking.plot_swaps``); a tentative
#: track older than this (its velocity known) is clutter once its score falls to
#: ``CLUTTER_SCORE``.
CONFIRM_SCANS = 4
#: Scans in a row without a plot, at ``DETECTION_PROBABILITY``, that end a track
#: (``DELETE_DROP``).
MAX_MISSES = 5
#: Plots come in frames when at least this share of them share a time stamp with another.
FRAMED_SHARE = 0.5
#: A rotating radar: at least this many turns, at most this many seconds per turn.
MIN_TURNS = 2.0
MAX_TURN_SECONDS = 30.0
#: Elevation sigma (rad) given to plots without elevation (placed at elevation 0), as the
#: assembly does for a 2-D radar.
NO_ELEVATION_SIGMA = PLANE_ELEVATION_SIGMA
#: Fastest turn of a line of sight an instrument following one object can see (rad/s): an
#: object at 300 m/s passing 300 m away.
ANGULAR_RATE = 1.0
#: A step between consecutive rows is a jump beyond this many sigmas of the two rows' noise
#: (on top of the distance an object could travel).
JUMP_SIGMAS = 5.0
#: A file with more than this share of jumps holds several objects (a tracking instrument's
#: wild points and noise bursts make a few percent).
JUMP_SHARE = 0.25


def is_rotating(t: np.ndarray, azimuth: np.ndarray) -> bool:
    """True when the plots sweep in azimuth like a rotating radar: at least 90 % of the steps
    go forward, over at least ``MIN_TURNS`` turns, at one turn per ``MAX_TURN_SECONDS`` or
    faster (an instrument following one object never does that)."""
    if t.size < 3:
        return False
    step = np.mod(np.diff(azimuth), 2 * np.pi)
    forward = step < np.pi
    advance = float(step[forward].sum()) / (2 * np.pi)
    span = float(t[-1] - t[0])
    return bool(forward.mean() >= 0.9 and advance >= MIN_TURNS
                and span > 0 and span / advance <= MAX_TURN_SECONDS)


def is_framed(t: np.ndarray) -> bool:
    """True when the plots come in frames: most share their time stamp with another plot (a
    radar or lidar that stamps a whole scan with one time)."""
    if t.size < 3:
        return False
    same = np.diff(t) == 0.0
    shared = np.zeros(t.size, dtype=bool)
    shared[1:] |= same
    shared[:-1] |= same
    return bool(shared.mean() >= FRAMED_SHARE)


def scan_numbers(t: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    """(N,) int64 scan number of each plot (time ordered): for plots in frames
    (:func:`is_framed`) each time stamp is a scan; otherwise (a rotating radar) a new scan
    starts where the azimuth wraps (falls by more than half a turn)."""
    if t.size == 0:
        return np.zeros(0, dtype=np.int64)
    if is_framed(t):
        return np.cumsum(np.concatenate([[False], np.diff(t) > 0.0])).astype(np.int64)
    da = np.diff(np.mod(azimuth, 2 * np.pi))
    return np.cumsum(np.concatenate([[False], da < -np.pi])).astype(np.int64)


def silent_clock(t: np.ndarray, scan: np.ndarray, revisit: float) -> np.ndarray:
    """(N,) float, the clock in scans of plots at times ``t`` (N,) s ascending with scan
    numbers ``scan`` (N,) (:func:`scan_numbers`): the scan number plus the scans a sensor
    left out. A lidar or radar that writes a frame only when it detects something is silent
    while nothing is in view; each silence longer than a scan (the time between consecutive
    scans, over ``revisit`` s, rounded) adds its missing scans, at most ``MAX_MISSES`` + 1 a
    silence: an object in view would have been reported in them, so the few plots a track
    coasting through one takes after it, tens of seconds later, are a stray tail
    (``tracking.plot_tails``); a longer silence (a sensor switched off) counts no further.
    ``scan`` as floats when ``revisit`` is not positive."""
    clock = scan.astype(float)
    if t.size < 2 or not revisit > 0.0:
        return clock
    order = np.argsort(scan, kind="stable")
    first = np.concatenate([[True], np.diff(scan[order]) > 0])
    starts = order[first]                                 # first plot of each scan
    step = np.diff(t[starts])
    missing = np.clip(np.round(step / revisit) - 1.0, 0.0, MAX_MISSES + 1.0)
    extra = np.concatenate([[0.0], np.cumsum(missing)])
    index = np.cumsum(first) - 1                          # scan index of each sorted plot
    clock[order] += extra[index]
    return clock


def revisit_period(t: np.ndarray, scan: np.ndarray) -> float:
    """Median time (s) between consecutive scans of plots at times ``t`` (N,) with scan
    numbers ``scan`` (N,) (each scan at the median time of its plots); 0 with one scan."""
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    scan_t = np.array([np.median(t[rows]) for rows in np.split(order, bounds)])
    return float(np.median(np.diff(scan_t))) if scan_t.size > 1 else 0.0


def jump_share(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, s: np.ndarray,
               Qr: np.ndarray) -> float:
    """Share of the steps between consecutive rows that no single object could make (module
    docstring: *Plots or one instrument's track*).

    t: (N,) s ascending; z: (N, >=3) range (m, NaN none), azimuth, elevation (rad, NaN none)
    in the sensor's axes; sigma: (N, >=3) their sigmas; s: (N, 3) sensor position (range ENU
    m); Qr: (N, 3, 3) rotation range ENU -> sensor axes. Rows with range on both sides of a
    step are compared as positions (distance against ``INITIATION_SPEED`` dt), others as lines
    of sight (angle against ``ANGULAR_RATE`` dt). 0 with fewer than two rows.
    """
    if t.size < 2:
        return 0.0
    r, az, el = z[:, 0], z[:, 1], z[:, 2]
    dt = np.abs(np.diff(t))
    ranged = np.isfinite(r)
    both = ranged[1:] & ranged[:-1]
    jump = np.zeros(t.size - 1, dtype=bool)
    if both.any():
        p, R = plot_positions(np.where(ranged, r, 0.0), az, el, sigma[:, :3], s, Qr)
        d = np.diff(p, axis=0)
        dist = np.linalg.norm(d, axis=1)
        u = d / np.maximum(dist, 1e-9)[:, None]
        var = np.einsum("ni,nij,nj->n", u, R[1:] + R[:-1], u)
        jump |= both & (dist > INITIATION_SPEED * dt + JUMP_SIGMAS * np.sqrt(var))
    angles = ~both
    if angles.any():
        flat = ~np.isfinite(el)
        e = np.where(flat, 0.0, el)
        los = np.column_stack([np.cos(e) * np.sin(az), np.cos(e) * np.cos(az), np.sin(e)])
        los = np.einsum("nji,nj->ni", Qr, los)          # sensor axes -> range ENU
        turn = np.arccos(np.clip(np.einsum("ni,ni->n", los[1:], los[:-1]), -1.0, 1.0))
        daz = np.abs(np.angle(np.exp(1j * np.diff(az))))
        planar = flat[1:] | flat[:-1]                    # bearings only: the azimuth step
        turn = np.where(planar, daz, turn)
        sig = np.hypot(sigma[1:, 1], sigma[:-1, 1])
        sig = np.where(planar, sig, np.hypot(sig, np.hypot(np.nan_to_num(sigma[1:, 2]),
                                                           np.nan_to_num(sigma[:-1, 2]))))
        jump |= angles & (turn > ANGULAR_RATE * dt + JUMP_SIGMAS * sig)
    return float(jump.mean())


def several_objects(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, s: np.ndarray,
                    Qr: np.ndarray) -> bool:
    """True when rows without ``track_id`` (arguments as :func:`jump_share`) are plots of
    several objects (a plot sensor), False when they are one instrument following one
    object: the rows sweep in azimuth, come in frames, or jump (module docstring)."""
    return bool(is_framed(t) or is_rotating(t, z[:, 1])
                or jump_share(t, z, sigma, s, Qr) > JUMP_SHARE)


def plot_positions(r: np.ndarray, az: np.ndarray, el: np.ndarray, sig: np.ndarray,
                   s: np.ndarray, Qr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """ENU positions (N, 3) m and covariances (N, 3, 3) m^2 of plots.

    r, az, el: (N,) slant range (m), azimuth, elevation (rad; NaN elevation -> 0 with
    ``NO_ELEVATION_SIGMA``) in the sensor's axes; sig: (N, 3) their sigmas; s: (N, 3) sensor
    position; Qr: (N, 3, 3) rotation range ENU -> sensor axes.
    """
    el = np.array(el, dtype=float)
    sig = np.array(sig, dtype=float)
    flat = ~np.isfinite(el)
    el[flat] = 0.0
    sig[flat, 2] = NO_ELEVATION_SIGMA
    ce, se, ca, sa = np.cos(el), np.sin(el), np.cos(az), np.sin(az)
    d = np.column_stack([r * ce * sa, r * ce * ca, r * se])
    # Jacobian of d wrt (r, az, el) in the sensor axes
    J = np.empty((r.size, 3, 3))
    J[:, :, 0] = np.column_stack([ce * sa, ce * ca, se])
    J[:, :, 1] = np.column_stack([r * ce * ca, -r * ce * sa, np.zeros_like(r)])
    J[:, :, 2] = np.column_stack([-r * se * sa, -r * se * ca, r * ce])
    Rl = J @ (sig[:, :, None] ** 2 * np.eye(3)) @ np.transpose(J, (0, 2, 1))
    QrT = np.transpose(Qr, (0, 2, 1))
    p = s + np.einsum("nij,nj->ni", QrT, d)
    return p, QrT @ Rl @ Qr


@dataclass(slots=True)
class _Track:
    """A track under way: CV state x (6,) [p, v] in ENU, covariance P (6, 6), time t (s);
    the clock (scans or revisits, ``plot_tracker.PlotTiming``) of its first and last plot."""

    x: np.ndarray
    P: np.ndarray
    t: float
    first_scan: float
    last_scan: float
    hits: int = 1
    confirmed: bool = False
    rows: list[int] = field(default_factory=list)


def predict_tracks(x: np.ndarray, P: np.ndarray, t_track: np.ndarray, t: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """CV prediction (PSD ``ACCELERATION_PSD``) of L tracks to times ``t`` (A,): states
    x (L, 6) and covariances P (L, 6, 6) at their times ``t_track`` (L,) s -> states
    (L, A, 6), covariances (L, A, 6, 6)."""
    dt = np.asarray(t, dtype=float)[None, :] - np.asarray(t_track, dtype=float)[:, None]
    return cv_predict(x[:, None], P[:, None], dt, ACCELERATION_PSD)


def start_track(p: np.ndarray, R: np.ndarray, t: float, scan: float, row: int) -> _Track:
    P = np.zeros((6, 6))
    P[:3, :3] = R
    P[3:, 3:] = (INITIATION_SPEED / 3.0) ** 2 * np.eye(3)   # 3 sigma = the speed bound
    return _Track(np.concatenate([p, np.zeros(3)]), P, t, scan, scan, rows=[row])


def update_track(tr: _Track, x: np.ndarray, P: np.ndarray, p: np.ndarray, R: np.ndarray,
            t: float, scan: float, row: int) -> None:
    S = P[:3, :3] + R
    K = np.linalg.solve(S, P[:3, :]).T
    tr.x = x + K @ (p - x[:3])
    tr.P = P - K @ P[:3, :]
    tr.P = 0.5 * (tr.P + tr.P.T)
    tr.t = t
    tr.last_scan = scan
    tr.hits += 1
    tr.rows.append(row)
