"""One track per hull for a sensor that gives several returns of one object a scan
(``tracking.plot_tracker``, *Several returns in one scan*): each track's hull measured from the
spread of its returns in each scan (``tracking.track_extent.HullSpread``), and two confirmed
tracks that hold one hull merged into one.

A lidar sees a ship 30 m long as several returns a scan anywhere along its side. Where its
first scans show the bow and the stern apart by more than the gate of their noise, each end
starts a track, both are confirmed, and each track's own innovations (it takes one end) tell
a small extent: the pair gate built from it never spans the hull, and the ship is written as
two objects that swap.

* **The hull from its returns** (:func:`spread_update`): each plot no track took in a scan goes
  to the nearest plot a track took (in the metric of their two noises) where it lies within
  the gate of that track's position (the plot's noise and the track's covariance); the track's
  plot and these, pooled about their scan's mean over its scans, give its hull's spread
  directly, which then widens its pair gate (``tracking.track_extent.pair_close``): the
  further returns of a hull are claimed along its length. The nearest plot, not every plot in
  the gate, so that a boat beside another does not lend it its returns; the gate of the
  track's position without its hull, so that the hull does not grow on the returns its own
  growth takes in (a boat 13 m behind another, whose returns no track takes yet, became part
  of the first boat's hull, which then claimed them for good).
* **Two tracks, one hull** (:func:`hull_tracks`): two confirmed tracks that take plots in the
  same scan within the pair gate of the larger of their hulls, with velocities that agree
  within ``HULL_MERGE_PROBABILITY``, are candidates; the scan's returns in the box spanned by
  their two positions (from a third of their distance behind the one to a third beyond the
  other, as wide as they are apart) count in its middle third or in its outer ones. A hull
  seen along its length fills the middle (a uniform hull between the two: half the count of
  the outer thirds); two boats, one behind or beside the other, leave water between them.
  Candidates in every scan in which both take a plot for ``HULL_MERGE_SECONDS``, with at least
  ``HULL_FILL`` times the outer count in the middle, are one object: the track with fewer
  plots is merged into the other (its plots of scans the other missed join it; the rest are
  that object's further returns). Two boats passing each other differ in velocity.
"""
from __future__ import annotations

from typing import Protocol

import numpy as np

from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.track_extent import HullSpread, pair_close

#: Two confirmed tracks that hold one hull for this long (s) are merged into one (module
#: docstring).
HULL_MERGE_SECONDS = 5.0
#: The chi-square probability within which two tracks' velocities agree for them to hold one
#: hull.
HULL_MERGE_PROBABILITY = 0.99
#: The returns in the middle third between two tracks of one hull, as a share of those in the
#: outer thirds: at least half of a uniform hull's 0.5.
HULL_FILL = 0.25


class HullTrack(Protocol):
    """What this module reads and changes of a plot track (``plot_tracker._ImmTrack``): its
    per-model states xs (M, 6) and covariances Ps (M, 6, 6), model probabilities mu (M,),
    plots ``rows``, whether it is confirmed, its extent (``track_extent``) and hull spread."""

    xs: np.ndarray
    Ps: np.ndarray
    mu: np.ndarray
    rows: list
    confirmed: bool
    extent: float
    noise: float
    hull: HullSpread


def _combined(tr: HullTrack, axes: slice) -> tuple[np.ndarray, np.ndarray]:
    """The IMM's combined state (2,) over ``axes`` (east and north of its position or its
    velocity) and its covariance (2, 2), the models' spread included."""
    x = tr.xs[:, axes]
    m = tr.mu @ x
    dx = x - m
    return m, np.einsum("m,mij->ij", tr.mu, tr.Ps[:, axes, axes]) + (tr.mu[:, None] * dx).T @ dx


def spread_update(live: list, owner: np.ndarray, rows: np.ndarray, p: np.ndarray,
                  R: np.ndarray, gate: float) -> None:
    """Each track of ``live`` that took a plot of the scan ``rows`` (owner (A,) the index of
    the track that took each plot, -1 none) adds the scan's returns of its hull to its
    :class:`HullSpread`: its plot and the plots no track took whose nearest taken plot (in
    the metric of their two noises, east and north) is its and that lie within the
    chi-square ``gate`` of its position (the plot's noise and the track's covariance, east
    and north; module docstring). p (N, 3) m, R (N, 3, 3) m^2."""
    held = np.flatnonzero(owner >= 0)
    free = np.flatnonzero(owner < 0)
    nearest = np.zeros(free.size, dtype=np.int64)
    if held.size and free.size:
        dp = p[rows[free], None, :2] - p[rows[held], :2][None]                 # (f, h, 2)
        C = R[rows[free], None, :2, :2] + R[rows[held], :2, :2][None]
        m2 = np.einsum("fhi,fhi->fh", dp, np.linalg.solve(C, dp[..., None])[..., 0])
        nearest = held[np.argmin(m2, axis=1)]
    for b in held:
        tr = live[owner[b]]
        mine = rows[free[nearest == b]]
        if mine.size:
            x, P = _combined(tr, slice(0, 2))
            d = p[mine, :2] - x
            S = R[mine, :2, :2] + P
            mine = mine[np.einsum("fi,fi->f", d, np.linalg.solve(S, d[..., None])[..., 0])
                        <= gate]
        member = np.concatenate([[rows[b]], mine]).astype(np.int64)
        tr.hull.add(p[member, :2], R[member, :2, :2])


def _candidates(a: HullTrack, b: HullTrack, pa: np.ndarray, pb: np.ndarray, Ra: np.ndarray,
                Rb: np.ndarray, gate: float, axes: int) -> bool:
    """Whether confirmed tracks a and b, with plots pa, pb (3,) m of noises Ra, Rb (3, 3) m^2
    in one scan, may hold one hull: the plots within the pair gate of the larger measured
    hull of the two (none measured: no), the velocities within ``HULL_MERGE_PROBABILITY``."""
    Ea, Eb = a.hull.extent(), b.hull.extent()
    if Ea is None and Eb is None:
        return False
    wide = a if Eb is None or (Ea is not None and np.trace(Ea) >= np.trace(Eb)) else b
    if not pair_close(wide, pa, pb, Ra, Rb, gate, axes):
        return False
    (va, Pa), (vb, Pb) = _combined(a, slice(3, 5)), _combined(b, slice(3, 5))
    d = va - vb
    return bool(d @ np.linalg.solve(Pa + Pb, d) <= chi2_ppf(HULL_MERGE_PROBABILITY, 2))


def _fill(a: HullTrack, b: HullTrack, q: np.ndarray) -> tuple[int, int]:
    """The returns at q (n, 2) m (east, north) in the middle third and in the outer thirds of
    the box spanned by tracks a and b (module docstring); tracks closer than their positions'
    uncertainty hold one point: (1, 2), a uniform hull's share."""
    (xa, Pa), (xb, Pb) = _combined(a, slice(0, 2)), _combined(b, slice(0, 2))
    u = xb - xa
    d2 = float(u @ u)
    if d2 <= np.trace(Pa + Pb):
        return 1, 2
    s = (q - xa) @ u / d2                                       # 0 at a, 1 at b
    lateral = np.abs((q - xa) @ np.array([-u[1], u[0]])) / d2   # in units of the distance
    box = (s >= -1.0 / 3.0) & (s <= 4.0 / 3.0) & (lateral <= 1.0)
    middle = box & (s >= 1.0 / 3.0) & (s <= 2.0 / 3.0)
    return int(middle.sum()), int((box & ~middle).sum())


def hull_tracks(live: list, owner: np.ndarray, rows: np.ndarray, p: np.ndarray,
                R: np.ndarray, t: float, scan: np.ndarray, gate: float, planar: bool
                ) -> tuple[list, np.ndarray]:
    """The live tracks after one scan of a several-returns sensor (module docstring): each
    hull spread updated (:func:`spread_update`), and a confirmed track that has held returns
    of another confirmed track's hull for ``HULL_MERGE_SECONDS`` merged into it. live the
    tracks, owner (A,) the index into ``live`` of the track that took each plot of the scan
    ``rows`` (-1 none); p (N, 3) m, R (N, 3, 3) m^2, scan (N,) the scan of every plot; t (s)
    the scan's time. Returns the live tracks left and owner re-indexed to them (a merged
    track's plot -1: a further return of the object)."""
    axes = 2 if planar else 3
    spread_update(live, owner, rows, p, R, gate)
    held = [int(b) for b in np.flatnonzero(owner >= 0) if live[owner[b]].confirmed]
    scan_q = p[rows[owner < 0], :2]
    ids = {id(tr) for tr in live}
    gone: set[int] = set()
    for x, b in enumerate(held):
        for c in held[x + 1:]:
            j, k = int(owner[b]), int(owner[c])
            old, new = (j, k) if live[j].rows[0] <= live[k].rows[0] else (k, j)
            since = live[old].hull.since
            for key in [key for key in since if key not in ids]:
                del since[key]
            i, m = int(rows[b]), int(rows[c])
            if not _candidates(live[j], live[k], p[i], p[m], R[i], R[m], gate, axes):
                since.pop(id(live[new]), None)
                continue
            t0, middle, ends = since.setdefault(id(live[new]), (t, 0, 0))
            mid, out = _fill(live[j], live[k], scan_q)
            since[id(live[new])] = (t0, middle + mid, ends + out)
            if (t - t0 < HULL_MERGE_SECONDS or middle + mid < HULL_FILL * (ends + out)
                    or gone & {j, k}):
                continue
            keep, drop = (j, k) if len(live[j].rows) >= len(live[k].rows) else (k, j)
            _merge(live[keep], live[drop], scan)
            gone.add(drop)
    if not gone:
        return live, owner
    index = np.cumsum([j not in gone for j in range(len(live))]) - 1
    owner = np.where((owner >= 0) & ~np.isin(owner, list(gone)), index[owner], -1)
    return [tr for j, tr in enumerate(live) if j not in gone], owner


def _merge(keep: HullTrack, drop: HullTrack, scan: np.ndarray) -> None:
    """Track ``drop`` merged into ``keep``: its plots of scans ``keep`` holds none of (scan
    (N,) the scan of every plot) join ``keep``'s, in time order; the rest are further returns
    of the object (no track's)."""
    mine = set(scan[keep.rows].tolist())
    keep.rows = sorted(keep.rows + [r for r in drop.rows if scan[r] not in mine])

