"""Where an object measured by plots is: the spread of its reference point about the returns.

A radar or lidar that reports plots (rows without ``track_id``) of an extended object (a boat,
a ship) returns the centroid of what it sees of the hull, not the point the user's reference
measures (a GNSS antenna somewhere on the hull): the offset changes slowly with the aspect and
does not average out, and the smoother, which follows the returns, cannot see it. A user who
states a sensor's sigma as the spread of its plots about the reference (as the contract asks:
the 1-sigma error of a row) states that offset too, while the noise rangeproc estimates from
the residuals about the smoothed track holds only what the track does not absorb. Their
difference is the reference point's spread about the returns:

    v_i = ( max(0, s_r^2 - e_r^2) + R_i^2 max(0, s_a^2 - e_a^2) ) / 2

per horizontal axis (m^2), for each plot sensor ``i`` of the object with stated range and
azimuth sigmas ``s_r`` (m), ``s_a`` (rad), estimated noise ``e_r``, ``e_a`` and median range
``R_i`` (m); the range term lies along the line of sight and the azimuth term across it, so
each axis of an unknown heading gets half of both. The offset is one for every sensor (one
hull), and each ``v_i`` estimates it. A component whose estimated noise exceeds its stated
sigma, significantly for its rows (the variance ratio above ``1 + 3 sqrt(2 / n)``), gives the
excess ``e^2 - s^2`` instead: its rows spread about the track by more than the user stated,
by the hull's points (a ship's radar returns along a 30 m hull) or by rows of several things;
either way the smoother averages it down as white noise where it is not. The largest ``v_i``
is taken (a sigma too small is worse than one too large). It is one of three estimates of the same
spread: :func:`reference_extent` joins it with the hull's spread fitted from the returns
themselves (``fusion.extent``) and with the returns' offsets that persist from scan to scan
(``fusion.persistent_offset``), the largest per axis along and across the heading, and that
is added to the horizontal position covariance of every output epoch (a target's
``lever_arm`` moves the reported point and leaves the spread: the centre of the returns
wanders over the hull with the aspect by about as much). Objects with GPS rows or rows of
tracked instruments (``track_id``) get nothing: their position is that of the point those
sensors measure, and a sensor whose stated sigma is its noise (the simulator's, a calibrated
tracking radar's) gives 0.
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.extent import Extent
from rangeproc.models.measurement import AZIMUTH, CARTESIAN, SPHERICAL

#: The range component of a SPHERICAL row.
RANGE = 0
#: A sensor's estimated noise beyond its stated sigma counts where the variance ratio exceeds
#: 1 by this many of its standard errors (``sqrt(2 / n)`` for n rows).
EXCESS_SIGMAS = 3.0


def reference_variance(batch: MeasurementBatch, noise: dict[tuple[int, int], float],
                       stated: np.ndarray, radar: np.ndarray) -> float:
    """The horizontal reference-point variance (m^2 per axis, module docstring) of the object
    whose rows are ``batch``, with the estimated noise per (sensor index, component) ``noise``
    and the stated sigmas ``stated`` (S, 3) (range m, azimuth rad, elevation rad for a radar);
    ``radar`` (S,) bool: the sensors of kind radar (plots with range). 0 for an object with
    GPS or tracked-instrument rows, or without a radar's plots."""
    if np.any(batch.model == CARTESIAN):
        return 0.0
    ranged = ((batch.model == SPHERICAL) & np.isfinite(batch.z[:, RANGE])
              & radar[batch.sensor])
    if np.any(ranged & (batch.track >= 0)) or not ranged.any():
        return 0.0
    best = 0.0
    for i in np.unique(batch.sensor[ranged]):
        i = int(i)
        s_r, s_a = stated[i, RANGE], stated[i, AZIMUTH]
        e_r, e_a = noise.get((i, RANGE)), noise.get((i, AZIMUTH))
        if None in (e_r, e_a) or not (np.isfinite(s_r) and np.isfinite(s_a)):
            continue
        mine = ranged & (batch.sensor == i)
        r_med = float(np.median(batch.z[mine, RANGE]))
        n = int(mine.sum())
        v = 0.5 * (_share(s_r, e_r, n) + r_med**2 * _share(s_a, e_a, n))
        best = max(best, v)
    return float(best)


def _share(stated: float, estimated: float, n: int) -> float:
    """The variance of one component that the track does not show as noise: the stated
    variance beyond the estimated one, or the estimated beyond the stated where that excess
    is significant for ``n`` rows (the variance ratio above ``1 + EXCESS_SIGMAS sqrt(2 / n)``,
    a chi-square's three sigma); else 0."""
    if stated >= estimated:
        return stated**2 - estimated**2
    if estimated**2 > stated**2 * (1.0 + EXCESS_SIGMAS * np.sqrt(2.0 / max(n, 1))):
        return estimated**2 - stated**2
    return 0.0


def spread_extent(spread: np.ndarray | None) -> Extent:
    """The reference point's spread (m^2) about the track that the returns' spread within a
    scan ``spread`` ((2, 2) m^2 east and north, ``tracking.return_spread``; None: 0) shows:
    twice its largest eigenvalue, on both axes. The returns show the hull's side facing the
    sensor, and the hull reaches in any direction at most as far as along the longest spread
    it shows; the reference point lies anywhere on it, and so does the point the track
    follows (the returns the tracker took, one a scan): the difference of two points of one
    hull has twice the hull's spread."""
    if spread is None:
        return Extent()
    v = 2.0 * max(0.0, float(np.linalg.eigvalsh(spread)[-1]))
    return Extent(along=v, across=v)


def reference_extent(variance: float, fitted: Extent, persistent: Extent = Extent(),
                     spread: Extent = Extent()) -> Extent:
    """The spread (m^2, along and across the heading) of the reference point about the
    returns that the output carries: the largest, per axis, of the stated-sigma estimate
    ``variance`` (:func:`reference_variance`, one per horizontal axis), the hull's spread
    fitted from the returns ``fitted`` (``fusion.extent.object_extent``) and the offsets of
    the returns that persist from scan to scan ``persistent``
    (``fusion.persistent_offset.persistent_offset``) and the returns' spread within a scan
    ``spread`` (:func:`spread_extent`). Estimates of one spread, so the largest is taken, not
    their sum."""
    return Extent(along=max(variance, fitted.along, persistent.along, spread.along),
                  across=max(variance, fitted.across, persistent.across, spread.across))

