"""Stationary returns: confirmed plot tracks that never moved (a quay's scatterers, a moored
boat) are left as clutter, so that quays and moored boats that never move are not output
objects, while a moored boat that leaves keeps its one track (issue 41; called by
``tracking.plot_tracker.track_plots`` after retrodiction). Positions in the range ENU frame.
"""
from __future__ import annotations

import numpy as np

from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.plots import CONFIRM_SCANS, GATE_PROBABILITY


def moving_tracks(label: np.ndarray, p: np.ndarray, R: np.ndarray, planar: bool
                  ) -> np.ndarray:
    """``label`` (N,) (as ``tracking.plot_tracker.track_plots`` returns) without the tracks
    of stationary returns, renumbered in order of first plot. A track moved when the median of
    some block of ``CONFIRM_SCANS`` consecutive plots lies outside the chi-square gate
    (``GATE_PROBABILITY``) of one plot's noise (the mean of its plots' covariances) about the
    median of the blocks' medians. Else it is a quay's scatterers or a moored boat, whose
    positions, known to their noise scan after scan, can outscore the clutter map, and it
    stays a stationary return. The gate is one plot's, not a block's, so that a hull's spread
    or returns from two scatterers of one quay do not make it move. A moored boat that leaves
    keeps its one track, its plots at the quay included. A track of fewer than two blocks is
    kept: a lidar's few plots of a boat at 2 m/s in its last 3 s in view do not tell its
    motion from a stationary return's scatter. p (N, 3) m, R (N, 3, 3) m^2 (east and north
    only when ``planar``)."""
    axes = 2 if planar else 3
    gate = float(chi2_ppf(GATE_PROBABILITY, axes))
    out = np.full_like(label, -1)
    n = 0
    for k in range(int(label.max()) + 1 if label.size else 0):
        rows = np.flatnonzero(label == k)
        if rows.size < 2 * CONFIRM_SCANS:             # too few plots to tell: kept
            out[rows] = n
            n += 1
            continue
        blocks = np.array_split(rows, rows.size // CONFIRM_SCANS)
        medians = np.array([np.median(p[b, :axes], axis=0) for b in blocks])
        d = medians - np.median(medians, axis=0)
        noise = R[rows, :axes, :axes].mean(axis=0)          # one plot's, in the mean
        if np.einsum("bi,bi->b", d, np.linalg.solve(noise, d.T).T).max() > gate:
            out[rows] = n
            n += 1
    return out
