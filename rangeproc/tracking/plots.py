"""Plots without a track number (a surveillance radar, a plot feed): a multi-target tracker
with clutter.

Rows without ``track_id`` are plots of anything in view, clutter included (DATA_CONTRACT
section 2). They are tracked per sensor in the range ENU frame:

* **Plots or one instrument's track** (:func:`several_objects`). A file of rows without
  ``track_id`` is taken as one instrument following one object only when its consecutive rows
  could be one object: a step between consecutive rows longer than an object at
  ``INITIATION_SPEED`` (or a line of sight turning faster than ``ANGULAR_RATE``) could travel,
  plus ``JUMP_SIGMAS`` of the two rows' noise, is a jump, and a file with more than
  ``JUMP_SHARE`` of its steps jumps holds several objects. Wild points of a tracking
  instrument make a few percent of such steps; plots of several objects and clutter make most
  of them. A radar that sweeps in azimuth (:func:`is_rotating`) or stamps whole scans with one
  time (:func:`is_framed`) is a plot sensor whatever its steps.
* **Scans and revisits** (:func:`plot_timing`). A rotating radar reports in azimuth order, so a
  scan ends where the azimuth wraps (falls by more than half a turn); a sensor that stamps a
  whole scan with one time has one scan per time stamp. Within a scan an object gives at most
  one plot. Plots in any other order (a phased-array radar revisiting each object on its own
  schedule, a feed merged from several radars) have no scans: each time stamp is taken on its
  own, and missed detections are counted in revisit periods of the sensor, the median time
  between consecutive plots of its confirmed tracks (found by tracking with a trial revisit
  until the estimate agrees with the revisit it was tracked with).
* **Prediction**: a constant-velocity model with white-acceleration noise of PSD
  ``ACCELERATION_PSD`` ((m/s^2)^2/s, a 3 g manoeuvre over a few seconds stays inside the gate).
* **Association**: global nearest neighbour per scan (Munkres via
  ``scipy.optimize.linear_sum_assignment`` on the Mahalanobis distances, gated at chi-square
  probability ``GATE_PROBABILITY``). GNN rather than JPDA or a plot-level MHT because this is
  post-processing: every plot is kept with its track, the tracks are smoothed afterwards, and
  the ambiguous cases (objects closer than the plot noise) are settled at the segment level,
  across sensors and gaps, by the track-oriented hypothesis search (``tracking.associate``),
  which sees far more evidence than one scan.
* **Initiation and clutter**: an unassigned plot starts a tentative track; its second plot
  must lie within ``INITIATION_SPEED`` times the elapsed time (plus the plot noise); a track is
  confirmed after ``CONFIRM_HITS`` hits in its first ``CONFIRM_SCANS`` scans (revisits).
  Clutter, uniform over the coverage, seldom builds such a chain; plots of tracks never
  confirmed are clutter.
* **Deletion**: after ``MAX_MISSES`` scans (revisits) in a row without a plot (detection
  probability 0.9 makes five misses in a row a 1e-5 event), or a tentative track not confirmed
  in time.

Positions come from the plots' range, azimuth and elevation; a plot without elevation (a 2-D
radar) is placed at elevation 0 with ``NO_ELEVATION_SIGMA`` of uncertainty.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment
from rangeproc.quantiles import chi2_ppf

from rangeproc.fusion.assemble import PLANE_ELEVATION_SIGMA

#: White-acceleration PSD of the constant-velocity model ((m/s^2)^2 / s).
ACCELERATION_PSD = 400.0
#: Gate probability of a plot-to-track distance (3 degrees of freedom).
GATE_PROBABILITY = 0.9999
#: Fastest object a new track may be (m/s); its second plot must be reachable.
INITIATION_SPEED = 1500.0
#: Confirmation: hits among the first scans of a tentative track.
CONFIRM_HITS = 3
CONFIRM_SCANS = 4
#: Scans in a row without a plot that end a confirmed track.
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
#: Revisit periods (s) tried first and last by :func:`free_revisit`; the estimate is accepted
#: when it agrees with the revisit tracked with to ``REVISIT_AGREEMENT`` (relative).
REVISIT_TRIAL = 4.0
REVISIT_MAX = MAX_TURN_SECONDS
REVISIT_AGREEMENT = 0.2
#: Confirmed tracks with at least this many plots give the revisit estimate.
REVISIT_MIN_HITS = 5


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


@dataclass(frozen=True, slots=True)
class PlotTiming:
    """How one sensor's plots are grouped in time (module docstring: *Scans and revisits*).

    frame: (N,) int64, plots taken together (an object gives at most one plot per frame);
    scan: (N,) int64, the scan number, or for plots in no scan order the number of whole
    revisit periods since the first plot; clock: (N,) float, the same in revisits (the scan
    number itself for a scanning radar); revisit: the revisit period (s; 0 with one scan);
    order: "rotating", "framed" or "free".
    """

    frame: np.ndarray
    scan: np.ndarray
    clock: np.ndarray
    revisit: float
    order: str


def plot_timing(t: np.ndarray, azimuth: np.ndarray, p: np.ndarray, R: np.ndarray
                ) -> PlotTiming:
    """The :class:`PlotTiming` of plots at times ``t`` (N,) s ascending, azimuth (N,) rad,
    ENU positions ``p`` (N, 3) m with covariances ``R`` (N, 3, 3) m^2."""
    framed = is_framed(t)
    if framed or is_rotating(t, azimuth):
        scan = scan_numbers(t, azimuth)
        return PlotTiming(scan, scan, scan.astype(float), revisit_period(t, scan),
                          "framed" if framed else "rotating")
    frame = np.cumsum(np.concatenate([[False], np.diff(t) > 0.0])).astype(np.int64)
    revisit = free_revisit(t, p, R, frame)
    clock = (t - t[0]) / revisit if t.size else np.zeros(0)
    return PlotTiming(frame, np.floor(clock).astype(np.int64), clock, revisit, "free")


def free_revisit(t: np.ndarray, p: np.ndarray, R: np.ndarray, frame: np.ndarray) -> float:
    """Revisit period (s) of plots in no scan order (arguments as :func:`track_plots`): the
    median time between consecutive plots of the confirmed tracks with at least
    ``REVISIT_MIN_HITS`` plots, tracked with a trial revisit; tracked again with the estimate
    until the two agree to ``REVISIT_AGREEMENT`` (at most four times). A trial that confirms
    no such track is doubled, up to ``REVISIT_MAX``; with none even then, ``REVISIT_MAX``."""
    trial = REVISIT_TRIAL
    for _ in range(4):
        label = track_plots(t, p, R, frame, (t - t[0]) / trial)
        steps = [np.diff(t[label == k]) for k in range(int(label.max()) + 1)
                 if np.count_nonzero(label == k) >= REVISIT_MIN_HITS]
        if not steps:
            if trial >= REVISIT_MAX:
                return REVISIT_MAX
            trial = min(2.0 * trial, REVISIT_MAX)
            continue
        estimate = float(np.median(np.concatenate(steps)))
        estimate = min(max(estimate, 1e-3), REVISIT_MAX)
        if abs(estimate - trial) <= REVISIT_AGREEMENT * trial:
            return estimate
        trial = estimate
    return trial


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
    the clock (scans or revisits, :class:`PlotTiming`) of its first and last plot."""

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
    """CV prediction of L tracks to times ``t`` (A,): states x (L, 6) and covariances
    P (L, 6, 6) at their times ``t_track`` (L,) s -> states (L, A, 6), covariances
    (L, A, 6, 6)."""
    dt = np.asarray(t, dtype=float)[None, :] - np.asarray(t_track, dtype=float)[:, None]
    shape = dt.shape
    F = np.broadcast_to(np.eye(6), (*shape, 6, 6)).copy()
    for k in range(3):
        F[..., k, k + 3] = dt
    q = ACCELERATION_PSD
    Q = np.zeros((*shape, 6, 6))
    for k in range(3):
        Q[..., k, k] = q * np.abs(dt) ** 3 / 3
        Q[..., k, k + 3] = Q[..., k + 3, k] = q * dt * np.abs(dt) / 2
        Q[..., k + 3, k + 3] = q * np.abs(dt)
    xp = np.einsum("laij,lj->lai", F, x)
    Pp = F @ P[:, None] @ np.swapaxes(F, -1, -2) + Q
    return xp, Pp


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


def track_plots(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                clock: np.ndarray | None = None) -> np.ndarray:
    """(N,) int64 track label per plot (0, 1, ... in order of confirmation; -1 = clutter).

    t: (N,) s ascending; p: (N, 3) ENU m; R: (N, 3, 3) m^2; scan: (N,) the frames plots are
    assigned in (:class:`PlotTiming`; a scanning radar's scan numbers); clock: (N,) float,
    the time in scans or revisits that counts misses and confirmation (default: ``scan``).
    See the module docstring for the method.
    """
    if clock is None:
        clock = np.asarray(scan, dtype=float)
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    live: list[_Track] = []
    done: list[_Track] = []
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    for rows in np.split(order, bounds):
        k = float(clock[rows[0]])
        cost = np.full((rows.size, len(live)), np.inf)
        if live:                                     # every live track against every plot
            xs, Ps = predict_tracks(np.stack([tr.x for tr in live]),
                                    np.stack([tr.P for tr in live]),
                                    np.array([tr.t for tr in live]), t[rows])
            S = Ps[:, :, :3, :3] + R[rows][None]
            d = p[rows][None] - xs[:, :, :3]
            m2 = np.einsum("lai,lai->la", d, np.linalg.solve(S, d[..., None])[..., 0])
            ok = (m2 <= gate).T                      # (A, L)
            with np.errstate(invalid="ignore"):      # a pair outside the gate may be NaN
                cost[ok] = (m2 + np.linalg.slogdet(S)[1]).T[ok]
        taken = np.zeros(rows.size, dtype=bool)
        if live and rows.size:
            big = 1e12
            a_idx, j_idx = linear_sum_assignment(np.where(np.isfinite(cost), cost, big))
            for a, j in zip(a_idx, j_idx):
                if np.isfinite(cost[a, j]):
                    update_track(live[j], xs[j, a], Ps[j, a], p[rows[a]], R[rows[a]], t[rows[a]], k,
                                 int(rows[a]))
                    taken[a] = True
        for tr in live:
            if not tr.confirmed and tr.hits >= CONFIRM_HITS:
                tr.confirmed = True
        keep = []
        for tr in live:
            missed = k - tr.last_scan
            expired = (missed >= MAX_MISSES if tr.confirmed
                       else k - tr.first_scan >= CONFIRM_SCANS - 1 and tr.hits < CONFIRM_HITS)
            (done if expired else keep).append(tr)
        live = keep
        for a in np.flatnonzero(~taken):
            i = int(rows[a])
            live.append(start_track(p[i], R[i], t[i], k, i))
    done.extend(live)
    label = np.full(t.size, -1, dtype=np.int64)
    confirmed = sorted((tr for tr in done if tr.confirmed), key=lambda tr: tr.rows[0])
    for n, tr in enumerate(confirmed):
        label[np.asarray(tr.rows)] = n
    return label
