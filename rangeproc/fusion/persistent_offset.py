"""The part of a plot sensor's offsets from the track that persists from scan to scan.

A radar or lidar returns the point of a hull it sees, and that point wanders over the hull as
the aspect turns: slowly, over tens of scans, so that the offset of the returns from the
smoothed track is correlated from one scan to the next, where the sensor's noise is not. The
smoothed track follows the sensors' returns as a whole; where two sensors see different parts
of the hull (a radar the side facing it, a lidar a cluster of its near corner), or one sensor
sees a part that changes, the track lies between them and each sensor's returns sit off it by
a slowly varying offset. Those offsets are samples of how far points of the hull lie from the
track, and the reference point (a GNSS antenna) is another point of the same hull: their
second moment is a floor for the reference point's spread about the track.

For each plot sensor ``i`` of an object measured by plots alone, the mean horizontal offset
``m_s`` (m) of its used range-and-azimuth rows of each scan ``s`` (rows of one time stamp) from
the smoothed state (``fusion.extent.plot_offsets``; rows beyond the 99.9 % chi-square of their
stated noise left out: a wild row, or a stretch where the track left its rows) is paired
with that of the sensor's next scan of the object, ``m_s'``, where the two are at most
:data:`MAX_LAG` of the sensor's median scan interval apart (a missed scan or two). For
white noise ``E[m_s m_s'^T] = 0``; for an offset ``o`` that persists over the lag it is
``E[o o^T]``. The lag-one autocovariance

    V_i = mean over pairs of ( m_s m_s'^T + m_s' m_s^T ) / 2

is taken along and across the heading (the pair's mean velocity, from :data:`HEADING_SPEED`;
below it each axis gets half the trace) and counts only where its trace, the mean of
``m_s . m_s'``, exceeds :data:`SIGNIFICANCE` standard errors of that mean (its sample spread
over the pairs; a point target's offsets, white about the track, give 0). Negative diagonal
entries are 0. The object's floor is the largest per axis over its plot sensors; it joins the
other two estimates of the same spread in ``fusion.reference_point.reference_extent``.

This is the time-correlation test of Bryson and Henrikson (1968) applied to the residuals of a
plot sensor about the track: the part correlated across scans is a slowly varying offset (here
the hull), not noise. It leaves a sensor's estimate alone (the track stays where it is) and
widens only the reported covariance.
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.extent import HEADING_SPEED, Extent, largest_per_sensor
from rangeproc.models.measurement import AZIMUTH

#: The range component of a SPHERICAL row.
RANGE = 0
#: Consecutive scans of one sensor pair up where at most this many of its median scan
#: intervals apart (two missed scans at a detection probability of 0.9: 1 %).
MAX_LAG = 3.0
#: Chi-square (2 dof, 99.9 %) of a row's offset under its stated noise beyond which the row
#: is left out: a return that far from the track is no point of the hull the track follows
#: (a wild row, or a stretch where the track has left its rows).
CHI2_2_999 = 13.8
#: Scan pairs a sensor needs for an estimate.
MIN_PAIRS = 20
#: The lag-one autocovariance counts where its trace exceeds this many standard errors
#: (three sigma, one-sided 0.13 %).
SIGNIFICANCE = 3.0


def scan_means(t: np.ndarray, d: np.ndarray, vel: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sensor's rows grouped by time stamp: the scans' times (K,) s, mean offsets (K, 2) m
    and mean horizontal velocities (K, 2) m/s, from the rows' times ``t`` (M,), offsets ``d``
    (M, 2) and smoothed velocities ``vel`` (M, 2)."""
    ts, inv = np.unique(t, return_inverse=True)
    n = np.bincount(inv, minlength=ts.size).astype(float)

    def mean(a: np.ndarray) -> np.ndarray:
        return np.c_[np.bincount(inv, a[:, 0], ts.size), np.bincount(inv, a[:, 1], ts.size)] \
            / n[:, None]
    return ts, mean(d), mean(vel)


def lag_one_offset(t: np.ndarray, d: np.ndarray, vel: np.ndarray) -> Extent:
    """The persistent offset (module docstring; m^2 along and across the heading) of one
    sensor's rows at times ``t`` (M,) s with horizontal offsets ``d`` (M, 2) m from the track
    and the track's velocities ``vel`` (M, 2) m/s; 0 where not significant or too few
    pairs."""
    ts, m, v = scan_means(t, d, vel)
    if ts.size < MIN_PAIRS + 1:
        return Extent()
    dt = np.diff(ts)
    pair = dt <= MAX_LAG * float(np.median(dt))
    if pair.sum() < MIN_PAIRS:
        return Extent()
    a, b = m[:-1][pair], m[1:][pair]
    dot = np.einsum("ki,ki->k", a, b)                       # the trace of a b^T
    se = float(np.std(dot, ddof=1)) / np.sqrt(dot.size)
    if not float(np.mean(dot)) > SIGNIFICANCE * se:
        return Extent()
    vm = 0.5 * (v[:-1][pair] + v[1:][pair])
    speed = np.hypot(vm[:, 0], vm[:, 1])
    moving = speed >= HEADING_SPEED
    u = vm / np.maximum(speed, 1e-9)[:, None]
    w = np.c_[-u[:, 1], u[:, 0]]
    along = np.where(moving, np.einsum("ki,ki->k", a, u) * np.einsum("ki,ki->k", b, u),
                     0.5 * dot)
    across = np.where(moving, np.einsum("ki,ki->k", a, w) * np.einsum("ki,ki->k", b, w),
                      0.5 * dot)
    return Extent(along=max(0.0, float(np.mean(along))),
                  across=max(0.0, float(np.mean(across))))


def stated_m2(d: np.ndarray, los: np.ndarray, r: np.ndarray, s_r: np.ndarray,
              s_a: np.ndarray) -> np.ndarray:
    """(M,) the squared Mahalanobis distance of horizontal offsets ``d`` (M, 2) m under the
    rows' stated noise: ``s_r`` (M,) m along the line of sight ``los`` (M, 2) unit and
    ``r s_a`` (range (M,) m, azimuth sigma (M,) rad) across it."""
    along = np.einsum("ki,ki->k", d, los)
    across = d[:, 1] * los[:, 0] - d[:, 0] * los[:, 1]
    return (along / np.maximum(s_r, 1e-9)) ** 2 + (across / np.maximum(r * s_a, 1e-9)) ** 2


def persistent_offset(batch: MeasurementBatch, xs: np.ndarray, used: np.ndarray,
                      radar: np.ndarray) -> Extent:
    """The largest persistent offset (module docstring) per axis over the plot sensors of the
    object whose rows are ``batch``, with the smoothed state at each row's epoch ``xs`` (N, >=6)
    and the final pass's accepted components ``used`` (N, 6); ``radar`` (S,) bool: the sensors
    of kind radar. None (0) for an object with GPS or tracked-instrument rows, or without a
    radar's plots."""
    def estimate(rows: np.ndarray, d: np.ndarray, los: np.ndarray, r: np.ndarray) -> Extent:
        near = stated_m2(d, los, r, batch.sigma[rows, RANGE], batch.sigma[rows, AZIMUTH]) \
            <= CHI2_2_999
        return lag_one_offset(batch.t[rows][near], d[near], xs[rows[near], 3:5])

    return largest_per_sensor(batch, xs, used, radar, estimate)
