"""A plot track that coasted onto another object: cut where it jumped across missed scans.

A plot track that misses scans coasts with a gate that grows with the manoeuvre model's
process noise (``tracking.plot_tracker``: 1200 (m/s^2)^2/s for an aircraft, a 1.3 km sigma
per axis after 16 s). After ``STRAY_MISSES`` missed scans in a row (probability 1e-3 for an
object still in view, ``tracking.plot_tails``) that gate holds another object's plot as
readily as its own, and the track, once it took it, follows that object from then on: one
segment then holds two objects, before and after the coast, and track synthesis, which
decides segment by segment, cannot part them (the benchmark kind ``scale``, 600 s, seed 1: a
surveillance track lost U2 at 126 s, coasted 4 scans and took U6 3.4 km away at 142 s, so
U2's first 126 s and U6's whole span became one object).

So where a track coasted through ``STRAY_MISSES`` missed scans or more, its first plot after
the gap is tested against the track's own plots before it under the tracker's cruise model
(a constant velocity with white acceleration of PSD ``CRUISE_PSD``, no manoeuvre), at the
tracker's gate probability: an object that kept its course while it was missed lies inside
that gate, a jump to another object does not, and there the track is cut, as the
segmentation of a tracking radar cuts its track where it jumped (``tracking.segments``).
Each piece is a segment of its own, and track synthesis relays the pieces to the objects
they continue with every sensor's evidence. A track that merely missed scans (a boat behind
a ship, a fade) stays whole: a cut there would leave its pieces to a relay that has less to
go on than the tracker had.
"""
from __future__ import annotations

import numpy as np

from rangeproc.models.motion import cv_predict
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.plot_tails import STRAY_MISSES
from rangeproc.tracking.plot_tracker import CRUISE_PSD, GATE_PROBABILITY
from rangeproc.tracking.plots import INITIATION_SPEED

#: Plots of a track before a coast that its cruise-model prediction across the gap is
#: filtered from (the last ones; older plots say little about where it went).
HISTORY_PLOTS = 10


def cruise_distance(t: np.ndarray, p: np.ndarray, R: np.ndarray, t_next: float,
                    p_next: np.ndarray, R_next: np.ndarray, stamp_sigma: float = 0.0
                    ) -> float:
    """Squared Mahalanobis distance of the plot ``p_next`` (3,) m, covariance ``R_next``
    (3, 3) m^2 at ``t_next`` s from the cruise-model prediction of a track's plots ``p``
    (K, 3) m with covariances ``R`` (K, 3, 3) at times ``t`` (K,) s ascending: a constant-
    velocity Kalman filter (white-acceleration PSD ``CRUISE_PSD`` m^2/s^3, the velocity
    started at the tracker's initiation bound) carried to ``t_next``; ``stamp_sigma`` (s) the
    plot time stamp's error, along the velocity."""
    x = np.concatenate([p[0], np.zeros(3)])
    P = np.zeros((6, 6))
    P[:3, :3] = R[0]
    P[3:, 3:] = (INITIATION_SPEED / 3.0) ** 2 * np.eye(3)
    stamp = stamp_sigma ** 2

    def innovation(tk: float, tj: float, z: np.ndarray, Rz: np.ndarray, x: np.ndarray,
                   P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        x, P = cv_predict(x, P, np.asarray(tk - tj), CRUISE_PSD)
        return x, P, z - x[:3], P[:3, :3] + Rz + stamp * np.outer(x[3:], x[3:])

    for k in range(1, t.size):                   # x+ = x + K d, P+ = P - K S K^T
        x, P, d, S = innovation(t[k], t[k - 1], p[k], R[k], x, P)
        gain = np.linalg.solve(S, P[:3, :]).T                  # K = P H^T S^-1, (6, 3)
        x, P = x + gain @ d, P - gain @ S @ gain.T
        P = 0.5 * (P + P.T)
    _, _, d, S = innovation(t_next, t[-1], p_next, R_next, x, P)
    return float(d @ np.linalg.solve(S, d))                    # d^T S^-1 d


def cut_jumps(t: np.ndarray, p: np.ndarray, R: np.ndarray, clock: np.ndarray,
              label: np.ndarray, stamp_sigma: float = 0.0) -> np.ndarray:
    """``label`` (N,) (the plot tracker's: track number, -1 clutter) with every track cut
    where, after at least ``STRAY_MISSES`` missed scans in a row, its next plot lies outside
    the gate of its cruise-model prediction (module docstring): the plots from there on are
    a track of their own, numbered on from the largest track number (every track keeps its
    number up to its first cut, so a label without cuts comes back as it was).

    t: (N,) s; p: (N, 3) ENU m; R: (N, 3, 3) m^2; clock: (N,) float, each plot's time in scans
    or revisits (``PlotTiming.clock``: a gap of k + 1 is k missed scans); stamp_sigma: s."""
    out = label.copy()
    fresh = int(label.max()) + 1 if label.size else 0
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    for k in np.unique(label[label >= 0]):
        mine = np.flatnonzero(label == k)
        mine = mine[np.argsort(clock[mine], kind="stable")]
        start = 0
        for g in np.flatnonzero(np.diff(clock[mine]) - 1.0 >= STRAY_MISSES - 0.5):
            before = mine[max(start, g + 1 - HISTORY_PLOTS):g + 1]
            nxt = mine[g + 1]
            if cruise_distance(t[before], p[before], R[before], float(t[nxt]), p[nxt], R[nxt],
                               stamp_sigma) <= gate:
                continue
            out[mine[g + 1:]] = fresh
            fresh += 1
            start = g + 1
    return out
