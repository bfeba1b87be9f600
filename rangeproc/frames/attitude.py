"""Platform attitude: body FRD -> local NED rotations and their gap-aware interpolation in time.

Conventions (DATA_CONTRACT section 1):

- Body frame FRD: x forward (bow), y right (starboard), z down.
- Attitude (roll, pitch, yaw) in **radians**, aerospace 3-2-1 sequence relative to the local NED
  frame at the platform: body-to-NED ``C = Rz(yaw) @ Ry(pitch) @ Rx(roll)``, so that
  ``v_ned = C @ v_body``. Yaw 0 = north, positive turning right; pitch positive bow up; roll
  positive starboard down.
- ``NED_TO_ENU`` maps a NED vector to the same vector in ENU (swap north/east, negate down).

Rotations are :class:`scipy.spatial.transform.Rotation` objects; interpolation is spherical
linear (:class:`~scipy.spatial.transform.Slerp`) on the rotation group, so yaw 359 deg -> 1 deg
passes through 0 deg, never 180 deg.

Time series helpers (used also by :mod:`rangeproc.frames.platform`): :func:`clean_series`
(drop non-finite rows, deduplicate equal times keeping the first), :func:`locate` (interval index
and gap-aware validity of query times) and :func:`rates_at_samples` (second-order derivative at
the samples from per-interval slopes, never across a gap).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation, Slerp

from rangeproc.errors import DataError

__all__ = [
    "NED_TO_ENU",
    "Located",
    "body_to_ned",
    "clean_series",
    "interpolate_attitude",
    "locate",
    "rates_at_samples",
]

log = logging.getLogger(__name__)

NED_TO_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
NED_TO_ENU.flags.writeable = False


def body_to_ned(roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike) -> Rotation:
    """Body FRD -> local NED rotation ``C = Rz(yaw) Ry(pitch) Rx(roll)`` (angles in rad).

    Inputs broadcast against each other; scalars give a single Rotation, (N,) arrays give N.
    """
    r, p, y = np.broadcast_arrays(
        np.asarray(roll, np.float64), np.asarray(pitch, np.float64), np.asarray(yaw, np.float64)
    )
    # intrinsic Z-Y'-X'' with angles (yaw, pitch, roll) == Rz(yaw) @ Ry(pitch) @ Rx(roll)
    return Rotation.from_euler("ZYX", np.stack([y, p, r], axis=-1))


def clean_series(
    t: ArrayLike, *columns: ArrayLike, source: str = "series", row: np.ndarray | None = None
) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """Prepare a time series for interpolation.

    Drops samples whose time or any column is non-finite (they become gaps), then, among equal
    times, keeps the first sample. Times must be non-decreasing (SensorLog is sorted).

    Args:
        t: (M,) sample times, s.
        columns: arrays with leading dimension M.
        source: name used in error messages (e.g. the sensor id).
        row: (M,) 1-based file row numbers for messages; default 1..M.

    Returns:
        (t_clean (K,), [column_clean ...], keep (M,) bool mask of the samples kept).

    Raises:
        DataError: times decrease somewhere.
    """
    t = np.asarray(t, np.float64).reshape(-1)
    cols = [np.asarray(c, np.float64) for c in columns]
    for c in cols:
        if c.shape[:1] != t.shape:
            raise ValueError(f"{source}: column length {c.shape[:1]} != time length {t.shape}")
    keep = np.isfinite(t)
    for c in cols:
        keep &= np.isfinite(c.reshape(t.shape[0], -1)).all(axis=1)
    idx = np.flatnonzero(keep)
    dt = np.diff(t[idx])
    bad = np.flatnonzero(dt < 0.0)
    if bad.size:
        i = idx[bad[0] + 1]
        r = int(row[i]) if row is not None else i + 1
        raise DataError(f"{source}: row {r}: column time: times must be sorted ascending")
    dup = np.flatnonzero(dt == 0.0) + 1  # later sample of each equal pair
    if dup.size:
        log.debug("%s: dropped %d samples with duplicate times", source, dup.size)
        keep[idx[dup]] = False
        idx = np.flatnonzero(keep)
    return t[idx], [c[idx] for c in cols], keep


@dataclass(frozen=True, slots=True)
class Located:
    """Where query times fall among samples ``t`` (K >= 2, strictly increasing).

    Attributes:
        k: (N,) int interval index in [0, K-2]; the query is evaluated between t[k] and t[k+1].
        frac: (N,) float in [0, 1], position of ``t_eval`` within interval k.
        t_eval: (N,) the time actually evaluated: the query time when valid, otherwise the
            nearest sample time (so invalid entries get the nearest sample's value, never NaN).
        valid: (N,) bool; False outside [t[0], t[-1]], for non-finite queries and inside an
            interval longer than ``max_gap`` (a query exactly on a sample is valid).
    """

    k: np.ndarray
    frac: np.ndarray
    t_eval: np.ndarray
    valid: np.ndarray


def locate(t: np.ndarray, t_query: ArrayLike, max_gap: float) -> Located:
    """Locate ``t_query`` (any shape, flattened to (N,)) among strictly increasing ``t`` (K>=2)."""
    tq = np.asarray(t_query, np.float64).reshape(-1)
    n_int = t.shape[0] - 1
    finite = np.isfinite(tq)
    tq_c = np.clip(np.where(finite, tq, t[0]), t[0], t[-1])
    k = np.clip(np.searchsorted(t, tq_c, side="right") - 1, 0, n_int - 1)
    t_lo, t_hi = t[k], t[k + 1]
    on_sample = (tq_c == t_lo) | (tq_c == t_hi)
    valid = finite & (tq >= t[0]) & (tq <= t[-1]) & ((t_hi - t_lo <= max_gap) | on_sample)
    nearest = np.where(tq_c - t_lo <= t_hi - tq_c, t_lo, t_hi)
    t_eval = np.where(valid, tq_c, nearest)
    frac = np.clip((t_eval - t_lo) / (t_hi - t_lo), 0.0, 1.0)
    return Located(k=k, frac=frac, t_eval=t_eval, valid=valid)


def rates_at_samples(t: np.ndarray, slopes: np.ndarray, max_gap: float) -> np.ndarray:
    """Derivative at each sample from per-interval slopes, not differencing across gaps.

    With h1, h2 the lengths of the intervals left and right of sample k and s1, s2 their slopes,
    the rate is ``(h2 s1 + h1 s2) / (h1 + h2)`` (second-order central difference on a
    non-uniform grid, as ``numpy.gradient``); one-sided where one neighbour interval is longer
    than ``max_gap`` or missing; zero for an isolated sample.

    Args:
        t: (K,) strictly increasing sample times, s.
        slopes: (K-1, ...) slope over each interval.
        max_gap: intervals longer than this (s) are gaps.

    Returns:
        (K, ...) rate at each sample.
    """
    h = np.diff(t)
    ok = h <= max_gap
    extra = (1,) * (slopes.ndim - 1)
    pad = np.zeros((1,) + slopes.shape[1:])
    s_left = np.concatenate([pad, slopes])  # slope of interval k-1, for sample k
    s_right = np.concatenate([slopes, pad])  # slope of interval k, for sample k
    h_left = np.concatenate([[0.0], np.where(ok, h, 0.0)]).reshape(-1, *extra)  # 0 = unusable
    h_right = np.concatenate([np.where(ok, h, 0.0), [0.0]]).reshape(-1, *extra)
    both = (h_left > 0.0) & (h_right > 0.0)
    w_sum = np.where(both, h_left + h_right, 1.0)
    central = (h_right * s_left + h_left * s_right) / w_sum
    one_sided = np.where(h_left > 0.0, s_left, np.where(h_right > 0.0, s_right, 0.0))
    return np.where(both, central, one_sided)


def _check_max_gap(max_gap: float) -> float:
    max_gap = float(max_gap)
    if not max_gap > 0.0:
        raise ValueError(f"max_gap must be > 0 s, got {max_gap}")
    return max_gap


def interpolate_attitude(
    t: ArrayLike,
    roll: ArrayLike,
    pitch: ArrayLike,
    yaw: ArrayLike,
    t_query: ArrayLike,
    *,
    max_gap: float = 1.0,
    source: str = "INS",
) -> tuple[Rotation, np.ndarray]:
    """Body-to-NED attitude at ``t_query`` by Slerp between INS samples.

    Samples with a non-finite time or angle are dropped (they become gaps); among samples with
    equal times the first is kept. Queries outside [t0, t_end], or inside an interval between
    kept samples longer than ``max_gap`` seconds, are flagged invalid and get the attitude of
    the nearest sample (never NaN).

    Args:
        t: (M,) sample times, s, non-decreasing.
        roll, pitch, yaw: (M,) attitude, rad (see module conventions).
        t_query: (N,) query times, s (a scalar is treated as N = 1).
        max_gap: longest interval (s) interpolated across.
        source: name for error messages.

    Returns:
        (C (N rotations, body FRD -> NED), valid (N,) bool).

    Raises:
        DataError: times decrease, or fewer than 2 usable samples.
    """
    max_gap = _check_max_gap(max_gap)
    tc, (r, p, y), _ = clean_series(t, roll, pitch, yaw, source=source)
    if tc.shape[0] < 2:
        raise DataError(f"{source}: fewer than 2 rows with finite time, roll, pitch, yaw")
    loc = locate(tc, t_query, max_gap)
    rot = Slerp(tc, body_to_ned(r, p, y))(loc.t_eval)
    return rot, loc.valid
