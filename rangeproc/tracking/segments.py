"""Per-sensor tracking into segments: where a sensor's track jumped to another object.

A radar or theodolite ``track_id`` is only a hint (DATA_CONTRACT section 2): a lock may jump
to another object during a close pass, an operator may slew to another object. Each sensor's
track is therefore filtered on its own first (He 2015: per-sensor filtering before
association) and cut into *segments*, pieces that each follow one object.

The filter works in the sensor's own measurement space, one constant-acceleration Kalman
filter per measured component (range, azimuth (unwrapped), elevation, range rate), so it
needs no range to work (angle-only theodolites are segmented alike) and no geometry (a deck
frame's motion is just signal). The components are gated together: a row is rejected when its
normalised innovation squared, summed over the measured components, exceeds the chi-square
gate of that many degrees of freedom. A single rejected row is a wild value (the filter
carries its prediction); ``RESET_ROWS`` consecutive rejections (at least ``RESET_SECONDS``)
mean the sensor now sees something else: the segment ends before the first of them and a new
one starts there, the filter restarted from that row. A time gap longer than
``gap_seconds`` also ends a segment (across it the prediction is too loose to see a jump;
association relays the pieces).

Each component's process noise (white-jerk PSD, units of the component squared per s^5) is
its maximum-likelihood value on a logarithmic grid of the dimensionless tracking index
``q dt^3 / sigma^2`` (``dt`` the median step, ``sigma`` the third-difference noise), so a
hard-turning aircraft and a slow boat need no setting.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from rangeproc.quantiles import chi2_ppf

from rangeproc.editing.hampel import noise_floor
from rangeproc.models.motion import ca_axis_step, white_jerk_q

#: Consecutive rejected rows that end a segment, and the least time they must span (s).
RESET_ROWS = 5
RESET_SECONDS = 0.3
#: Gate probability of the joint chi-square test per row.
GATE_PROBABILITY = 1.0 - 1e-6
#: Grid of the tracking index q dt^3 / sigma^2 searched per component.
TRACKING_INDEX_GRID = 10.0 ** np.arange(-9.0, 3.0, 1.0)
#: Rows used to choose the process noise of a long track: blocks of ``Q_BLOCK`` rows spread
#: over it, ``Q_ROWS`` in all (block joins are time gaps, which restart the filter).
Q_ROWS = 20_000
Q_BLOCK = 1_000
#: Initial velocity / acceleration uncertainty, in noise sigmas per median step (diffuse).
DIFFUSE = 1e4


@njit(cache=True)
def _predict(x: np.ndarray, P: np.ndarray, dt: float, q: float) -> None:
    """1-D constant-acceleration prediction over ``dt`` (s) with white-jerk PSD ``q``, in place
    on ``x`` (3,) and ``P`` (3, 3): ``F x``, ``F P F^T + Q``: one axis of the fusion's CA
    model (``models.motion``: the step ``ca_axis_step``, the noise ``white_jerk_q``)."""
    h2 = 0.5 * dt * dt
    x[0] += dt * x[1] + h2 * x[2]
    x[1] += dt * x[2]
    # F P column by column (P symmetric: column j is row j), then (F P) F^T row by row
    r00, r10, r20 = ca_axis_step(P[0, 0], P[0, 1], P[0, 2], dt, h2)
    r01, r11, r21 = ca_axis_step(P[0, 1], P[1, 1], P[1, 2], dt, h2)
    r02, r12, r22 = ca_axis_step(P[0, 2], P[1, 2], P[2, 2], dt, h2)
    n00, n01, n02 = ca_axis_step(r00, r01, r02, dt, h2)
    _, n11, n12 = ca_axis_step(r10, r11, r12, dt, h2)
    q00, q01, q02, q11, q12, q22 = white_jerk_q(dt, q)
    P[0, 0] = n00 + q00
    P[0, 1] = P[1, 0] = n01 + q01
    P[0, 2] = P[2, 0] = n02 + q02
    P[1, 1] = n11 + q11
    P[1, 2] = P[2, 1] = n12 + q12
    P[2, 2] = r22 + q22


@njit(cache=True)
def _update(x: np.ndarray, P: np.ndarray, z: float, r: float) -> None:
    """Scalar position update of ``x`` (3,), ``P`` (3, 3) by ``z`` with variance ``r``."""
    s = P[0, 0] + r
    k0, k1, k2 = P[0, 0] / s, P[1, 0] / s, P[2, 0] / s
    nu = z - x[0]
    x[0] += k0 * nu
    x[1] += k1 * nu
    x[2] += k2 * nu
    p0 = (P[0, 0], P[0, 1], P[0, 2])
    P[0, 0] -= k0 * p0[0]
    P[0, 1] -= k0 * p0[1]
    P[0, 2] -= k0 * p0[2]
    P[1, 1] -= k1 * p0[1]
    P[1, 2] -= k1 * p0[2]
    P[2, 2] -= k2 * p0[2]
    P[1, 0] = P[0, 1]
    P[2, 0] = P[0, 2]
    P[2, 1] = P[1, 2]


@njit(cache=True)
def _start(x: np.ndarray, P: np.ndarray, z: float, sigma: float, scale: float) -> None:
    """Diffuse start at measurement ``z``: velocity/acceleration unknown (``scale`` per s)."""
    x[0], x[1], x[2] = z, 0.0, 0.0
    P[:, :] = 0.0
    P[0, 0] = sigma * sigma
    P[1, 1] = (DIFFUSE * scale) ** 2
    P[2, 2] = (DIFFUSE * scale) ** 2


@njit(cache=True, nogil=True)
def segment_filter(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, q: np.ndarray,
                   gate: np.ndarray, reset_rows: int, reset_seconds: float,
                   gap_seconds: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Run the per-component CA filters over one track's rows (module docstring).

    Args:
        t: (N,) ascending times (s). z: (N, C) measured components (NaN = not measured;
            angles unwrapped). sigma: (C,) noise sigma per component. q: (C,) white-jerk PSD
            per component. gate: (C + 1,) chi-square threshold by number of measured
            components. reset_rows, reset_seconds, gap_seconds: see the module docstring.
    Returns:
        start: (N,) bool, True where a segment starts (row 0 always); rejected: (N,) bool
        rows rejected by the gate; loglik: the gated Gaussian log-likelihood of the rows
        (rejected rows count at the gate), for choosing ``q``.
    """
    n, c = z.shape
    start = np.zeros(n, dtype=np.bool_)
    rejected = np.zeros(n, dtype=np.bool_)
    if n == 0:
        return start, rejected, 0.0
    x = np.zeros((c, 3))
    P = np.zeros((c, 3, 3))
    xp = np.zeros((c, 3))
    Pp = np.zeros((c, 3, 3))
    begun = np.zeros(c, dtype=np.bool_)
    loglik = 0.0
    i = 0
    t_prev = t[0]
    run = 0
    first_rejected = -1
    start[0] = True
    while i < n:
        if i > 0 and (start[i] or t[i] - t_prev > gap_seconds):
            start[i] = True
            begun[:] = False
            run = 0
        dt = t[i] - t_prev if not start[i] else 0.0
        nis = 0.0
        m = 0
        logdet = 0.0
        for k in range(c):
            if not begun[k]:
                continue
            for a in range(3):
                xp[k, a] = x[k, a]
                for b in range(3):
                    Pp[k, a, b] = P[k, a, b]
            _predict(xp[k], Pp[k], dt, q[k])
            zk = z[i, k]
            if math.isnan(zk):
                continue
            s = Pp[k, 0, 0] + sigma[k] * sigma[k]
            nu = zk - xp[k, 0]
            nis += nu * nu / s
            logdet += math.log(s)
            m += 1
        reject = m > 0 and nis > gate[m]
        if reject:
            rejected[i] = True
            if run == 0:
                first_rejected = i
            run += 1
            loglik -= 0.5 * (gate[m] + logdet)
            if run >= reset_rows and t[i] - t[first_rejected] >= reset_seconds:
                i = first_rejected                  # the sensor sees another object: restart
                rejected[i:i + run] = False
                start[i] = True
                begun[:] = False
                run = 0
                t_prev = t[i]
                continue
        else:
            run = 0
            loglik -= 0.5 * (nis + logdet)
        for k in range(c):                          # update (or carry the prediction)
            zk = z[i, k]
            if begun[k]:
                for a in range(3):
                    x[k, a] = xp[k, a]
                    for b in range(3):
                        P[k, a, b] = Pp[k, a, b]
                if not reject and not math.isnan(zk):
                    _update(x[k], P[k], zk, sigma[k] * sigma[k])
            elif not math.isnan(zk):
                _start(x[k], P[k], zk, sigma[k], sigma[k])
                begun[k] = True
        t_prev = t[i]
        i += 1
    return start, rejected, loglik


def _chi2_gates(c: int) -> np.ndarray:
    """(c + 1,) chi-square thresholds by degrees of freedom (index 0 unused)."""
    return np.array([0.0] + [float(chi2_ppf(GATE_PROBABILITY, d)) for d in range(1, c + 1)])


def component_noise(t: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, float]:
    """(C,) noise sigma per component (third differences; NaN-free runs) and the median step."""
    step = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    sig = np.empty(z.shape[1])
    for k in range(z.shape[1]):
        v = z[:, k]
        v = v[np.isfinite(v)]
        s = noise_floor(v) if v.size >= 8 else 0.0
        sig[k] = s if s > 0.0 else max(float(np.std(v)) if v.size > 1 else 1.0, 1e-9)
    return sig, max(step, 1e-6)


def choose_process_noise(t: np.ndarray, z: np.ndarray, sigma: np.ndarray, step: float,
                         gap_seconds: float) -> np.ndarray:
    """(C,) white-jerk PSD per component: the maximum-likelihood tracking index of each
    component filtered alone (module docstring)."""
    if t.size > Q_ROWS:                       # blocks spread over the track suffice
        starts = np.linspace(0, t.size - Q_BLOCK, Q_ROWS // Q_BLOCK).astype(np.int64)
        keep = np.concatenate([np.arange(a, a + Q_BLOCK) for a in np.unique(starts)])
        t, z = t[keep], z[keep]
    q = np.empty(z.shape[1])
    gate = _chi2_gates(1)
    for k in range(z.shape[1]):
        zk = np.ascontiguousarray(z[:, k:k + 1])
        if not np.isfinite(zk).any():
            q[k] = 1.0
            continue
        best, best_q = -np.inf, 1.0
        for lam in TRACKING_INDEX_GRID:
            qk = lam * sigma[k] ** 2 / step ** 3
            _, _, ll = segment_filter(t, zk, sigma[k:k + 1], np.array([qk]), gate,
                                      RESET_ROWS, RESET_SECONDS, gap_seconds)
            if ll > best:
                best, best_q = ll, qk
        q[k] = best_q
    return q


@dataclass(frozen=True, slots=True)
class TrackSegments:
    """The segmentation of one sensor track: ``label`` (N,) int64 segment number per row
    (0, 1, ... in time order), ``rejected`` (N,) bool rows the per-sensor gate rejected,
    ``q`` (C,) the process noise used per component."""

    label: np.ndarray
    rejected: np.ndarray
    q: np.ndarray


def segment_track(t: np.ndarray, z: np.ndarray, *, gap_seconds: float | None = None,
                  angle_columns: tuple[int, ...] = ()) -> TrackSegments:
    """Cut one sensor track (rows of one ``track_id``, time ordered) into segments.

    Args:
        t: (N,) s ascending. z: (N, C) the measured components (SI; NaN = not measured).
        gap_seconds: a gap longer than this ends a segment; default ``max(2 s, 10 median
            steps)``.
        angle_columns: columns of ``z`` holding wrapped angles (unwrapped here).
    """
    z = np.array(z, dtype=float)
    for k in angle_columns:
        have = np.isfinite(z[:, k])
        z[have, k] = np.unwrap(z[have, k])
    keep = np.isfinite(z).any(axis=0)
    z = np.ascontiguousarray(z[:, keep])
    n = t.size
    if n == 0 or z.shape[1] == 0:
        return TrackSegments(np.zeros(n, dtype=np.int64), np.zeros(n, dtype=bool),
                             np.zeros(0))
    sigma, step = component_noise(t, z)
    gap = gap_seconds if gap_seconds is not None else max(2.0, 10.0 * step)
    q = choose_process_noise(t, z, sigma, step, gap)
    start, rejected, _ = segment_filter(np.ascontiguousarray(t, dtype=float), z, sigma, q,
                                        _chi2_gates(z.shape[1]), RESET_ROWS, RESET_SECONDS,
                                        gap)
    return TrackSegments(np.cumsum(start) - 1, rejected, q)
