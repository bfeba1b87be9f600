"""The spread of an extended object's returns within one scan: the part of its hull a sensor
sees, measured directly.

A lidar (or any sensor measured to give several returns of one object a scan,
``tracking.clutter_map.neighbour_share``) returns several points of a hull in each scan. The
tracker gives one of them to the object's track and takes the others as its further returns
(``tracking.plot_tracker``: they start no track); they stay out of the fusion, which follows
the track's plots. Their spread about their own mean in each scan is the spread of the hull's
visible points, whatever the aspect (a random matrix's scatter, Koch 2008), and needs no
separation of hull from noise over turning aspects as the fit over the whole track does
(``fusion.extent``): where a user's stated sigma is the returns' spread against GNSS and so
spans the hull, the track's residuals show it as noise, and a ship 30 m long seen by such a
lidar got a fitted hull of 2 m.

For each object and each scan of a several-returns sensor in which the object holds a plot,
the scan's plots that no object holds and that lie within the chi-square ``gate`` of the
object's plot (their two noises, east and north) are its further returns. With ``n_s`` returns
in scan ``s`` (the object's plot and its further ones) at horizontal points ``q_sk`` (m) about
their mean ``q_s``, the pooled within-scan covariance is

    S = sum_s sum_k (q_sk - q_s)(q_sk - q_s)^T / sum_s (n_s - 1)

(m^2, east and north); it holds the sensor's noise too (a floor that is too large, not too
small). It counts where at least :data:`MIN_SCANS` scans hold two returns or more and
``sum_s (n_s - 1) >= MIN_DOF``; the object's is the one with the largest eigenvalue over its
sensors. A radar that gives one plot per object a scan (an aircraft, a boat at 2 s scans)
gives none.
"""
from __future__ import annotations

import numpy as np

#: Scans with two returns or more that an estimate needs.
MIN_SCANS = 10
#: Degrees of freedom (returns beyond the first of each scan) that an estimate needs.
MIN_DOF = 20


def further_returns(p: np.ndarray, R: np.ndarray, scan: np.ndarray, owner: np.ndarray,
                    gate: float) -> np.ndarray:
    """(N,) the object id whose further return each plot is ("" none): a plot no object holds
    (``owner`` "") within the chi-square ``gate`` (east and north, their two noises) of a plot
    of the same ``scan`` that an object holds, the nearest such in that metric. p (N, 3) m,
    R (N, 3, 3) m^2, scan (N,), owner (N,) object id or ""."""
    out = np.full(owner.shape, "", dtype=object)
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    for rows in np.split(order, bounds):
        held = rows[owner[rows] != ""]
        free = rows[owner[rows] == ""]
        if held.size == 0 or free.size == 0:
            continue
        dp = p[free][:, None, :2] - p[held][None, :, :2]                     # (f, h, 2)
        C = R[free][:, None, :2, :2] + R[held][None, :, :2, :2]
        m2 = np.einsum("abi,abi->ab", dp, np.linalg.solve(C, dp[..., None])[..., 0])
        best = np.argmin(m2, axis=1)
        near = m2[np.arange(free.size), best] <= gate
        out[free[near]] = owner[held[best[near]]]
    return out


def scan_spread(p: np.ndarray, scan: np.ndarray, member: np.ndarray) -> np.ndarray | None:
    """(2, 2) m^2 the pooled within-scan covariance (module docstring) of the plots ``member``
    (N,) bool of one object (its own and its further returns) at p (N, 3) m in scans ``scan``
    (N,); None below :data:`MIN_SCANS` or :data:`MIN_DOF`."""
    q, s = p[member][:, :2], np.asarray(scan)[member]
    _, inv, n = np.unique(s, return_inverse=True, return_counts=True)
    if np.count_nonzero(n >= 2) < MIN_SCANS or int((n - 1).sum()) < MIN_DOF:
        return None
    mean = np.c_[np.bincount(inv, q[:, 0]), np.bincount(inv, q[:, 1])] / n[:, None]
    dev = q - mean[inv]
    return dev.T @ dev / float((n - 1).sum())


def object_spreads(p: np.ndarray, R: np.ndarray, scan: np.ndarray, owner: np.ndarray,
                   gate: float) -> dict[str, np.ndarray]:
    """Object id -> its returns' pooled within-scan covariance (2, 2) m^2 on one
    several-returns sensor (arguments as :func:`further_returns`); objects without enough
    scans are left out."""
    further = further_returns(p, R, scan, owner, gate)
    out = {}
    for name in np.unique(owner[owner != ""]):
        S = scan_spread(p, scan, (owner == name) | (further == name))
        if S is not None:
            out[str(name)] = S
    return out


def largest(a: np.ndarray | None, b: np.ndarray) -> np.ndarray:
    """Of two (2, 2) spreads (``a`` None: none yet) the one with the larger eigenvalue."""
    if a is None:
        return b
    return b if np.linalg.eigvalsh(b)[-1] > np.linalg.eigvalsh(a)[-1] else a
