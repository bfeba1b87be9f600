"""A recorded trajectory as the simulator's truth: a real flight's shape over the simulated range.

``rangeproc simulate --trajectory FILE`` flies the scenario's sensors along a recorded track
(an ADS-B or GPS log, a planned trajectory) instead of a drawn one. The file has the truth
format of ``rangeproc evaluate`` (``evaluate.truth``: ``time``, then ``e, n, u`` or ``lat, lon,
height``; one object). The track is

* smoothed: each axis by a quintic spline, so that position, velocity and acceleration are
  continuous and the jerk is finite, as the constant-acceleration filters assume of any real
  flight. With velocities in the file (``ve, vn, vu``) the spline is the antiderivative of
  their quartic smoothing spline (noise :data:`RECORD_SIGMA_V`), placed onto the positions by
  a least-squares line (where the track is and its mean velocity): ADS-B positions repeat
  stale values and step, its velocities do not.
  Without, the positions' quintic smoothing spline (noise :data:`RECORD_SIGMA`). Smoothing
  factor ``S = M sigma^2`` for M samples (``scipy.interpolate.UnivariateSpline``; Dierckx
  1993, *Curve and Surface Fitting with Splines*, ch. 5);
* re-placed: its horizontal centre at :data:`PLACE_DISTANCE` from the range origin, on a
  bearing drawn from the scenario's trajectory stream, its heights kept (a geodetic file's
  heights above its own ellipsoid point, an ENU file's ``u``); so the scenario's sensors, drawn
  around the origin, see it as they see a drawn flight;
* re-timed: its first sample at the scenario's start time, at most ``duration`` seconds of it.

The smoothed spline *is* the truth (``truth.csv``, every sensor's rows): what the recording's
own noise hid is not in it, and that is the point: its maneuvers are a real aircraft's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pymap3d as pm
from scipy.interpolate import UnivariateSpline

from rangeproc.errors import DataError
from rangeproc.evaluate.truth import TruthTable, read_truth

#: Noise (1-sigma, m) the smoothing spline assumes in the recorded positions (ADS-B reports
#: positions to ~5 m and barometric altitude in 25 ft steps, ~2 m rms).
RECORD_SIGMA = 5.0
#: Noise (1-sigma, m/s) the smoothing spline assumes in recorded velocities (ADS-B reports
#: ground speed to 1 kt, track to ~0.1 deg, vertical rate in 64 ft/min steps, each updated
#: every second or two).
RECORD_SIGMA_V = 2.0
#: Distance (m) of the re-placed track's horizontal centre from the range origin.
PLACE_DISTANCE = 25e3
#: Node spacing (s) of the truth table (``truth.csv``), as the drawn trajectories' 100 Hz.
NODE_STEP = 0.01
#: Fewest samples of a usable recording (a quintic spline needs six).
MIN_SAMPLES = 12


@dataclass(frozen=True, slots=True)
class RecordedTrajectory:
    """A smoothed, re-placed recording with the interface of ``simulate.trajectory.Trajectory``
    that the scenario uses: ``t0`` (range time s of its start), ``duration`` (s), ``state(t)``
    and the 100 Hz nodes ``node_time``, ``node_p``, ``node_v``, ``node_a`` ((K, 3) range ENU,
    m, m/s, m/s^2). Each axis is its spline (of relative time) plus the line ``offset +
    drift tau`` ((3,) m and m/s)."""

    t0: float
    duration: float
    splines: tuple[UnivariateSpline, UnivariateSpline, UnivariateSpline]
    offset: np.ndarray
    drift: np.ndarray
    node_time: np.ndarray = field(init=False, repr=False)
    node_p: np.ndarray = field(init=False, repr=False)
    node_v: np.ndarray = field(init=False, repr=False)
    node_a: np.ndarray = field(init=False, repr=False)

    def state(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration, each (M, 3), at range times ``t`` (M,) s (a
        time outside the recording is extrapolated by the end polynomials: avoid). Each axis
        is its spline plus the line ``offset + drift tau``."""
        tau = np.asarray(t, dtype=float) - self.t0
        out = [np.column_stack([s.derivative(d)(tau) if d else s(tau) for s in self.splines])
               for d in range(3)]
        return (out[0] + self.offset + np.outer(tau, self.drift), out[1] + self.drift, out[2])

    def __post_init__(self) -> None:
        """The 100 Hz truth nodes, evaluated once."""
        t = self.t0 + NODE_STEP * np.arange(int(math.floor(self.duration / NODE_STEP)) + 1)
        p, v, a = self.state(t)
        for name, value in (("node_time", t), ("node_p", p), ("node_v", v), ("node_a", a)):
            object.__setattr__(self, name, value)


def read_track(path: Path, what: str) -> TruthTable:
    """A track file in the truth format of ``rangeproc evaluate``: one object, at least
    :data:`MIN_SAMPLES` rows (DataError naming the file otherwise; ``what`` it is for)."""
    table = read_truth(Path(path))
    name = Path(path).name
    if table.target_id is not None and len(set(table.target_id)) > 1:
        raise DataError(f"{name}: target_id: {what} is one object "
                        f"({len(set(table.target_id))} found)")
    if len(table.time) < MIN_SAMPLES:
        raise DataError(f"{name}: {len(table.time)} rows; {what} needs at least {MIN_SAMPLES}")
    return table


def read_recording(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Times (M,) s, positions (M, 3) and velocities (M, 3) or None, in a local ENU frame
    (m, m/s) of a recorded track: an ENU file as written, a geodetic one about its first
    point (velocities, local ENU at each point, rotated into that frame). DataError for several
    objects or too few samples."""
    table = read_track(Path(path), "a recorded trajectory")
    pos, vel = table.position, table.velocity
    if table.form == "geodetic":
        lat0, lon0 = pos[0, 0], pos[0, 1]
        e, n, u = pm.geodetic2enu(pos[:, 0], pos[:, 1], pos[:, 2], lat0, lon0, 0.0)
        if vel is not None:
            x, y, z = pm.enu2uvw(vel[:, 0], vel[:, 1], vel[:, 2], pos[:, 0], pos[:, 1])
            vel = np.column_stack(pm.uvw2enu(x, y, z, lat0, lon0))
        pos = np.column_stack([e, n, u])
    return table.time, pos, vel


def _axis_spline(tau: np.ndarray, p: np.ndarray, v: np.ndarray | None, smooth: bool
                 ) -> tuple[UnivariateSpline, float, float]:
    """Quintic spline of one position axis and the line ``a + b tau`` to add to it: the
    positions' (smoothing or interpolating) spline and no line, or, with velocities, the
    antiderivative of their quartic spline and the line (least squares) that puts it onto the
    positions: the positions fix where the track is and its mean velocity, the velocities its
    shape."""
    m = len(tau)
    if v is None:
        return UnivariateSpline(tau, p, k=5, s=m * RECORD_SIGMA ** 2 if smooth else 0.0), 0.0, 0.0
    ps = UnivariateSpline(tau, v, k=4, s=m * RECORD_SIGMA_V ** 2 if smooth else 0.0
                          ).antiderivative()
    b, a = np.polyfit(tau, p - ps(tau), 1)
    return ps, float(a), float(b)


def recorded_trajectory(t: np.ndarray, pos: np.ndarray, vel: np.ndarray | None, t0: float,
                        duration: float, bearing: float | None, smooth: bool = True
                        ) -> RecordedTrajectory:
    """Smooth, re-time and re-place a recorded track (module docstring).

    t: (M,) s ascending; pos: (M, 3) local ENU m; vel: (M, 3) m/s or None; t0: the scenario's
    start (range time s); duration: most seconds to keep; bearing: direction (rad, clockwise
    from north) of the track's horizontal centre from the range origin.
    """
    keep = t - t[0] <= duration + 1e-9
    tau = t[keep] - t[0]
    p = pos[keep]
    v = vel[keep] if vel is not None else None
    if len(tau) < MIN_SAMPLES:
        raise DataError(f"recorded trajectory: {len(tau)} samples in the first {duration:g} s; "
                        f"need at least {MIN_SAMPLES}")
    fits = [_axis_spline(tau, p[:, i], None if v is None else v[:, i], smooth)
            for i in range(3)]
    splines = tuple(f[0] for f in fits)
    own = np.array([f[1] for f in fits])               # the lines added to the splines
    drift = np.array([f[2] for f in fits])
    offset = own.copy()
    if bearing is not None:
        centre = (np.array([s(tau).mean() for s in splines[:2]]) + own[:2]
                  + drift[:2] * tau.mean())
        target = PLACE_DISTANCE * np.array([math.sin(bearing), math.cos(bearing)])
        offset[:2] += target - centre
    return RecordedTrajectory(float(t0), float(tau[-1]), splines, offset, drift)
