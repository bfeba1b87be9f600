"""From a FusionResult to the products: the output-grid track and per-sensor residuals."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rangeproc.estimation.linalg import unpack_many
from rangeproc.fusion.achievable import achievable_sigma
from rangeproc.fusion.bridge import bridge_gaps
from rangeproc.fusion.extent import Extent, extent_covariance, held_heading, lever_offset
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.io.memory import release_freed_between
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.fusion.support import left_out, supported
from rangeproc.models.measurement import COMPONENTS
from rangeproc.results import SensorResiduals, TrackEstimate


#: s: time stamps closer than this to an output interval's boundary count as on it. Float64
#: resolves about 0.24 us at Unix-scale times (1.8e9 s) and far finer at seconds of day, so
#: without it a sensor stamped exactly half an interval off the grid would fall into one
#: interval or the next depending on the time scale.
TIME_RESOLUTION = 1e-6


def epoch_of_rows(grid_t: np.ndarray, rate_hz: float, t: np.ndarray) -> np.ndarray:
    """(N,) int64: the index into ``grid_t`` (K,) of the output epoch whose interval
    [t_k - T/2, t_k + T/2) (T = 1 / ``rate_hz`` s) holds each time ``t`` (N,), or -1.

    The arithmetic runs in whole output intervals counted from ``grid_t[0]``, with boundaries
    resolved to :data:`TIME_RESOLUTION`, so that the same data give the same answer on Unix,
    GPS-week or seconds-of-day time scales (the grid need not be complete: bridged or left-out
    epochs are matched by their interval number)."""
    t = np.asarray(t, dtype=float)
    if len(grid_t) == 0 or t.size == 0:
        return np.full(t.size, -1, dtype=np.int64)
    ref = grid_t[0]
    grid_k = np.rint((grid_t - ref) * rate_hz).astype(np.int64)
    row_k = np.floor((t - ref + TIME_RESOLUTION) * rate_hz + 0.5).astype(np.int64)
    j = np.clip(np.searchsorted(grid_k, row_k), 0, grid_k.size - 1)
    return np.where(grid_k[j] == row_k, j, -1).astype(np.int64)


def _sensor_epochs(grid_t: np.ndarray, rate_hz: float, t_used: np.ndarray,
                   sensor_used: np.ndarray) -> dict[int, np.ndarray]:
    """sensor index -> (K,) bool: the epochs whose interval holds a used row of that sensor."""
    epoch = epoch_of_rows(grid_t, rate_hz, t_used)
    have = {}
    for sensor in np.unique(sensor_used):
        e = epoch[(sensor_used == sensor) & (epoch >= 0)]
        mask = np.zeros(len(grid_t), dtype=bool)
        mask[e] = True
        have[int(sensor)] = mask
    return have


def sensors_per_epoch(grid_t: np.ndarray, rate_hz: float, t_used: np.ndarray,
                      sensor_used: np.ndarray) -> np.ndarray:
    """(K,) distinct sensors with a used row in [t - T/2, t + T/2) around each grid epoch."""
    return _count(_sensor_epochs(grid_t, rate_hz, t_used, sensor_used), len(grid_t))


def epoch_provenance(grid_t: np.ndarray, rate_hz: float, t_used: np.ndarray,
                     sensor_used: np.ndarray, sensor_ids: tuple[str, ...]
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Per output epoch: the comma-separated ids of the sensors with a used row within the
    output interval around it (K,) and the time (s) to the nearest used row of any sensor (K,),
    rounded to :data:`TIME_RESOLUTION` (finer digits are the time scale's float rounding)."""
    _, names, gap = epoch_bookkeeping(grid_t, rate_hz, t_used, sensor_used, sensor_ids)
    return names, gap


def epoch_bookkeeping(grid_t: np.ndarray, rate_hz: float, t_used: np.ndarray,
                      sensor_used: np.ndarray, sensor_ids: tuple[str, ...]
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sensors_per_epoch` and :func:`epoch_provenance` from one matching of the rows
    to the epochs: (K,) sensor counts, (K,) sensor ids, (K,) s to the nearest used row."""
    k = grid_t.size
    have = _sensor_epochs(grid_t, rate_hz, t_used, sensor_used) if k else {}
    names = np.full(k, "", dtype=object)
    for sensor, mask in have.items():
        sid = sensor_ids[sensor]
        names[mask] = [f"{n},{sid}" if n else sid for n in names[mask]]
    return _count(have, k), names, _nearest_row_gap(grid_t, t_used)


def _count(have: dict[int, np.ndarray], k: int) -> np.ndarray:
    count = np.zeros(k, dtype=np.int64)
    for mask in have.values():
        count += mask
    return count


def _nearest_row_gap(grid_t: np.ndarray, t_used: np.ndarray) -> np.ndarray:
    """(K,) s from each epoch to the nearest used row, rounded to :data:`TIME_RESOLUTION`."""
    k = grid_t.size
    if k == 0:
        return np.zeros(0)
    ts = np.sort(t_used)
    if ts.size == 0:
        return np.full(k, np.inf)
    j = np.clip(np.searchsorted(ts, grid_t), 1, ts.size - 1) if ts.size > 1 else np.zeros(k, int)
    gap = np.abs(ts[j] - grid_t)
    if ts.size > 1:
        gap = np.minimum(gap, np.abs(ts[j - 1] - grid_t))
    return np.round(gap, 6)


def track_estimate(target_id: str, result: FusionResult, frame: RangeFrame,
                   rate_hz: float, max_bridge: float = 0.0,
                   stated: np.ndarray | None = None,
                   reference: Extent = Extent(),
                   lever_arm: tuple[float, float, float] | None = None,
                   with_achievable: bool = True) -> TrackEstimate:
    """The smoothed state on the output grid, with geodetic position and n_sensors; gaps
    between spans up to ``max_bridge`` s are filled by the least-squares fit of
    ``fusion.bridge``; epochs where the object's own rows reject the trajectory are left out
    (``fusion.support``; ``stated`` (S, 3): each sensor's stated sigmas of its first three
    components, ``fusion.support.position_rows``); with the achievable 1-sigma position of
    every epoch (``fusion.achievable``); the spread ``reference`` (m^2 along and across the
    heading, ``fusion.reference_point.reference_extent``) is added to the horizontal position
    covariance of every epoch, turned with the smoothed heading (``fusion.extent``); a
    ``lever_arm`` (forward, right, down; m) moves the reported point by it in the body frame
    of the smoothed heading (``fusion.extent.held_heading``; the velocity is left as it is).
    ``with_achievable`` False: ``achievable`` None, for :func:`with_achievable_sigma` once
    the result's covariances are let go (the products stage: a long sortie's peak)."""
    on_grid = None
    if with_achievable:     # its forward history let go before the grid's covariances unpack
        on_grid = achievable_sigma(result)
        release_freed_between(len(result.batch))   # and its freed pages before the grid's
    t = result.epoch_t[result.grid]
    x = result.xs[result.grid][:, :9]
    n = result.xs.shape[1]
    P = unpack_many(result.Ps[result.grid], n, 9)
    filled = np.zeros(t.size, dtype=bool)
    if max_bridge > 0.0 and len(result.spans) > 1:
        t, x, P, filled = bridge_gaps(t, x, P, result.q[result.grid], rate_hz, max_bridge)
    if reference.along > 0.0 or reference.across > 0.0:  # where the reference point can be
        P[:, :2, :2] += extent_covariance(reference, x[:, 3:5])    # (P: unpacked here)
    achievable = None
    if on_grid is not None:
        achievable = np.full((t.size, 3), np.nan)       # none inside a bridged gap
        achievable[~filled] = on_grid
    # none where its own rows reject it
    keep = supported(t, result.batch, result.used, result.res, stated)
    unwritten = left_out(t, keep)
    if not keep.all():                                  # (every epoch kept: no copies)
        t, x, P = t[keep], x[keep], P[keep]
        achievable = None if achievable is None else achievable[keep]
    if lever_arm is not None:                           # the user's point on the object
        x = x.copy()
        x[:, :3] += lever_offset(held_heading(x[:, 3:5]), lever_arm)
    lat, lon, h = frame.to_geodetic(x[:, :3])
    acc = result.used.any(axis=1)
    ns, names, gap = epoch_bookkeeping(t, rate_hz, result.batch.t[acc],
                                       result.batch.sensor[acc], result.batch.sensor_ids)
    prob = {}
    if result.model_prob is not None:
        for j, name in enumerate(result.model_names):
            p = np.full(filled.size, np.nan)
            p[~filled] = result.model_prob[result.grid][:, j]
            prob[name] = p[keep]
    return TrackEstimate(target_id=target_id, time=t, x=x, P=P, n_sensors=ns,
                         lat=np.asarray(lat), lon=np.asarray(lon), height=np.asarray(h),
                         spans=result.spans, model_prob=prob, sensors=names, data_gap=gap,
                         achievable=achievable, unwritten=unwritten)


def with_achievable_sigma(track: TrackEstimate, result: FusionResult) -> TrackEstimate:
    """``track`` (of ``result``, as :func:`track_estimate` made it without the achievable
    sigma, perhaps extended by ``fusion.formation``) with its ``achievable`` (K, 3) m: the
    achievable 1-sigma position (``fusion.achievable``) at the epochs that are the result's
    output epochs (found by time, outside the stretches left ``unwritten``), NaN elsewhere
    (bridged, extended). Reads the result's batch, states, noise and grid, not its
    covariances or residuals: a caller may have let those go first."""
    on_grid = achievable_sigma(result)
    release_freed_between(len(result.batch))
    grid_t = result.epoch_t[result.grid]
    t = track.time
    j = np.minimum(np.searchsorted(grid_t, t), max(grid_t.size - 1, 0))
    own = grid_t[j] == t if grid_t.size else np.zeros(t.size, dtype=bool)
    for first, last in track.unwritten:      # a grid epoch left out: an extension's epoch
        own &= (t < first) | (t > last)
    achievable = np.full((t.size, 3), np.nan)
    achievable[own] = on_grid[j[own]]
    return replace(track, achievable=achievable)


def sensor_residuals(target_id: str, result: FusionResult, sensor_index: int,
                     kind: str) -> SensorResiduals:
    """Residuals of one sensor's rows (only the components the sensor measured at all)."""
    b = result.batch
    rows = np.flatnonzero(b.sensor == sensor_index)
    model = int(b.model[rows[0]]) if len(rows) else 1
    names, units = COMPONENTS[model]
    have = [c for c in range(len(names)) if np.isfinite(b.z[rows, c]).any()]
    station = b.station[rows] if kind == "mistram" else None
    cells = np.ix_(rows, have)          # the measured columns gathered at once, no (n, 6) copies
    measured = np.isfinite(b.z[cells])
    return SensorResiduals(
        sensor_id=b.sensor_ids[sensor_index], kind=kind, target_id=target_id,
        components=tuple(names[c] for c in have), units=tuple(units[c] for c in have),
        time=b.t[rows], residual=result.res[cells], sigma=b.sigma[cells],
        rejected=measured & ~result.used[cells], nis=result.nis[rows], station=station)
