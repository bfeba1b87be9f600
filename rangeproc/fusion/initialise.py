"""Track initialisation: automatic from the first usable position fixes, or from a given
initial state (``[[targets]] initial``) where the data cannot start a track by themselves."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rangeproc.errors import DataError
from rangeproc.fusion.assemble import PLANE_ELEVATION_SIGMA
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import CARTESIAN, SPHERICAL
from rangeproc.models.motion import N_KINEMATIC

#: Prior 1-sigma around the fitted start (m, m/s, m/s^2): generous, so that the prior does not
#: bias the smoothed start and early good rows pass the gate.
PRIOR_SIGMA = (100.0, 50.0, 30.0)
#: A start fix farther than this many of its accuracies from the Huber line sends the start
#: to the redescending fit (``_redescending_line``); below it the Huber line stands.
GROSS_START_SIGMAS = 10.0
#: Tukey biweight constant (95 % efficiency under Gaussian errors).
TUKEY_C = 4.685


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




def position_fixes(batch: MeasurementBatch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows that fix position on their own and the fixed positions.

    Returns (row indices (M,), positions (M, 3) range ENU m, 1-sigma (M,) m, a scalar
    accuracy used as the fit weight): GPS rows with a full position, and radar/theodolite rows
    with range, azimuth and elevation. Where fewer than two such rows exist, rows with range
    and azimuth but no elevation (a 2-D radar: a navigation radar's or a lidar's plots) are
    taken in the sensor's horizontal plane (elevation 0 ± :data:`PLANE_ELEVATION_SIGMA`):
    a start that the measured range and azimuth then correct, the height staying as uncertain
    as the assumption makes it.
    """
    z = batch.z
    cart = (batch.model == CARTESIAN) & np.isfinite(z[:, :3]).all(axis=1)
    sph = (batch.model == SPHERICAL) & np.isfinite(z[:, :3]).all(axis=1)
    plane = np.zeros_like(sph)
    if np.count_nonzero(cart | sph) < 2:
        plane = ((batch.model == SPHERICAL) & np.isfinite(z[:, :2]).all(axis=1)
                 & ~np.isfinite(z[:, 2]))
    rows = np.flatnonzero(cart | sph | plane)
    local = np.empty((len(rows), 3))
    zc = z[rows].copy()
    is_cart = cart[rows]
    is_plane = plane[rows]
    zc[is_plane, 2] = 0.0
    local[is_cart] = zc[is_cart, :3]
    r, az, el = zc[~is_cart, 0], zc[~is_cart, 1], zc[~is_cart, 2]
    local[~is_cart] = np.column_stack([r * np.sin(az) * np.cos(el), r * np.cos(az) * np.cos(el),
                                       r * np.sin(el)])
    # local = Qr (p - s)  =>  p = s + Qr^T local
    pos = batch.s[rows] + np.einsum("nji,nj->ni", batch.Qr[rows], local)
    sig = batch.sigma[rows].copy()
    sig[is_plane, 2] = PLANE_ELEVATION_SIGMA
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
    a thousand kilometres. ``fallback`` is returned when fewer than two fixes keep weight."""
    i, j = np.triu_indices(t.size, 1)
    dt = t[j] - t[i]
    ok = dt > 0.0
    if not ok.any():
        return fallback
    slope = np.median((p[j][ok] - p[i][ok]) / dt[ok, None], axis=0)
    coef = np.vstack([np.median(p - t[:, None] * slope, axis=0), slope])
    A = np.column_stack([np.ones_like(t), t])
    for _ in range(10):
        dist = np.linalg.norm(p - A @ coef, axis=1)
        scale = max(float(np.median(acc)), 1.4826 * float(np.median(dist)))
        u = dist / (TUKEY_C * scale)
        w = np.where(u < 1.0, (1.0 - u * u) ** 2, 0.0) / acc ** 2
        if np.count_nonzero(w) < 2 or np.ptp(t[w > 0]) <= 0.0:
            return fallback
        sw = np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(A * sw, p * sw, rcond=None)[0]
    return coef


def initial_state(batch: MeasurementBatch, t0: float, *, window: float = 4.0,
                  n_min: int = 5, n_state: int = N_KINEMATIC) -> tuple[np.ndarray, np.ndarray]:
    """Prior state (n,) and covariance (n, n) at time ``t0`` (s).

    Fits position and velocity to the fixes of the first ``window`` seconds (at least
    ``n_min`` fixes) by iteratively reweighted least squares with Huber weights, so a wild
    point among the first fixes does not bias the start. Raises DataError when no sensor
    gives position fixes (angle-only or range-rate-only data cannot start a track alone).
    """
    rows, pos, acc = position_fixes(batch)
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
    pp = pos[take]
    w = 1.0 / np.maximum(acc[take], 1e-3) ** 2
    A = np.column_stack([np.ones_like(tt), tt])
    coef = np.zeros((2, 3))
    for _ in range(10):
        Aw = A * np.sqrt(w)[:, None]
        coef = np.linalg.lstsq(Aw, pp * np.sqrt(w)[:, None], rcond=None)[0]
        resid = np.linalg.norm(pp - A @ coef, axis=1) * np.sqrt(w)
        huber = np.where(resid <= 2.0, 1.0, 2.0 / np.maximum(resid, 1e-12))
        w = huber / np.maximum(acc[take], 1e-3) ** 2
    spread = np.linalg.norm(pp - A @ coef, axis=1) / np.maximum(acc[take], 1e-3)
    if len(tt) >= 3 and spread.max() > GROSS_START_SIGMAS:
        coef = _redescending_line(tt, pp, np.maximum(acc[take], 1e-3), coef)
    x0 = np.zeros(n_state)
    x0[0:3] = coef[0]
    x0[3:6] = coef[1] if len(tt) > 1 and np.ptp(tt) > 0 else 0.0
    P0 = np.zeros((n_state, n_state))
    sp, sv, sa = PRIOR_SIGMA
    P0[np.arange(3), np.arange(3)] = sp ** 2 + float(np.median(acc[take])) ** 2
    P0[np.arange(3, 6), np.arange(3, 6)] = sv ** 2
    P0[np.arange(6, 9), np.arange(6, 9)] = sa ** 2
    return x0, P0
