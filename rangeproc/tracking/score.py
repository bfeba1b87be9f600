"""How well measurement rows fit an object's trajectory: the log-likelihood ratio of association.

For a row ``z`` of a sensor and an object with smoothed state ``x(t)`` and covariance ``P(t)``
(9-state constant acceleration, range ENU), the predicted measurement is ``h(x(t_row))`` and
the innovation covariance ``S = H P Hᵀ + R``, with ``x``, ``P`` carried from the nearest
output epoch to the row time by the constant-acceleration model (its white-jerk noise ``q``
growing ``P`` across a gap: the bridged prediction of He 2015). The row's log-likelihood
ratio of "this object" against "something else in view" is the robust mixture

    llr = log((1 - eps) N(z - h; 0, S) / p_other + eps),

``p_other`` the density of an unrelated measurement (uniform over ``EXTENT`` per component:
100 km of range, a turn of azimuth, a quarter turn of elevation, 2 km/s of range rate, 100 km
per Cartesian axis), ``eps = OUTLIER_PROBABILITY``. A wild row therefore costs at most
``log eps`` instead of arbitrarily much, and a row of another object costs just that. A
segment's score is the sum over its rows: the track-oriented score of He 2015's association
"by position, time and heading" (the whole time series of the segment is compared, so its
velocity and heading are compared too).

Sensor biases are not yet registered when segments are associated, so a constant offset per
component (the segment's median residual, clipped to ``BIAS_TOLERANCE`` and to
``BIAS_SIGMAS`` of the segment's stated sigma) is removed first:
an unregistered 15 m range bias or 0.5 mrad azimuth bias must not make a sensor's segment
look like another object.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numba import njit

from rangeproc.estimation.kernels import add_q, left_f, predict_state, right_f_t
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH, N_COMPONENTS, SPHERICAL, measure, wrap_angle
from rangeproc.models.motion import speed_manoeuvre_psd, white_acceleration_q

#: Leading state columns a measurement Jacobian can be non-zero in (position, velocity;
#: ``models.measurement.measure``).
N_KINEMATIC_COLUMNS = 6
#: Probability that a row of the object is an outlier (its cost is at most log of this).
OUTLIER_PROBABILITY = 0.01
#: Evidence that decides between objects: a row or segment goes to its best object only when
#: it is this many nats (log-likelihood ratio) likelier there than under any other (a factor
#: of 100; the cameras' angle-only plots, ``tracking.angle_plots``, and the relays,
#: ``tracking.links``).
AMBIGUITY_NATS = float(np.log(100.0))
#: Extent per component of an unrelated measurement: spherical (range m, azimuth rad,
#: elevation rad, range rate m/s), Cartesian (m per axis, m/s per axis).
EXTENT_SPHERICAL = np.array([1.0e5, 2.0 * math.pi, 0.5 * math.pi, 2.0e3, 1.0, 1.0])
EXTENT_CARTESIAN = np.array([1.0e5, 1.0e5, 1.0e5, 2.0e3, 2.0e3, 2.0e3])
#: Largest constant offset per component removed before scoring: spherical (m, rad, rad,
#: m/s), Cartesian (m, m/s).
BIAS_TOLERANCE_SPHERICAL = np.array([50.0, 2e-3, 2e-3, 1.0, 0.0, 0.0])
BIAS_TOLERANCE_CARTESIAN = np.array([10.0, 10.0, 10.0, 0.5, 0.5, 0.5])
#: ... and at most this many of the segment's stated 1-sigma per component: a sensor's
#: unregistered bias is a few of its sigmas, and a larger tolerance would let the rows of a
#: nearby object (two boats 20 m apart seen by a 2 m lidar) fit after the offset.
BIAS_SIGMAS = 3.0


@dataclass(frozen=True, slots=True)
class ObjectTrack:
    """An object's smoothed trajectory for scoring: ``t`` (E,) s ascending, ``x`` (E, 9)
    [p, v, a] range ENU, ``P`` (E, 9, 9) covariance, ``q`` (E,) white-jerk PSD (m^2/s^5);
    ``weighed``: sensor index -> (its rows' ``source_row`` (K,) ascending, the sigma (K, 6)
    the trajectory weighed each row's components with, inf where a component was not used),
    for the rows it was estimated from (:func:`weighed_sigma`); None: as stated."""

    t: np.ndarray
    x: np.ndarray
    P: np.ndarray
    q: np.ndarray
    weighed: Mapping[int, tuple[np.ndarray, np.ndarray]] | None = None


@njit(cache=True, nogil=True)
def _carry(x: np.ndarray, P: np.ndarray, dt: float, q: float, xo: np.ndarray,
           Po: np.ndarray) -> None:
    """Constant-acceleration prediction of a 9-state (3 axes) over ``dt`` (s, either sign)
    into xo, Po: the fusion's own prediction (``estimation.kernels``: ``F x``, ``F P F^T``
    through the structure of F, and the white-jerk noise, which a backward step adds with the
    velocity terms' sign flipped), with no allocation: this runs once per scored row."""
    for i in range(9):
        xo[i] = x[i]
    predict_state(xo, dt)
    left_f(P, Po, dt)
    right_f_t(Po, Po, dt)
    add_q(Po, dt, q)


@njit(cache=True, nogil=True)
def _add_manoeuvre(x: np.ndarray, Pe: np.ndarray, P: np.ndarray, dt: float) -> None:
    """Add to P (9, 9), carried ``dt`` s (either sign) beyond the object's span from its end
    state ``x`` (9,) with covariance ``Pe`` (9, 9), the white-acceleration noise of a
    manoeuvre the object's speed allows (``models.motion.manoeuvre_psd`` of that state; the
    bridge's gap noise, ``fusion.bridge``): the trajectory's own process noise says how the
    object moved while seen, nothing says it kept to that while unseen."""
    qm = speed_manoeuvre_psd(math.sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5]),
                             (Pe[3, 3] + Pe[4, 4] + Pe[5, 5]) / 3.0)
    q00, q01, q11 = white_acceleration_q(abs(dt), qm)
    if dt < 0.0:
        q01 = -q01
    for k in range(3):
        P[k, k] += q00
        P[k, k + 3] += q01
        P[k + 3, k] += q01
        P[k + 3, k + 3] += q11


@njit(cache=True, nogil=True)
def _nearest_epoch(ot: np.ndarray, t: float) -> int:
    """Index of the epoch of ``ot`` (E,) s nearest to ``t`` (the earlier one at a tie; the
    first or last outside the span)."""
    n_epochs = ot.shape[0]
    if n_epochs < 2:
        return 0
    e = min(max(np.searchsorted(ot, t), 1), n_epochs - 1)
    if abs(ot[e - 1] - t) <= abs(ot[e] - t):
        e -= 1
    return e


@njit(cache=True, nogil=True)
def row_geometry(sel: np.ndarray, t: np.ndarray, model: np.ndarray, z: np.ndarray,
                 sigma: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                 ot: np.ndarray, ox: np.ndarray, oP: np.ndarray, oq: np.ndarray,
                 extent_sph: np.ndarray, extent_cart: np.ndarray, epoch: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                            np.ndarray, np.ndarray]:
    """What the rows' scores need of the object, whatever offset is removed from ``z``.

    Rows ``sel`` (N,) of the batch's t, model, z (., 6), sigma (., 6), s, sv (., 3), Qr
    (., 3, 3), each carried from the object epoch ``epoch[i]`` (N,), or where that is -1
    from the epoch nearest in time (the earlier one at a tie; the first or last outside
    the object's span); the
    object: ot (E,), ox (E, 9), oP (E, 9, 9), oq (E,). Indexing happens here, without the
    GIL. Returns h (N, 6) the predicted measurement, L (N, 6, 6) the
    Cholesky factor of S = H P Hᵀ + R over the measured components (leading m x m block),
    m (N,) how many components are measured, idx (N, 6) which (first m), ok (N,) S positive
    definite, logdet (N,) log det S, log_ext (N,) log of the unrelated density's extent.
    """
    n = sel.shape[0]
    h_all = np.zeros((n, N_COMPONENTS))
    L = np.zeros((n, N_COMPONENTS, N_COMPONENTS))
    m_all = np.zeros(n, dtype=np.int64)
    idx_all = np.zeros((n, N_COMPONENTS), dtype=np.int64)
    ok = np.zeros(n, dtype=np.bool_)
    logdet_all = np.zeros(n)
    log_ext_all = np.zeros(n)
    x = np.empty(9)
    P = np.empty((9, 9))
    h = np.empty(N_COMPONENTS)
    H = np.empty((N_COMPONENTS, 9))
    HP = np.empty((N_COMPONENTS, 9))
    for i in range(n):
        r = sel[i]
        e = epoch[i] if epoch[i] >= 0 else _nearest_epoch(ot, t[r])
        _carry(ox[e], oP[e], t[r] - ot[e], oq[e], x, P)
        if t[r] < ot[0] or t[r] > ot[-1]:            # beyond the span: it may manoeuvre
            _add_manoeuvre(ox[e], oP[e], P, t[r] - ot[e])
        measure(model[r], x, s[r], sv[r], Qr[r], h, H)
        m = np.int64(0)            # not the literal 0: one compiled cholesky_inplace
        for c in range(N_COMPONENTS):
            if not math.isnan(z[r, c]):
                idx_all[i, m] = c
                m += 1
        m_all[i] = m
        if m == 0:
            continue
        for c in range(N_COMPONENTS):      # a row assignment compiles numba's
            h_all[i, c] = h[c]             # shape-mismatch message (text, seconds)
        S = L[i]
        log_ext = 0.0
        for a in range(m):                 # H P over the measured rows (H has no
            c = idx_all[i, a]              # acceleration columns)
            for l in range(9):
                acc = 0.0
                for k in range(N_KINEMATIC_COLUMNS):
                    acc += H[c, k] * P[k, l]
                HP[a, l] = acc
        for a in range(m):
            c = idx_all[i, a]
            log_ext += math.log(extent_sph[c] if model[r] == SPHERICAL else extent_cart[c])
            for b in range(m):
                cb = idx_all[i, b]
                acc = 0.0
                for l in range(N_KINEMATIC_COLUMNS):
                    acc += HP[a, l] * H[cb, l]
                S[a, b] = acc
            S[a, a] += sigma[r, c] * sigma[r, c]
        log_ext_all[i] = log_ext
        if not cholesky_inplace(S, m):
            continue
        ok[i] = True
        logdet = 0.0
        for a in range(m):
            logdet += 2.0 * math.log(S[a, a])
        logdet_all[i] = logdet
    return h_all, L, m_all, idx_all, ok, logdet_all, log_ext_all


@njit(cache=True, nogil=True)
def row_llr(sel: np.ndarray, model: np.ndarray, z: np.ndarray, offset: np.ndarray,
            h: np.ndarray,
            L: np.ndarray, m_rows: np.ndarray, idx: np.ndarray, ok: np.ndarray,
            logdet: np.ndarray, log_ext: np.ndarray, eps: float
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-row residual (N, 6), normalised innovation squared (N,) and llr (N,) of the
    batch rows ``sel`` (N,) of ``model``, ``z`` (., 6), less ``offset`` (N, 6) (a bias), from
    :func:`row_geometry`'s outputs for the same rows."""
    n = sel.shape[0]
    res = np.full((n, N_COMPONENTS), np.nan)
    nis = np.full(n, np.nan)
    llr = np.zeros(n)
    for i in range(n):
        m = m_rows[i]
        if m == 0:
            continue
        nu = np.empty(m)
        for a in range(m):
            c = idx[i, a]
            d = z[sel[i], c] - offset[i, c] - h[i, c]
            if model[sel[i]] == SPHERICAL and c == AZIMUTH:
                d = wrap_angle(d)
            nu[a] = d
            res[i, c] = d
        if not ok[i]:
            llr[i] = math.log(eps)
            continue
        w = nu.copy().reshape(m, 1)
        chol_solve_inplace(L[i], m, w, np.int64(1))
        d2 = 0.0
        for a in range(m):
            d2 += nu[a] * w[a, 0]
        nis[i] = d2
        log_ratio = -0.5 * d2 - 0.5 * logdet[i] - 0.5 * m * math.log(2.0 * math.pi) + log_ext[i]
        llr[i] = mixture_llr(log_ratio, eps)
    return res, nis, llr


@njit(cache=True, nogil=True)
def mixture_llr(log_ratio: float, eps: float) -> float:
    """A row's llr from its Gaussian log ratio against the unrelated density: the mixture
    ``log((1 - eps) exp(log_ratio) + eps)`` (an outlier of the object costs at most log eps),
    without overflow."""
    if log_ratio > 700.0:
        return log_ratio + math.log(1.0 - eps)
    return math.log((1.0 - eps) * math.exp(log_ratio) + eps)


def _geometry(batch: MeasurementBatch, sel: np.ndarray, track: ObjectTrack,
              epoch: np.ndarray | None = None) -> tuple:
    """:func:`row_geometry` of ``batch`` rows ``sel`` against ``track`` (from its epochs
    ``epoch`` (N,) where given, else the nearest)."""
    if epoch is None:
        epoch = np.full(sel.size, -1, dtype=np.int64)
    return row_geometry(sel, batch.t, batch.model, batch.z, batch.sigma, batch.s, batch.sv,
                        batch.Qr, track.t, track.x, track.P, track.q, EXTENT_SPHERICAL,
                        EXTENT_CARTESIAN, epoch)


@njit(cache=True, nogil=True)
def deleted_states(sel: np.ndarray, t: np.ndarray, model: np.ndarray, z: np.ndarray,
                   sigma: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
                   ot: np.ndarray, ox: np.ndarray, oP: np.ndarray, oq: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The object's state at the time of each of its rows ``sel`` (K,), had that row been
    left out of its trajectory: (xd (K, 9), Pd (K, 9, 9), ok (K,)).

    The smoothed marginal at a row's time combines everything but the row with the row
    itself, so removing the row is one information subtraction (exact for a linear
    smoother): with the carried smoothed ``x``, ``P``, the row's Jacobian ``H``, residual
    ``r = z - h(x)`` and noise ``R``, and ``D = R - H P Hᵀ``,

        x_del = x - P Hᵀ D⁻¹ r,    P_del = P + P Hᵀ D⁻¹ H P.

    ``R`` must be the noise the trajectory weighed the row with (``sigma``: its sigma per
    component, inf for a component it did not use, which is then not removed;
    :func:`weighed_sigma`). ``ok`` is False (and the smoothed state is returned) where no
    component was used or ``D`` is not positive definite: the trajectory did not weigh the
    row as ``sigma`` says.
    """
    k_rows = sel.shape[0]
    xd = np.empty((k_rows, 9))
    Pd = np.empty((k_rows, 9, 9))
    ok = np.zeros(k_rows, dtype=np.bool_)
    h = np.empty(N_COMPONENTS)
    H = np.empty((N_COMPONENTS, 9))
    x = np.empty(9)
    P = np.empty((9, 9))
    comp = np.empty(N_COMPONENTS, dtype=np.int64)
    HP = np.empty((N_COMPONENTS, 9))
    W = np.empty((N_COMPONENTS, 9))
    D = np.empty((N_COMPONENTS, N_COMPONENTS))
    res = np.empty((N_COMPONENTS, 1))
    for i in range(k_rows):
        r = sel[i]
        e = _nearest_epoch(ot, t[r])
        _carry(ox[e], oP[e], t[r] - ot[e], oq[e], x, P)
        xd[i] = x
        Pd[i] = P
        measure(model[r], x, s[r], sv[r], Qr[r], h, H)
        m = 0
        for c in range(N_COMPONENTS):          # the components the trajectory weighed
            if not math.isnan(z[r, c]) and math.isfinite(sigma[r, c]):
                comp[m] = c
                m += 1
        if m == 0:
            continue
        for a in range(m):                                # H P (no acceleration columns)
            c = comp[a]
            d = z[r, c] - h[c]
            if model[r] == SPHERICAL and c == AZIMUTH:
                d = wrap_angle(d)
            res[a, 0] = d
            for l in range(9):
                acc = 0.0
                for k in range(N_KINEMATIC_COLUMNS):
                    acc += H[c, k] * P[k, l]
                HP[a, l] = acc
                W[a, l] = acc
        for a in range(m):                                # D = R - H P Hᵀ
            for b in range(m):
                acc = 0.0
                for k in range(N_KINEMATIC_COLUMNS):
                    acc += HP[a, k] * H[comp[b], k]
                D[a, b] = -acc
            D[a, a] += sigma[r, comp[a]] ** 2
        if not cholesky_inplace(D, m):
            continue
        chol_solve_inplace(D, m, W, np.int64(9))          # D⁻¹ H P
        chol_solve_inplace(D, m, res, np.int64(1))        # D⁻¹ r
        for a in range(9):
            acc = 0.0
            for b in range(m):
                acc += HP[b, a] * res[b, 0]
            xd[i, a] = x[a] - acc
            for c in range(9):
                acc = 0.0
                for b in range(m):
                    acc += HP[b, a] * W[b, c]
                Pd[i, a, c] = P[a, c] + acc
        ok[i] = True
    return xd, Pd, ok


def innovation_variance(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack,
                        component: int) -> np.ndarray:
    """(M,) the variance of ``component``'s innovation, ``S = H P Hᵀ + R`` (its unit
    squared), of each of ``batch`` rows ``rows`` (M,) against ``track``, carried as
    :func:`score_rows` carries it (beyond the span with the gap noise); NaN where the row
    does not measure the component or S is not positive definite."""
    sel = np.asarray(rows, dtype=np.int64)
    _, L, m_rows, idx, ok, _, _ = _geometry(batch, sel, track)
    out = np.full(sel.size, np.nan)
    for a in range(idx.shape[1]):
        at = ok & (idx[:, a] == component) & (a < m_rows)
        out[at] = np.einsum("nk,nk->n", L[at, a, :a + 1], L[at, a, :a + 1])
    return out


def score_rows(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack,
               offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(residual (M, 6), NIS (M,), llr (M,)) of ``batch`` rows ``rows`` against ``track``."""
    sel = np.asarray(rows, dtype=np.int64)
    off = np.zeros((sel.size, N_COMPONENTS)) if offset is None else offset
    return row_llr(sel, batch.model, batch.z, off, *_geometry(batch, sel, track),
                   OUTLIER_PROBABILITY)


def score_rows_left_out(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack,
                        left_out: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`score_rows`, each row scored against the trajectory with row ``left_out[i]``
    (M,) of ``batch`` left out of it: the row itself (one the track was estimated from),
    another row (the object's own plot in the same scan), or -1 (none: the plain score).

    A sparse object's smoothed trajectory leans towards each of its own rows, so scored
    against it a row of its own looks better than it is, and a plot that the plot tracker
    gave it but another object should have had keeps winning (a surveillance-only track of
    100 m sigma scores its formation partner's plot at a NIS below 1). For the same
    reason a plot competing with the object's own plot of that scan is scored against the
    trajectory without that plot: within a scan every candidate plot of an object then
    meets the same trajectory, one that none of them shaped. The left-out row is removed
    from the smoothed state at its time (:func:`deleted_states`, exact for a linear
    smoother) with the noise the trajectory weighed it with (:func:`weighed_sigma`: a
    trajectory whose fusion raised a sensor's sigma above the stated one, from the rows'
    own scatter, weighed its rows less than stated, and removing them as stated would
    remove more than they gave); every row is then scored against that state with its
    stated noise, the same for every object it is scored against. Where the removal is not
    possible (the row was not used, or ``R - H P Hᵀ`` is not positive definite) the row
    keeps its plain score.
    """
    sel = np.asarray(rows, dtype=np.int64)
    left_out = np.asarray(left_out, dtype=np.int64)
    res, nis, llr = row_llr(sel, batch.model, batch.z, np.zeros((sel.size, N_COMPONENTS)),
                            *_geometry(batch, sel, track), OUTLIER_PROBABILITY)
    other = np.flatnonzero(left_out >= 0)
    if other.size:
        gone, at = np.unique(left_out[other], return_inverse=True)
        xd, Pd, fine = deleted_states(gone, batch.t, batch.model, batch.z,
                                      weighed_sigma(batch, gone, track), batch.s, batch.sv,
                                      batch.Qr, track.t, track.x, track.P, track.q)
        k = np.clip(np.searchsorted(track.t, batch.t[gone]), 0, track.t.size - 1)
        deleted = ObjectTrack(batch.t[gone], xd, Pd, track.q[k])
        use = fine[at]
        part, at = sel[other[use]], at[use]
        r2, n2, l2 = row_llr(part, batch.model, batch.z, np.zeros((part.size, N_COMPONENTS)),
                             *_geometry(batch, part, deleted, at), OUTLIER_PROBABILITY)
        res[other[use]], nis[other[use]], llr[other[use]] = r2, n2, l2
    return res, nis, llr


def weighed_sigma(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack
                  ) -> np.ndarray:
    """The sigma (N, 6) of every row of ``batch`` (N rows) with rows ``rows`` given the
    sigma ``track`` weighed them with (``ObjectTrack.weighed``, found by sensor and
    ``source_row``; inf for a component it did not use, inf for every component of a row
    it was not estimated from); ``batch.sigma`` itself where the track records none."""
    if track.weighed is None or rows.size == 0:
        return batch.sigma
    sigma = batch.sigma.copy()
    sensors = batch.sensor[rows]
    for sensor in np.unique(sensors):
        mine = rows[sensors == sensor]
        got = track.weighed.get(int(sensor))
        if got is None:
            sigma[mine] = np.inf
            continue
        source, weighed = got
        k = np.clip(np.searchsorted(source, batch.source_row[mine]), 0, max(source.size - 1, 0))
        found = source.size > 0
        hit = (source[k] == batch.source_row[mine]) if found else np.zeros(mine.size, bool)
        sigma[mine[hit]] = weighed[k[hit]]
        sigma[mine[~hit]] = np.inf
    return sigma


def scores_after_offset(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack,
                        offset_of: Callable[[np.ndarray], np.ndarray | None]
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The rows' scores against an object with an offset removed that their own residuals
    give: ``offset_of(res)`` of the residuals ``res`` (M, 6) returns the offset, (6,) or
    (M, 6), or None (then None is returned). Returns (offset, NIS (M,), llr (M,)). The object
    is carried to the rows once; the scores with and without the offset share it."""
    sel = np.asarray(rows, dtype=np.int64)
    geometry = _geometry(batch, sel, track)
    res, _, _ = row_llr(sel, batch.model, batch.z, np.zeros((sel.size, N_COMPONENTS)),
                        *geometry, OUTLIER_PROBABILITY)
    off = offset_of(res)
    if off is None:
        return None
    _, nis, llr = row_llr(sel, batch.model, batch.z, np.broadcast_to(off, res.shape).copy(),
                          *geometry, OUTLIER_PROBABILITY)
    return off, nis, llr


def segment_score(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack
                  ) -> tuple[float, np.ndarray, np.ndarray]:
    """A segment's score against an object: (sum of row llr after removing the clipped
    median offset, the offset (6,), per-row llr (M,)). Module docstring."""
    sel = np.asarray(rows, dtype=np.int64)
    spherical = batch.model[sel[0]] == SPHERICAL
    tol = BIAS_TOLERANCE_SPHERICAL if spherical else BIAS_TOLERANCE_CARTESIAN
    off, _, llr = scores_after_offset(
        batch, sel, track, lambda res: clipped_median_offset(res, batch.sigma, sel, tol,
                                                             BIAS_SIGMAS))
    return float(llr.sum()), off, llr


@njit(cache=True, nogil=True)
def clipped_median_offset(res: np.ndarray, sigma: np.ndarray, sel: np.ndarray,
                          tolerance: np.ndarray, n_sigmas: float) -> np.ndarray:
    """(6,) per component: the median of the finite residuals ``res`` (M, 6) (0 when none),
    clipped to +-min(``tolerance`` (6,), ``n_sigmas`` x the median of the non-NaN
    ``sigma[sel]`` (sel (M,) rows of sigma), 0 where there is none): the constant offset a
    segment's score removes."""
    m = res.shape[0]
    off = np.zeros(N_COMPONENTS)
    buf = np.empty(m)
    for c in range(N_COMPONENTS):
        k = 0
        for i in range(m):
            if not math.isnan(sigma[sel[i], c]):     # NaN only, as nanmedian
                buf[k] = sigma[sel[i], c]
                k += 1
        tol = tolerance[c]
        if k:
            cap = n_sigmas * np.median(buf[:k])
            if math.isinf(cap):
                cap = 1.7976931348623157e308 if cap > 0 else -1.7976931348623157e308
            tol = min(tol, cap)
        else:
            tol = min(tol, 0.0)
        k = 0
        for i in range(m):
            if math.isfinite(res[i, c]):
                buf[k] = res[i, c]
                k += 1
        med = np.median(buf[:k]) if k else 0.0
        off[c] = min(max(med, -tol), tol)
    return off
