"""Track initialisation: automatic from the first usable position fixes, or from a given
initial state (``[[targets]] initial``) where the data cannot start a track by themselves."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rangeproc.errors import DataError
from rangeproc.fusion.assemble import assumed_elevation
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import CARTESIAN, SPHERICAL
from rangeproc.models.motion import N_KINEMATIC

#: Prior 1-sigma around the fitted start (m, m/s, m/s^2): generous, so that the prior does not
#: bias the smoothed start and early good rows pass the gate.
PRIOR_SIGMA = (100.0, 50.0, 30.0)
#: A start fix farther than this many of its accuracies from the Huber line, or from the
#: redescending line (``_redescending_line``) by this many of its accuracies and of that
#: line's robust scale, is gross: the start takes the redescending line.
GROSS_START_SIGMAS = 10.0
#: A start fix this many of its accuracies from the Huber line may hide a gross one that
#: leaned the line: the redescending line is then fitted to look (with five fixes, one plot
#: 17 accuracies off the others lay 7.4 from the Huber line).
LEANED_START_SIGMAS = 5.0
#: Tukey biweight constant (95 % efficiency under Gaussian errors).
TUKEY_C = 4.685
#: Where the start found gross fixes among the first, the prior's position 1-sigma is
#: narrowed (from ``PRIOR_SIGMA[0]``, never below the fit's robust scale) so that the nearest
#: gross fix lies this many sigmas from the start, beyond any gate: a prior as wide as 100 m
#: let the filter take the very outlier the fit left out (a clutter plot 130 m off a boat's
#: first plots), and the track started on it.
START_GATE_SIGMAS = 6.0


class NoPositionFix(DataError):
    """No row of the batch fixes a position, so the track cannot start by itself."""


@dataclass(frozen=True, slots=True)
class Prior:
    """A given state of the target: time ``t`` (s), state ``x`` (9,) and covariance ``P``
    (9, 9) in the range ENU frame (m, m/s, m/s^2)."""

    t: float
    x: np.ndarray
    P: np.ndarray


def given_prior(t: float, position: np.ndarray, velocity: np.ndarray, sigma_position: float,
                sigma_velocity: float) -> Prior:
    """A :class:`Prior` from a stated position (3,) m and velocity (3,) m/s in range ENU with
    1-sigma per axis; the acceleration is unknown (``PRIOR_SIGMA``'s acceleration sigma)."""
    x = np.zeros(N_KINEMATIC)
    x[0:3], x[3:6] = position, velocity
    P = np.diag([sigma_position ** 2] * 3 + [sigma_velocity ** 2] * 3
                + [PRIOR_SIGMA[2] ** 2] * 3)
    return Prior(float(t), x, P)


def prior_at(prior: Prior, t0: float) -> tuple[np.ndarray, np.ndarray]:
    """The prior moved to time ``t0`` (s) by the constant-acceleration model (forward or
    backward: ``x(t0) = F(t0 - t) x``, ``P = F P F^T``; the acceleration sigma already covers
    the manoeuvre between the two times)."""
    dt = float(t0 - prior.t)
    x = prior.x.copy()
    P = prior.P.copy()
    F1 = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    F = np.kron(F1, np.eye(3))
    x = F @ x
    P = F @ P @ F.T
    return x, 0.5 * (P + P.T)




def fix_rows(batch: MeasurementBatch) -> np.ndarray:
    """(M,) indices of the rows that fix position on their own (:func:`position_fixes`),
    without computing the positions: GPS rows with a full position and radar/theodolite rows
    with range, azimuth and elevation, or, where fewer than two such rows exist, rows with
    range and azimuth but no elevation (a 2-D radar's plots in its horizontal plane)."""
    z = batch.z
    cart = (batch.model == CARTESIAN) & np.isfinite(z[:, :3]).all(axis=1)
    sph = (batch.model == SPHERICAL) & np.isfinite(z[:, :3]).all(axis=1)
    fixes = cart | sph
    if np.count_nonzero(fixes) < 2:
        fixes |= ((batch.model == SPHERICAL) & np.isfinite(z[:, :2]).all(axis=1)
                  & ~np.isfinite(z[:, 2]))
    return np.flatnonzero(fixes)


def position_fixes(batch: MeasurementBatch, rows: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows that fix position on their own and the fixed positions.

    Returns (row indices (M,), positions (M, 3) range ENU m, 1-sigma (M,) m, a scalar
    accuracy used as the fit weight; without the height of an assumed elevation): GPS rows
    with a full position, and radar/theodolite rows with range, azimuth and elevation.
    Where fewer than two such rows exist, rows with range and azimuth but no elevation (a 2-D
    radar: a navigation radar's or a lidar's plots) are taken in the sensor's horizontal
    plane (elevation 0 ± :data:`PLANE_ELEVATION_SIGMA`): a start that the measured range and
    azimuth then correct, the height staying as uncertain as the assumption makes it.
    ``rows``: some of :func:`fix_rows`' indices (the track start's first seconds), whose
    positions alone are computed (each row's values are those of the call over every fix).
    """
    rows = fix_rows(batch) if rows is None else rows
    zc = batch.z[rows]                       # a copy (index array)
    is_cart = batch.model[rows] == CARTESIAN
    is_plane = ~is_cart & ~np.isfinite(zc[:, 2])    # a fix without elevation: 2-D plane
    local = np.empty((len(rows), 3))
    zc[is_plane, 2] = 0.0
    local[is_cart] = zc[is_cart, :3]
    r, az, el = zc[~is_cart, 0], zc[~is_cart, 1], zc[~is_cart, 2]
    local[~is_cart] = np.column_stack([r * np.sin(az) * np.cos(el), r * np.cos(az) * np.cos(el),
                                       r * np.sin(el)])
    # local = Qr (p - s)  =>  p = s + Qr^T local
    pos = batch.s[rows] + np.einsum("nji,nj->ni", batch.Qr[rows], local)
    sig = batch.sigma[rows].copy()
    # an assumed elevation (2-D radar, lidar) is the same plane for every fix: its vertical
    # spread is no measure of how far apart two fixes may lie, so it leaves the accuracy
    sig[is_plane | assumed_elevation(batch)[rows], 2] = 0.0
    acc = np.where(is_cart, np.sqrt(sig[:, 0] ** 2 + sig[:, 1] ** 2 + sig[:, 2] ** 2),
                   np.sqrt(sig[:, 0] ** 2 + (zc[:, 0] * sig[:, 1]) ** 2
                           + (zc[:, 0] * sig[:, 2]) ** 2))
    return rows, pos, acc


def _redescending_line(t: np.ndarray, p: np.ndarray, acc: np.ndarray, fallback: np.ndarray
                       ) -> np.ndarray:
    """(2, 3) [position; velocity] of a constant-velocity line through fixes ``p`` (K, 3) at
    times ``t`` (K,) s that ignores gross outliers: a Theil-Sen start (per axis, the median
    of the pairwise slopes), then Tukey's biweight (zero weight beyond ``TUKEY_C`` robust
    scales; scale = the larger of the fixes' median accuracy ``acc`` (K,) m and 1.4826 MAD
    of the distances). Huber weights cannot do this with few fixes: one plot of clutter
    kilometres away at the start of a surveillance radar's track still leaned its velocity
    by hundreds of m/s, the gate then rejected the object's own plots and the track left for
    a thousand kilometres. Returns the line and its robust scale (m); ``fallback`` and None
    when fewer than two fixes keep weight."""
    i, j = np.triu_indices(t.size, 1)
    dt = t[j] - t[i]
    ok = dt > 0.0
    if not ok.any():
        return fallback, None
    slope = np.median((p[j][ok] - p[i][ok]) / dt[ok, None], axis=0)
    coef = np.vstack([np.median(p - t[:, None] * slope, axis=0), slope])
    A = np.column_stack([np.ones_like(t), t])
    for _ in range(10):
        dist = np.linalg.norm(p - A @ coef, axis=1)
        scale = max(float(np.median(acc)), 1.4826 * float(np.median(dist)))
        u = dist / (TUKEY_C * scale)
        w = np.where(u < 1.0, (1.0 - u * u) ** 2, 0.0) / acc ** 2
        if np.count_nonzero(w) < 2 or np.ptp(t[w > 0]) <= 0.0:
            return fallback, None
        sw = np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(A * sw, p * sw, rcond=None)[0]
    return coef, scale


def initial_state(batch: MeasurementBatch, t0: float, *, window: float = 4.0,
                  n_min: int = 5, n_state: int = N_KINEMATIC) -> tuple[np.ndarray, np.ndarray]:
    """Prior state (n,) and covariance (n, n) at time ``t0`` (s).

    Fits position and velocity to the fixes of the first ``window`` seconds (at least
    ``n_min`` fixes) by iteratively reweighted least squares with Huber weights, so a wild
    point among the first fixes does not bias the start. Raises DataError when no sensor
    gives position fixes (angle-only or range-rate-only data cannot start a track alone).
    """
    rows = fix_rows(batch)
    if len(rows) < 2:
        present = sorted({batch.sensor_ids[i] for i in np.unique(batch.sensor)})
        raise NoPositionFix(f"cannot initialise the track: no position fixes from sensors "
                            f"({', '.join(present)}); need GPS or radar/theodolite rows with "
                            "range and azimuth, or a given initial state")
    t = batch.t[rows]
    take = t <= t[0] + window
    if take.sum() < n_min:
        take = np.arange(len(t)) < n_min
    tt = t[take] - t0
    _, pp, acc = position_fixes(batch, rows[take])    # only the fixes the start fits
    w = 1.0 / np.maximum(acc, 1e-3) ** 2
    A = np.column_stack([np.ones_like(tt), tt])
    coef = np.zeros((2, 3))
    for _ in range(10):
        Aw = A * np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(Aw, pp * np.sqrt(w)[:, None], rcond=None)[0]
        resid = np.linalg.norm(pp - A @ coef, axis=1) * np.sqrt(w)
        huber = np.where(resid <= 2.0, 1.0, 2.0 / np.maximum(resid, 1e-12))
        w = huber / np.maximum(acc, 1e-3) ** 2
    spread = np.linalg.norm(pp - A @ coef, axis=1) / np.maximum(acc, 1e-3)
    sp, sv, sa = PRIOR_SIGMA
    if len(tt) >= 3 and spread.max() > LEANED_START_SIGMAS:
        a = np.maximum(acc, 1e-3)
        robust, scale = _redescending_line(tt, pp, a, coef)
        off = np.linalg.norm(pp - A @ robust, axis=1)
        # gross: far off the line beyond its own accuracy and beyond the other fixes' spread
        # about it (a line through a turning object misses them all by its robust scale)
        gross = off > GROSS_START_SIGMAS * np.maximum(a, scale if scale is not None else 0.0)
        if scale is not None and gross.any():     # keep the gross fixes out of the gate too
            coef = robust
            sp = min(sp, max(scale, float(off[gross].min()) / START_GATE_SIGMAS))
        elif spread.max() > GROSS_START_SIGMAS:
            coef = robust
    x0 = np.zeros(n_state)
    x0[0:3] = coef[0]
    x0[3:6] = coef[1] if len(tt) > 1 and np.ptp(tt) > 0 else 0.0
    P0 = np.zeros((n_state, n_state))
    P0[np.arange(3), np.arange(3)] = sp ** 2 + float(np.median(acc)) ** 2
    P0[np.arange(3, 6), np.arange(3, 6)] = sv ** 2
    P0[np.arange(6, 9), np.arange(6, 9)] = sa ** 2
    return x0, P0
