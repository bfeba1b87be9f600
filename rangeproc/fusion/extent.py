"""The extent of an object measured by plots, estimated from the spread of its returns.

A radar or lidar that reports plots (rows without ``track_id``) of an extended object (a boat,
a ship) returns a point of the hull it sees, not the point the user's reference measures (a
GNSS antenna somewhere on the hull). The smoothed track follows the centre of the returns; the
reference point lies somewhere on the hull about it, an offset that changes slowly with the
aspect and does not average out. rangeproc reports the centre of the returns and widens its
horizontal covariance by the hull's spread, estimated per object from the returns themselves.

Each used plot row ``k`` of sensor ``i`` (range and azimuth measured) gives the horizontal
offset ``d_k`` (m, east and north) of the measured point from the smoothed track at the row's
epoch. Its second moment is modelled as the sensor's noise, along and across the line of
sight ``l_k`` (unit, horizontal) at range ``r_k``, plus the hull's spread along and across the
heading ``u_k`` (unit, from the smoothed velocity):

    E[d d^T] = n_r^2 l l^T + r^2 n_a^2 l' l'^T + L^2 u u^T + W^2 u' u'^T

(``'`` a quarter turn; rows slower than :data:`HEADING_SPEED` carry ``(L^2 + W^2) / 2 I``:
no heading). The four variances (m^2, rad^2) are the sensor's rows' Gaussian maximum
likelihood, kept non-negative (Fisher scoring, :func:`fit_extent`; rows beyond the 99.9 %
chi-square of the previous step left out of the next): the
noise lies in the sensor's frame and the hull in the object's, so the two separate as the
aspect turns against the line of sight (a random-matrix extent, Koch 2008, fitted in batch
over the smoothed track).

A hull that the rows cannot show is not a hull of 0: 45 radar plots of a 30 m ship over a
few turns cannot tell its hull from the radar's noise, and a sigma without it lies 3-7 times
inside the error. What the rows allow is kept instead: each of ``L^2``, ``W^2`` is its upper
confidence bound ``theta + z se`` (``z`` = :data:`UPPER_Z`, one-sided 95 %; ``se`` from the
fit's Fisher information ``2 (X^T X)^-1``, Wald), so a hull is reported as large as the rows
cannot exclude, at most their whole second moment along that axis about the track
(``mean (u . d)^2``, ``mean (u' . d)^2`` over the rows kept: the sensor's noise added to the
hull, so the hull is no larger) and never less than the estimate ``theta`` itself. Where the
fit cannot be made (fewer than :data:`MIN_ROWS` rows, or a singular information), that whole
second moment is the bound (a prior from the returns' spread across scans). A point target
seen by many rows (an aircraft's plots) gets ``z se``, which shrinks as ``1 / sqrt(rows)``
against its noise; a hull seen from turning aspects by many rows gets its estimate, about
``z se`` more.

The object's extent is the largest ``(L^2, W^2)`` over its plot sensors (a sensor that
returns the centroid of a cluster of hull points shows less of the hull than one that
returns a single point of it; the reference point can be anywhere on the hull). Objects with
GPS rows or rows of tracked instruments (``track_id``) get none: their position is the point
those sensors measure.
"""
from __future__ import annotations

from collections.abc import Callable

from dataclasses import dataclass

import numpy as np
from scipy.optimize import nnls

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH, CARTESIAN, SPHERICAL

#: The range component of a SPHERICAL row.
RANGE = 0
#: m/s: below this speed the smoothed velocity gives no heading; the extent counts equally
#: along every horizontal axis.
HEADING_SPEED = 1.0
#: Standard errors above the fitted hull variance at which its upper confidence bound is taken
#: (one-sided 95 %, a normal quantile).
UPPER_Z = 1.645
#: Rows a sensor needs for a fit.
MIN_ROWS = 20
#: Chi-square (2 dof, 99.9 %) beyond which a row is left out of the refit.
CHI2_2_999 = 13.8
#: Fisher-scoring steps of the fit (each with the weights and outliers of the one before).
SCORING_STEPS = 6
SQRT2 = float(np.sqrt(2.0))
#: Share of a row's modelled variance added to each axis so that its covariance stays
#: invertible (a fit with all of it along one axis).
FLOOR = 1e-6


@dataclass(frozen=True, kw_only=True, slots=True)
class Extent:
    """The hull's spread about the centre of the returns: ``along``, ``across`` (m^2) the
    variances along and across the heading; both 0 for a point."""

    along: float = 0.0
    across: float = 0.0

    @property
    def sigma(self) -> tuple[float, float]:
        """(along, across) 1-sigma, m."""
        return float(np.sqrt(self.along)), float(np.sqrt(self.across))


def plot_offsets(batch: MeasurementBatch, xs: np.ndarray, rows: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For SPHERICAL ``rows`` (M,) of ``batch`` with range and azimuth and the smoothed state
    at each row's epoch ``xs`` (M, >=6): the horizontal offset of the measured point from the
    state (M, 2) m (elevation, where not measured, the state's), the horizontal line of
    sight (M, 2) unit and the range (M,) m."""
    p, s, Q = xs[:, :3], batch.s[rows], batch.Qr[rows]
    r, a = batch.z[rows, RANGE], batch.z[rows, AZIMUTH]
    local = np.einsum("kij,kj->ki", Q, p - s)                 # d = Qr (p - s)
    el = batch.z[rows, 2]
    el = np.where(np.isfinite(el), el, np.arctan2(local[:, 2], np.hypot(local[:, 0],
                                                                        local[:, 1])))
    m = r[:, None] * np.c_[np.cos(el) * np.sin(a), np.cos(el) * np.cos(a), np.sin(el)]
    measured = s + np.einsum("kji,kj->ki", Q, m)              # s + Qr^T d
    los = (measured - s)[:, :2]
    los /= np.maximum(np.hypot(los[:, 0], los[:, 1]), 1e-9)[:, None]
    return (measured - p)[:, :2], los, r


def _outer(u: np.ndarray) -> np.ndarray:
    """(M, 2, 2) u u^T for unit vectors u (M, 2)."""
    return u[:, :, None] * u[:, None, :]


def _turn(u: np.ndarray) -> np.ndarray:
    """u turned a quarter (M, 2): the across axis of heading / line of sight u."""
    return np.c_[-u[:, 1], u[:, 0]]


def _entries(S: np.ndarray) -> np.ndarray:
    """(..., 3) the distinct entries of symmetric (..., 2, 2), the off-diagonal times sqrt 2
    (so that a whitened Wishart draw has variance 2 in each)."""
    return np.stack([S[..., 0, 0], S[..., 1, 1], SQRT2 * S[..., 0, 1]], axis=-1)


def _floored(C: np.ndarray) -> np.ndarray:
    """(M, 2, 2) symmetric C with its trace's :data:`FLOOR` share (and at least 1e-12 m^2)
    added on the diagonal: invertible where the fit puts all of a row's variance on one
    axis."""
    tr = np.maximum(C[:, 0, 0] + C[:, 1, 1], 1e-12 / FLOOR)
    return C + (FLOOR * tr)[:, None, None] * np.eye(2)


def _inverse(C: np.ndarray) -> np.ndarray:
    """(M, 2, 2) the inverse of symmetric positive definite C (M, 2, 2), in closed form."""
    det = C[:, 0, 0] * C[:, 1, 1] - C[:, 0, 1] * C[:, 1, 0]
    out = np.empty_like(C)
    out[:, 0, 0], out[:, 1, 1] = C[:, 1, 1], C[:, 0, 0]
    out[:, 0, 1], out[:, 1, 0] = -C[:, 0, 1], -C[:, 1, 0]
    return out / det[:, None, None]


def _inverse_root(C: np.ndarray) -> np.ndarray:
    """(M, 2, 2) C^(-1/2) of symmetric positive definite C (M, 2, 2)."""
    lam, V = np.linalg.eigh(C)
    lam = np.maximum(lam, FLOOR * np.maximum(lam[:, -1:], 1e-12))   # rounding below 0
    return np.einsum("kij,kj,klj->kil", V, 1.0 / np.sqrt(lam), V)


def fit_extent(d: np.ndarray, los: np.ndarray, r: np.ndarray, vel: np.ndarray) -> Extent:
    """The hull's variances (module docstring: their upper confidence bounds) from one
    sensor's offsets ``d`` (M, 2) m, lines of sight ``los`` (M, 2), ranges ``r`` (M,) m and
    smoothed velocities ``vel`` (M, 2) m/s.

    Fisher scoring of the Gaussian likelihood of ``d_k ~ N(0, C_k(theta))``, ``C_k`` linear in
    the four variances: each step a non-negative least-squares fit of the whitened
    ``C_k^(-1/2) d_k d_k^T C_k^(-1/2)`` to the whitened basis matrices, whose entries have
    variance 2 at the solution, so the fit's covariance is ``2 (X^T X)^-1``."""
    m = d.shape[0]
    speed = np.hypot(vel[:, 0], vel[:, 1])
    moving = (speed >= HEADING_SPEED)[:, None, None]
    u = vel / np.maximum(speed, 1e-9)[:, None]
    iso = 0.5 * np.eye(2)
    basis = np.stack([_outer(los), r[:, None, None] ** 2 * _outer(_turn(los)),
                      np.where(moving, _outer(u), iso),
                      np.where(moving, _outer(_turn(u)), iso)], axis=1)   # (M, 4, 2, 2)
    keep = np.ones(m, dtype=bool)
    if m < MIN_ROWS:
        return _whole_spread(d, basis, keep)
    D = d[:, :, None] * d[:, None, :]
    # start: the plots' spread as noise along and across the line of sight
    C = _floored(np.broadcast_to(np.mean(D, axis=0), (m, 2, 2)).copy())
    theta, cov = np.zeros(4), np.full((4, 4), np.inf)
    for _ in range(SCORING_STEPS):
        T = _inverse_root(C)
        X = _entries(np.einsum("kab,kibc,kcd->kiad", T, basis, T))        # (M, 4, 3)
        y = _entries(np.einsum("kab,kbc,kcd->kad", T, D, T))              # (M, 3)
        A = np.transpose(X[keep], (0, 2, 1)).reshape(-1, 4)
        b = y[keep].reshape(-1)
        scale = np.maximum(np.abs(A).max(axis=0), 1e-300)
        sol, _ = nnls(A / scale, b)
        theta = sol / scale
        try:
            cov = 2.0 * np.linalg.inv(A.T @ A)
        except np.linalg.LinAlgError:
            return _whole_spread(d, basis, keep)
        C = _floored(np.einsum("kiab,i->kab", basis, theta))
        m2 = np.einsum("ka,kab,kb->k", d, _inverse(C), d)
        if np.count_nonzero(m2 <= CHI2_2_999) < MIN_ROWS:
            return _whole_spread(d, basis, keep)
        keep = m2 <= CHI2_2_999
    se = np.sqrt(np.maximum(np.diag(cov)[2:], 0.0))
    whole = _whole_spread(d, basis, keep)
    upper = theta[2:] + UPPER_Z * se
    if not np.all(np.isfinite(upper)):
        return whole
    return Extent(along=max(float(theta[2]), min(float(upper[0]), whole.along)),
                  across=max(float(theta[3]), min(float(upper[1]), whole.across)))


def _whole_spread(d: np.ndarray, basis: np.ndarray, keep: np.ndarray) -> Extent:
    """The rows' whole second moment (m^2) along and across the heading about the track, the
    largest the hull can be (module docstring): ``mean d^T B d`` over the rows ``keep`` (M,)
    of offsets ``d`` (M, 2) m for the hull's basis matrices ``B`` (``basis[:, 2:]``, (M, 2, 2,
    2)); 0 without rows."""
    if not keep.any():
        return Extent()
    q = np.einsum("ka,kjab,kb->kj", d[keep], basis[keep, 2:], d[keep])
    return Extent(along=float(np.mean(q[:, 0])), across=float(np.mean(q[:, 1])))


def plots_only(batch: MeasurementBatch, radar: np.ndarray) -> bool:
    """Whether the object whose rows are ``batch`` is measured by plots (rows without
    ``track_id``) of radars or lidars (``radar`` (S,) bool: the sensors of kind radar) with
    range, and by no GPS or tracked instrument, whose point would be the one reported."""
    if np.any(batch.model == CARTESIAN):
        return False
    ranged = ((batch.model == SPHERICAL) & radar[batch.sensor]
              & np.isfinite(batch.z[:, RANGE]))
    return bool(ranged.any()) and not np.any(ranged & (batch.track >= 0))


def object_extent(batch: MeasurementBatch, xs: np.ndarray, used: np.ndarray,
                  radar: np.ndarray) -> Extent:
    """The extent (module docstring) of the object whose rows are ``batch``, with the
    smoothed state at each row's epoch ``xs`` (N, >=6) and the final pass's accepted
    components ``used`` (N, 6); ``radar`` (S,) bool: the sensors of kind radar. None (0) for
    an object with GPS or tracked-instrument rows, or without a radar's plots."""
    return largest_per_sensor(batch, xs, used, radar,
                              lambda rows, d, los, r: fit_extent(d, los, r, xs[rows, 3:5]))


def largest_per_sensor(batch: MeasurementBatch, xs: np.ndarray, used: np.ndarray,
                       radar: np.ndarray,
                       estimate: Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                                          Extent]) -> Extent:
    """The largest ``estimate`` per axis over the radar sensors whose plots measure the
    object alone (``plots_only``; else 0): ``estimate(rows, d, los, r)`` of each sensor's
    rows with accepted range and azimuth, given their offsets from the track
    (:func:`plot_offsets`). ``batch``, ``xs``, ``used``, ``radar`` as for
    :func:`object_extent`."""
    if not plots_only(batch, radar):
        return Extent()
    ranged = ((batch.model == SPHERICAL) & radar[batch.sensor] & used[:, RANGE]
              & used[:, AZIMUTH])
    best = Extent()
    for i in np.unique(batch.sensor[ranged]):
        rows = np.flatnonzero(ranged & (batch.sensor == i))
        e = estimate(rows, *plot_offsets(batch, xs[rows], rows))
        best = Extent(along=max(best.along, e.along), across=max(best.across, e.across))
    return best


def extent_covariance(extent: Extent, vel: np.ndarray) -> np.ndarray:
    """(K, 2, 2) m^2: the extent in east and north at epochs of horizontal velocity ``vel``
    (K, 2) m/s: along and across the heading, or ``(along + across) / 2`` on each axis below
    :data:`HEADING_SPEED`."""
    speed = np.hypot(vel[:, 0], vel[:, 1])
    moving = speed >= HEADING_SPEED
    u = np.where(moving[:, None], vel / np.maximum(speed, 1e-9)[:, None], 0.0)
    w = _turn(u)
    out = (extent.along * u[:, :, None] * u[:, None, :]
           + extent.across * w[:, :, None] * w[:, None, :])
    out[~moving] = 0.5 * (extent.along + extent.across) * np.eye(2)
    return out


def held_heading(vel: np.ndarray) -> np.ndarray:
    """(K,) rad clockwise from north: the heading of the horizontal velocity ``vel`` (K, 2)
    m/s where at least :data:`HEADING_SPEED`, else that of the nearest such epoch; all NaN
    when none is that fast."""
    speed = np.hypot(vel[:, 0], vel[:, 1])
    fast = np.flatnonzero(speed >= HEADING_SPEED)
    if fast.size == 0:
        return np.full(vel.shape[0], np.nan)
    k = np.arange(vel.shape[0])
    j = np.clip(np.searchsorted(fast, k), 1, fast.size - 1) if fast.size > 1 \
        else np.zeros(k.size, dtype=np.int64)
    if fast.size > 1:
        j = np.where(np.abs(fast[j - 1] - k) <= np.abs(fast[j] - k), j - 1, j)
    nearest = fast[j]
    return np.arctan2(vel[nearest, 0], vel[nearest, 1])


def lever_offset(heading: np.ndarray, lever_arm: tuple[float, float, float]) -> np.ndarray:
    """(K, 3) m east, north, up: a point at ``lever_arm`` (forward, right, down; m) in the
    body frame of an object at ``heading`` (K,) rad clockwise from north, level."""
    f, r, dn = lever_arm
    sh, ch = np.sin(heading), np.cos(heading)
    return np.c_[f * sh + r * ch, f * ch - r * sh, np.full(heading.size, -dn)]
