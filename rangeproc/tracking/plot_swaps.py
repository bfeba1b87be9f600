"""Two new plot tracks that took each other's objects: a two-track test over their first scans.

The plot tracker (``tracking.plot_tracker``) decides each scan on that scan alone. A track's first
scans are its weakest: until it has a velocity, its prediction is a wide disc, and where
two objects fly closer than that (a formation, 230 m apart) it may continue one object's
first plot with the other object's next (a formation's first plot or first two scans).
Each track then holds a head of one object and the rest of
the other, and everything built on the tracks inherits the exchange: the heads come before
any other sensor holds either object, so nothing later corrects them.

For two confirmed tracks whose plots in a scan are confusable (their difference inside the
chi-square gate ``GATE_PROBABILITY`` of both plots' noise and the tracker's manoeuvre noise
over one revisit: one object could have been at the other's plot), each boundary between
scans within ``CONFIRM_SCANS`` of both tracks' first scans is tested: "from this scan on, the
tracks' continuations are exchanged" against "as tracked", by the sequential likelihood of
each track's plots within ``WINDOW_SCANS`` scans either side under the plot tracker's own
constant-velocity filter (the sum of innovation NIS and log det S: minus twice the
log-likelihood, up to a constant); the likelier wins (a track-oriented MHT of two tracks
over their first scans, deferred by the window: the GNN committed after one scan). Both
tracks must be young: against an old track, whose velocity is known, a new track's head of
one or two plots explains either continuation, the two hypotheses score a near tie (margins
of 0.3-2.2 on the recordings, where true exchanges of two young tracks score 2-7) and the
test would swap a boat with the neighbour that just appeared beside it. Later
exchanges are not tested: once the tracks have velocities the tracker's choice is as good
as this test (true and false later exchanges score alike), and
step 5 repairs them where another sensor holds one of the objects.
"""
from __future__ import annotations

import numpy as np
from rangeproc.models.motion import white_acceleration_q
from rangeproc.quantiles import chi2_ppf

from rangeproc.tracking.plots import (
    ACCELERATION_PSD,
    CONFIRM_SCANS,
    predict_tracks,
    start_track,
    update_track,
    revisit_period,
)

#: Scans either side of a boundary whose plots score the exchange.
WINDOW_SCANS = 4
#: Two plots of one scan are confusable within this chi-square probability (3 dof).
GATE_PROBABILITY = 0.9999


def sequence_cost(t: np.ndarray, p: np.ndarray, R: np.ndarray) -> float:
    """Minus twice the log-likelihood (up to a constant) of plots at times ``t`` (N,) s,
    ENU positions ``p`` (N, 3) m and covariances ``R`` (N, 3, 3) m^2 as one object under
    the plot tracker's constant-velocity filter (``tracking.plots``: its start, prediction
    and update): the sum over plots 2..N of ``NIS + log det S``. The track starts at the
    first plot with the tracker's velocity prior, so the first plot costs nothing and the
    second little."""
    track = start_track(p[0], R[0], float(t[0]), 0, 0)
    cost = 0.0
    for i in range(1, t.size):
        xs, Ps = predict_tracks(track.x[None], track.P[None], np.array([track.t]), t[i:i + 1])
        x, P = xs[0, 0], Ps[0, 0]
        L = np.linalg.cholesky(P[:3, :3] + R[i])
        w = np.linalg.solve(L, p[i] - x[:3])
        cost += float(w @ w) + 2.0 * float(np.log(np.diag(L)).sum())
        update_track(track, x, P, p[i], R[i], float(t[i]), 0, i)
    return cost


def repair_heads(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                 label: np.ndarray) -> np.ndarray:
    """``label`` (N,) (the plot tracker's: track number, -1 clutter) with the exchanges of
    two young tracks' heads undone (module docstring). t (N,) s, p (N, 3) ENU m,
    R (N, 3, 3) m^2, scan (N,) as for ``tracking.plot_tracker.track_plots``."""
    label = label.copy()
    tracked = np.flatnonzero(label >= 0)
    if tracked.size == 0:
        return label
    first = {int(k): int(scan[label == k].min()) for k in np.unique(label[tracked])}
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    for a, b, k in _close_boundaries(t, p, R, scan, label, tracked, gate):
        if k - min(first[a], first[b]) > CONFIRM_SCANS or k <= min(first[a], first[b]):
            continue
        rows_a = np.flatnonzero(label == a)
        rows_b = np.flatnonzero(label == b)
        near_a = rows_a[np.abs(scan[rows_a] - k + 0.5) < WINDOW_SCANS]
        near_b = rows_b[np.abs(scan[rows_b] - k + 0.5) < WINDOW_SCANS]
        head_a, tail_a = near_a[scan[near_a] < k], near_a[scan[near_a] >= k]
        head_b, tail_b = near_b[scan[near_b] < k], near_b[scan[near_b] >= k]
        if min(head_a.size, head_b.size, tail_a.size, tail_b.size) == 0:
            continue
        as_tracked = _cost(t, p, R, near_a) + _cost(t, p, R, near_b)
        exchanged = (_cost(t, p, R, np.concatenate([head_a, tail_b]))
                     + _cost(t, p, R, np.concatenate([head_b, tail_a])))
        if exchanged < as_tracked:
            later_a = rows_a[scan[rows_a] >= k]
            later_b = rows_b[scan[rows_b] >= k]
            label[later_a], label[later_b] = b, a
    return label


def _cost(t: np.ndarray, p: np.ndarray, R: np.ndarray, rows: np.ndarray) -> float:
    rows = np.sort(rows)
    return sequence_cost(t[rows], p[rows], R[rows])


def _close_boundaries(t: np.ndarray, p: np.ndarray, R: np.ndarray, scan: np.ndarray,
                      label: np.ndarray, tracked: np.ndarray, gate: float
                      ) -> list[tuple[int, int, int]]:
    """(track a, track b, boundary scan k) in scan order: for each scan in which tracks a
    and b both have a plot and the two plots are confusable, the boundaries before that
    scan and after it (an exchange happens between scans)."""
    out: set[tuple[int, int, int]] = set()
    order = tracked[np.argsort(scan[tracked], kind="stable")]
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    starts = np.concatenate([[0], bounds])
    revisit = revisit_period(t[tracked], scan[tracked])
    manoeuvre = white_acceleration_q.py_func(revisit, ACCELERATION_PSD)[0] * np.eye(3)
    for lo, rows in zip(starts, np.split(order, bounds)):
        if rows.size < 2:
            continue
        k = int(scan[order[lo]])
        i, j = np.triu_indices(rows.size, 1)
        u, v = rows[i], rows[j]
        u, v = u[label[u] != label[v]], v[label[u] != label[v]]
        if u.size == 0:
            continue
        d = p[u] - p[v]
        w = np.linalg.solve(R[u] + R[v] + manoeuvre, d[..., None])[..., 0]
        m2 = np.einsum("ni,ni->n", d, w)
        for uu, vv in zip(u[m2 <= gate], v[m2 <= gate]):
            a, b = sorted((int(label[uu]), int(label[vv])))
            out.update({(a, b, k), (a, b, k + 1)})
    return sorted(out, key=lambda abk: (abk[2], abk[0], abk[1]))
