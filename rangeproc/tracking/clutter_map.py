"""The spatial statistics of a sensor's plots that the plot tracker (``tracking.plot_tracker``)
reads before tracking: its clutter map, its stationary returns and how often a plot has a
neighbour in its own scan (:func:`neighbour_share`: several returns of one object a scan).

The density of the sensor's own plots per scan in cells of ``CLUTTER_CELL_SIGMAS`` median plot
sigmas (east, north and, for a sensor that measures elevation, up), each plot's own cell
counted without the plot itself and without the plots of the ``CLUTTER_OWN_SCANS`` scans either
side of it, shrunk toward the sensor-wide density with the weight of ``CLUTTER_PRIOR_CELLS``
cells (a Gamma prior). A moving object's own plots fall in its cell for as long as it takes to
cross it: a boat at 2 m/s gives three plots in a 15 m cell, which counted as clutter made its
cells 40 times denser than the sea around it (a boat among 5 clutter plots a scan over 1 km^2
went untracked for 100 s); leaving out the scans around each plot removes them, while a
stationary return, present in every scan, keeps its density (the count over the scans left is
scaled back to the whole span). Quays, moored boats and shore returns give plots in the same
cells scan after scan, so a track there needs far stronger evidence than in open water or open
sky; cells with plots in most scans are reported as stationary returns.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Clutter map: cells of this many median plot sigmas along each axis; each cell's density
#: shrunk toward the sensor-wide mean with the weight of this many cells (a Gamma prior).
CLUTTER_CELL_SIGMAS = 3.0
CLUTTER_PRIOR_CELLS = 1.0
#: A plot's own cell is counted without the plots of this many scans (or revisits) either
#: side of it (module docstring): an object that crosses its cell in fewer scans (a 15 m cell
#: and a 2.5 s scan: faster than 1.2 m/s) leaves none of its own plots in its density, a
#: slower one some, and one that lies still (a moored boat) all: a stationary return.
CLUTTER_OWN_SCANS = 5.0
#: A clutter-map cell with plots in at least this share of the scans is reported as a
#: stationary return (a moving object crosses a cell in a few scans); at most this many.
STATIONARY_SHARE = 0.5
STATIONARY_MAX = 50


def _clutter_cells(p: np.ndarray, R: np.ndarray, planar: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clutter map's cells of plots p (N, 3) ENU m with covariances R (N, 3, 3): cell of
    each plot (N,) (an index into the occupied cells), plots per occupied cell, and the cell
    size (axes,) m: ``CLUTTER_CELL_SIGMAS`` median plot sigmas along east, north and (unless
    ``planar``) up."""
    axes = 2 if planar else 3
    sig = np.sqrt(np.maximum(np.einsum("nii->ni", R)[:, :axes], 1e-12))
    cell = CLUTTER_CELL_SIGMAS * np.median(sig, axis=0)                 # (axes,) m
    index = np.floor(p[:, :axes] / cell).astype(np.int64)
    _, inverse, counts = np.unique(index, axis=0, return_inverse=True, return_counts=True)
    return inverse.ravel(), counts, cell


def clutter_density(p: np.ndarray, R: np.ndarray, n_scans: float, planar: bool,
                    clock: np.ndarray | None = None) -> np.ndarray:
    """(N,) the clutter density (plots per scan per m^2, or per m^3 unless ``planar``) at each
    plot's place: the sensor's spatial clutter map (module docstring).

    p: (N, 3) ENU m; R: (N, 3, 3) m^2; n_scans: scans (or revisits) the plots span; planar:
    the sensor measures no elevation (cells in east and north only); clock: (N,) the plots'
    time in scans or revisits (``tracking.plot_tracker.PlotTiming.clock``), which leaves out
    the plots of ``CLUTTER_OWN_SCANS`` scans either side of each plot (None: none left out).
    """
    axes = 2 if planar else 3
    if p.shape[0] == 0:
        return np.zeros(0)
    inverse, counts, cell = _clutter_cells(p, R, planar)
    volume = float(np.prod(cell))
    box = float(np.prod(np.ptp(p[:, :axes], axis=0) + cell))
    mean_count = p.shape[0] * volume / box                    # the sensor-wide mean per cell
    n = max(float(n_scans), 1.0)
    others = counts[inverse] - 1.0                             # the plot itself left out
    if clock is not None:                    # and the object's own plots around it
        others = _away_from_own_scans(inverse, np.asarray(clock, dtype=float), others)
    return (others + CLUTTER_PRIOR_CELLS * mean_count) / \
        ((1.0 + CLUTTER_PRIOR_CELLS) * n * volume)


def _away_from_own_scans(cell: np.ndarray, clock: np.ndarray, others: np.ndarray
                         ) -> np.ndarray:
    """(N,) the other plots of each plot's cell (``others``) less those within
    ``CLUTTER_OWN_SCANS`` of it in ``clock`` (N,), scaled from the scans left to the whole
    span. cell: (N,) each plot's cell index."""
    w = CLUTTER_OWN_SCANS
    lo, hi = float(clock.min()), float(clock.max())
    key = cell * (hi - lo + 4.0 * w + 10.0) + (clock - lo)      # cells apart, time within
    order = np.argsort(key, kind="stable")
    ks = key[order]
    near = np.empty(clock.size)
    near[order] = (np.searchsorted(ks, ks + w, side="right")
                   - np.searchsorted(ks, ks - w, side="left") - 1.0)
    span = hi - lo + 1.0
    left = span - (np.minimum(clock + w, hi) - np.maximum(clock - w, lo) + 1.0)
    return np.where(left >= 1.0, (others - near) * span / np.maximum(left, 1.0), others)


def stationary_returns(p: np.ndarray, R: np.ndarray, scan: np.ndarray, planar: bool
                       ) -> list[dict[str, float]]:
    """The clutter map's cells that hold plots in at least ``STATIONARY_SHARE`` of the scans:
    quays, moored boats, shore and other stationary returns, which the track score treats as
    clutter. Each {"e", "n", "u": the mean position of its plots (range ENU m), "share": the
    share of the scans (revisits) with a plot there, "plots": its plots}, most persistent
    first, at most ``STATIONARY_MAX`` of them. Arguments as :func:`clutter_density`, with
    ``scan`` (N,) the plots' scans (``tracking.plot_tracker.PlotTiming.scan``)."""
    usable = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
    p, R, scan = p[usable], R[usable], np.asarray(scan)[usable]
    n_scans = np.unique(scan).size
    if n_scans == 0:
        return []
    inverse, counts, _ = _clutter_cells(p, R, planar)
    scans_in = np.array([np.unique(scan[inverse == c]).size for c in range(counts.size)])
    share = scans_in / n_scans
    out = []
    for c in np.argsort(-share, kind="stable"):
        if share[c] < STATIONARY_SHARE or len(out) >= STATIONARY_MAX:
            break
        mean = p[inverse == c].mean(axis=0)
        out.append({"e": float(mean[0]), "n": float(mean[1]), "u": float(mean[2]),
                    "share": float(share[c]), "plots": int(counts[c])})
    return out


def on_stationary_returns(p: np.ndarray, R: np.ndarray, scan: np.ndarray, planar: bool,
                          gate: float) -> np.ndarray:
    """(N,) bool: the plots p (N, 3) m, R (N, 3, 3) m^2 of scans ``scan`` (N,) that have a
    plot within ``gate`` (chi-square, of their two noises) in at least ``STATIONARY_SHARE``
    of the scans: returns of a quay, a moored boat or the shore, seen at one place scan after
    scan (a moving object's plots are each near the others of a few scans only). East and
    north only when ``planar``. Plots without a finite position are False."""
    out = np.zeros(p.shape[0], dtype=bool)
    usable = np.flatnonzero(np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2)))
    if usable.size == 0:
        return out
    axes = 2 if planar else 3
    pu, Ru = p[usable, :axes], R[usable, :axes, :axes]
    su = np.asarray(scan)[usable]
    n_scans = np.unique(su).size
    largest = np.linalg.eigvalsh(Ru)[:, -1]
    tree = cKDTree(pu)
    reach = np.sqrt(gate * 2.0 * largest.max())           # no pair in the gate lies further
    for a, near in enumerate(tree.query_ball_point(pu, reach)):
        near = np.asarray(near, dtype=np.int64)
        d = pu[near] - pu[a]
        S = Ru[near] + Ru[a]
        m2 = np.einsum("ki,ki->k", d, np.linalg.solve(S, d[..., None])[..., 0])
        out[usable[a]] = np.unique(su[near[m2 <= gate]]).size >= STATIONARY_SHARE * n_scans
    return out


def neighbour_share(p: np.ndarray, R: np.ndarray, scan: np.ndarray, gate: float,
                    planar: bool) -> float:
    """The share of plots with another plot of the same scan within the chi-square ``gate``
    of their two noises (p (N, 3) m, R (N, 3, 3) m^2, scan (N,); east and north only when
    ``planar``): near 1 for a sensor that gives several returns per object a scan (a lidar
    whose stated noise, its residuals' spread against GNSS, spans the hull), small for one
    plot per object a scan, where only objects closer than their noise and clutter give
    pairs."""
    axes = 2 if planar else 3
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    near = 0
    for rows in np.split(order, bounds):
        for lo in range(0, rows.size if rows.size > 1 else 0, 64):  # blocks of 64 plots
            a = rows[lo:lo + 64]
            dp = p[a][:, None, :axes] - p[rows][None, :, :axes]           # (b, m, axes)
            C = R[a][:, None, :axes, :axes] + R[rows][None, :, :axes, :axes]
            m2 = np.einsum("abi,abi->ab", dp, np.linalg.solve(C, dp[..., None])[..., 0])
            m2[np.arange(a.size), lo + np.arange(a.size)] = np.inf       # not itself
            near += int((m2 <= gate).any(axis=1).sum())
    return near / max(p.shape[0], 1)
