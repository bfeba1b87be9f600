"""Physical limits: values no instrument can report truthfully are edited before estimation.

A single finite but absurd value (a range of 1e308 m, an elevation of 500 degrees, a GPS height
of 1e9 m) must never reach the estimator: it would overflow the whitened innovation, wreck the
track initialisation or drag the smoother. Each check edits only the offending component(s)
(set to NaN = not measured) and records it (reason ``limit`` or ``speed``); the rest of the
row is kept. A row with nothing left measured is removed.

Limits (SI; the bounds are settings of :class:`Limits`, in ``[processing]``):

* range (radar, theodolite laser): ``MIN_RANGE <= range <= max_range``;
* elevation: ``|E| <= pi/2``; azimuth and INS roll/yaw: ``|angle| <= 4 pi`` (any wrapped or
  unwrapped log fits; beyond that the value carries no angle); INS pitch ``|theta| <= pi/2``;
* height (GPS, INS): ``MIN_HEIGHT <= h <= max_range``;
* range rate (radar, MISTRAM) ``|Rdot| <= max_speed``; velocity (GPS, INS) ``|v| <= max_speed``
  (all three components edited together);
* ``speed``: a step between consecutive position fixes is impossible when the displacement
  exceeds ``max_speed * |dt| + tol``, ``tol = 10 (sigma_a + sigma_b) + 10 median |dp|`` with
  the stated position sigma of each fix and the sequence's median step (the noise of a fast
  sensor can exceed ``max_speed * dt``).
  GPS (one receiver on one object, it cannot jump): the fixes are cut into segments at the
  impossible steps; the longest segment is the anchor, and going outward from it each segment
  is kept only when the step from the last kept fix to it is possible (a run of wild fixes at
  the start, or a stretch of corrupt ones, is edited however long it is, as long as it is
  shorter than the good data).
  Fixed-site radar/theodolite with range, per track: an isolated spike, a fix whose steps
  to *both* neighbours are impossible, and a short run at either end of the track (at most
  a tenth of its fixes, ``EDGE_RUN_FRACTION``) cut off from the rest by an impossible step
  that the next step confirms (acquisition transients: a run of wild points at track start,
  which no local test sees when it is longer than its window). Any other jump stays: a track
  may legitimately jump to another object (a lock swap), which is for the association stage
  to sort out. Plots (radar rows
  without ``track_id``) and platform-mounted sensors are not speed-checked (several objects,
  a rotating deck frame).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rangeproc.config import HEIGHT_BOUNDS, SensorSettings
from rangeproc.editing.record import ALL_COMPONENTS, EditRecord
from rangeproc.frames.geodesy import aer_to_enu, geodetic_to_ecef
from rangeproc.io.logs import SensorLog, replace_columns, select_rows

#: Shortest range accepted (m): below any radar's blind range or laser ranger's minimum.
MIN_RANGE = 1.0
#: Lowest ellipsoidal height accepted (m): below the deepest ocean trench and geoid low
#: (the config's lowest site height too).
MIN_HEIGHT = HEIGHT_BOUNDS[0]
#: Largest |azimuth|, |roll|, |yaw| accepted (rad).
MAX_WRAPPED_ANGLE = 4.0 * math.pi
#: Multipliers of the speed test's noise tolerance.
SPEED_SIGMA_FACTOR = 10.0
SPEED_STEP_FACTOR = 10.0
#: A run of fixes at a track's start or end cut off by an impossible step is edited when it
#: holds at most 1/EDGE_RUN_FRACTION of the track's fixes.
EDGE_RUN_FRACTION = 10


@dataclass(frozen=True, kw_only=True, slots=True)
class Limits:
    """Physical limits: ``max_range`` (m, also the highest height), ``max_speed`` (m/s)."""

    max_range: float = 5.0e7
    max_speed: float = 2.0e4


def _out_of(v: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """True where a measured (non-NaN) value lies outside [lo, hi]."""
    with np.errstate(invalid="ignore"):
        return ~np.isnan(v) & ((v < lo) | (v > hi))


def _bounds(kind: str, lim: Limits) -> dict[str, tuple[float, float]]:
    """column -> (low, high) of the scalar limits of one sensor kind."""
    angle = (-MAX_WRAPPED_ANGLE, MAX_WRAPPED_ANGLE)
    elevation = (-0.5 * math.pi, 0.5 * math.pi)
    rng = (MIN_RANGE, lim.max_range)
    rate = (-lim.max_speed, lim.max_speed)
    height = (MIN_HEIGHT, lim.max_range)
    return {
        "radar": {"range": rng, "azimuth": angle, "elevation": elevation, "range_rate": rate},
        "theodolite": {"range": rng, "azimuth": angle, "elevation": elevation},
        "gps": {"height": height},
        "mistram": {"range_rate": rate},
        "ins": {"roll": angle, "pitch": elevation, "yaw": angle, "height": height},
    }[kind]


def _velocity_too_fast(log: SensorLog, lim: Limits) -> np.ndarray:
    if "ve" not in log.columns:
        return np.zeros(len(log), dtype=bool)
    v = np.column_stack([log.columns[c] for c in ("ve", "vn", "vu")])
    with np.errstate(over="ignore", invalid="ignore"):
        speed = np.sqrt(np.nansum(v * v, axis=1))
    return speed > lim.max_speed


def apply_limits(log: SensorLog, settings: SensorSettings, record: EditRecord,
                 limits: Limits) -> SensorLog:
    """Edit the values of one sensor outside physical limits (module docstring)."""
    if len(log) == 0:
        return log
    new: dict[str, np.ndarray] = {}

    def edit(col: str, bad: np.ndarray, reason: str) -> None:
        if not bad.any():
            return
        values = new.get(col, log.columns[col])
        record.add(log.sensor_id, reason, col, log.row[bad], log.time[bad], values[bad])
        out = np.array(values, dtype=float)
        out[bad] = np.nan
        new[col] = out

    for col, (lo, hi) in _bounds(log.kind, limits).items():
        edit(col, _out_of(log.columns[col], lo, hi), "limit")
    if log.kind in ("gps", "ins"):
        fast = _velocity_too_fast(log, limits)
        for col in ("ve", "vn", "vu"):
            edit(col, fast & ~np.isnan(log.columns[col]), "limit")
    edited = replace_columns(log, new) if new else log
    spikes = speed_spikes(edited, settings, limits)
    if spikes is not None and spikes[1].any():
        cols, bad = spikes
        for col in cols:
            edit(col, bad & ~np.isnan(edited.columns[col]), "speed")
        edited = replace_columns(log, new)
    return drop_empty_rows(edited, record, "limit")


def drop_empty_rows(log: SensorLog, record: EditRecord, reason: str) -> SensorLog:
    """Remove rows with nothing measured left (INS: any attitude/position value missing; the
    rest of such a row is recorded with ``reason``, its edited components already were)."""
    if log.kind == "ins":
        need = ("roll", "pitch", "yaw", "lat", "lon", "height")
        empty = np.zeros(len(log), dtype=bool)
        for col in need:
            empty |= np.isnan(log.columns[col])
    else:
        empty = np.ones(len(log), dtype=bool)
        for values in log.columns.values():
            empty &= np.isnan(values)
    if not empty.any():
        return log
    if log.kind == "ins":   # the edited components were recorded; the rest of the row goes too
        record.add(log.sensor_id, reason, ALL_COMPONENTS, log.row[empty], log.time[empty])
    return select_rows(log, ~empty)


def _fixes(log: SensorLog, settings: SensorSettings
           ) -> tuple[tuple[str, ...], np.ndarray, np.ndarray, np.ndarray] | None:
    """Position fixes of a sensor for the speed test: (columns edited on failure, (N,) bool
    rows with a fix, (N, 3) positions (m, any Cartesian frame), (N,) stated 1-sigma (m))."""
    c = log.columns
    sig = settings.sigma
    if log.kind == "gps":
        have = ~(np.isnan(c["lat"]) | np.isnan(c["lon"]) | np.isnan(c["height"]))
        pos = np.full((len(log), 3), np.nan)
        if have.any():
            pos[have] = geodetic_to_ecef(c["lat"][have], c["lon"][have], c["height"][have])
        sigma = math.sqrt(2.0 * sig["horizontal"] ** 2 + sig["vertical"] ** 2)
        return ("lat", "lon", "height"), have, pos, np.full(len(log), sigma)
    if log.kind in ("radar", "theodolite") and settings.site is not None:
        r, az, el = c["range"], c["azimuth"], c["elevation"]
        have = ~(np.isnan(r) | np.isnan(az) | np.isnan(el))
        pos = np.full((len(log), 3), np.nan)
        if have.any():
            pos[have] = aer_to_enu(az[have], el[have], r[have])
        with np.errstate(invalid="ignore", over="ignore"):
            sigma = np.sqrt(sig["range"] ** 2 + (r * sig["azimuth"]) ** 2
                            + (r * sig["elevation"]) ** 2)
        return ("range", "azimuth", "elevation"), have, pos, sigma
    return None


def speed_spikes(log: SensorLog, settings: SensorSettings, limits: Limits
                 ) -> tuple[tuple[str, ...], np.ndarray] | None:
    """(columns, (N,) bool) fixes implying an impossible speed to both neighbours, per track
    (module docstring); None when the sensor is not speed-checked."""
    got = _fixes(log, settings)
    if got is None:
        return None
    cols, have, pos, sigma = got
    bad = np.zeros(len(log), dtype=bool)
    track = log.track_id if log.track_id is not None else np.zeros(len(log), dtype=np.int64)
    if log.kind == "gps":
        rows = np.flatnonzero(have)
        bad[rows] = _unreachable(log.time[rows], pos[rows], sigma[rows], limits.max_speed)
        return cols, bad
    for tid in np.unique(track[have]):
        if tid < 0:                                   # plots: several objects, not one path
            continue
        rows = np.flatnonzero(have & (track == tid))
        bad[rows[_spikes(log.time[rows], pos[rows], sigma[rows], limits.max_speed)]] = True
    return cols, bad


def _possible(t: np.ndarray, p: np.ndarray, sigma: np.ndarray, scale: float,
              max_speed: float, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """True where the step from fix ``a`` to fix ``b`` (index arrays) is physically possible."""
    tol = SPEED_SIGMA_FACTOR * (sigma[a] + sigma[b]) + SPEED_STEP_FACTOR * scale
    with np.errstate(invalid="ignore", over="ignore"):
        dist = np.linalg.norm(p[b] - p[a], axis=-1)
        return ~(dist > max_speed * np.abs(t[b] - t[a]) + tol)


def _median_step(p: np.ndarray) -> float:
    return float(np.median(np.linalg.norm(np.diff(p, axis=0), axis=1)))


def _spikes(t: np.ndarray, p: np.ndarray, sigma: np.ndarray, max_speed: float) -> np.ndarray:
    """(M,) bool over one time-ordered sequence of fixes: isolated impossible spikes."""
    m = t.size
    out = np.zeros(m, dtype=bool)
    if m < 3:
        return out
    k = np.arange(m - 1)
    wrong = ~_possible(t, p, sigma, _median_step(p), max_speed, k, k + 1)
    out[1:-1] = wrong[:-1] & wrong[1:]
    breaks = np.flatnonzero(wrong)
    if breaks.size == 0:
        return out
    longest = max(1, m // EDGE_RUN_FRACTION)
    first, last = int(breaks[0]), int(breaks[-1])     # steps first -> first + 1, ...
    if first + 1 <= longest and (first + 1 == m - 1 or not wrong[first + 1]):
        out[:first + 1] = True                        # a short run before the first break
    if m - 1 - last <= longest and (last == 0 or not wrong[last - 1]):
        out[last + 1:] = True                         # a short run after the last break
    return out


def _unreachable(t: np.ndarray, p: np.ndarray, sigma: np.ndarray,
                 max_speed: float) -> np.ndarray:
    """(M,) bool over one time-ordered sequence of fixes of one object: the fixes not reachable
    from the longest segment without an impossible step (module docstring, GPS)."""
    m = t.size
    out = np.zeros(m, dtype=bool)
    if m < 2:
        return out
    scale = _median_step(p)
    k = np.arange(m - 1)
    wrong = ~_possible(t, p, sigma, scale, max_speed, k, k + 1)
    if not wrong.any():
        return out
    starts = np.concatenate([[0], np.flatnonzero(wrong) + 1])
    ends = np.concatenate([starts[1:], [m]])                # segment j: rows starts[j]:ends[j]
    anchor = int(np.argmax(ends - starts))
    out[:] = True
    out[starts[anchor]:ends[anchor]] = False
    first = starts[anchor]                                  # earliest kept fix so far
    for j in range(anchor - 1, -1, -1):
        if _possible(t, p, sigma, scale, max_speed, np.array([ends[j] - 1]),
                     np.array([first]))[0]:
            out[starts[j]:ends[j]] = False
            first = starts[j]
    last = ends[anchor] - 1                                 # latest kept fix so far
    for j in range(anchor + 1, starts.size):
        if _possible(t, p, sigma, scale, max_speed, np.array([last]),
                     np.array([starts[j]]))[0]:
            out[starts[j]:ends[j]] = False
            last = ends[j] - 1
    return out
