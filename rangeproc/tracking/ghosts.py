"""Multipath ghosts: plot tracks that follow a nearer object's line of sight, further out.

A surface radar among boats gives, besides each boat's own plot, returns further out on the
bearing of a near boat: the echo that went from the boat to another reflector (a quay, the
water, another hull) and back, or back and forth between the boat and the own platform,
arrives later and is placed on the boat's bearing at a larger range. In the Autoferry
recordings a boat 100-200 m off the ferry drags a fan of such returns at 250-500 m along its
bearing for a minute and more; the plot tracker (``tracking.plot_tracker``) follows them as
well as it follows the boat (track scores of 15-200, far above its confirmation threshold:
they come every scan, where a boat is, as a boat would), and each became an object that
zig-zagged at 10-30 m/s along the bearing (4-6 false objects a scenario, most of the
scenarios' GOSPA). No clutter density rejects them: they are where the near boat's bearing
is, not where the clutter map says clutter is.

What tells them apart is their geometry. A ghost has, in the scan it is seen in, a plot of
another track on its line of sight (azimuth and, for a sensor that measures it, elevation,
within ``GHOST_SIGMAS`` of the two plots' noise) nearer to the sensor by more than
``GHOST_SIGMAS`` of their range noise; a track most of whose plots (at least
``GHOST_SHARE``) are so placed is a ghost of the nearer object, and its plots are clutter.
A boat that crosses behind another for a few scans keeps its track: the Autoferry radar
tracks of the boats had at most 28 % of their plots behind another track, their ghosts
44-100 % (most above 60 %). The test applies to a sensor that gives one return per object a
scan (``tracking.plot_tracker.several_returns``, decided once in synthesis step 1 for the
plot tracker and for this test): a lidar's further returns of one hull lie behind each
other on its line of sight, and a second track on them is a copy of the object, which the
plot tracker and step 5 of synthesis settle, not a ghost.
Two objects that stay on one line of sight from the sensor for most of their common time (one
in another's wake, straight toward or away from the sensor) would lose the further one's
plot track; the object is still followed by every other sensor that sees it.
"""
from __future__ import annotations

import numpy as np

#: Line-of-sight and range test of :func:`ghost_tracks`, in standard deviations of the two
#: plots' combined noise (azimuth, elevation and range).
GHOST_SIGMAS = 3.0
#: A track with at least this share of its plots behind another track's plot of the same
#: frame is a ghost (module docstring).
GHOST_SHARE = 0.5


def shadowed(frame: np.ndarray, rng: np.ndarray, az: np.ndarray, el: np.ndarray,
             sigma: np.ndarray, label: np.ndarray, planar: bool) -> np.ndarray:
    """(N,) bool: plots of a track behind a plot of another track in their frame, on its line
    of sight (module docstring).

    frame: (N,) the plots' frames (``tracking.plot_tracker.PlotTiming.frame``); rng (N,) m,
    az (N,) rad, el (N,) rad (NaN for a sensor without elevation): the plots as measured in
    the sensor's axes; sigma: (N, 3) their range, azimuth and elevation sigmas (m, rad,
    rad); label: (N,) the plot tracker's track per plot (-1 clutter); planar: the sensor
    measures no elevation (azimuth alone is the line of sight).
    """
    out = np.zeros(label.size, dtype=bool)
    mine = np.flatnonzero(label >= 0)
    if mine.size < 2:
        return out
    order = mine[np.argsort(frame[mine], kind="stable")]
    bounds = np.flatnonzero(np.diff(frame[order])) + 1
    for a in np.split(order, bounds):
        if a.size < 2 or np.unique(label[a]).size < 2:
            continue
        # pair (i, j): plot i behind plot j, on its line of sight, of another track
        d_az = np.angle(np.exp(1j * (az[a][:, None] - az[a][None, :])))   # wrapped
        near = np.abs(d_az) <= GHOST_SIGMAS * np.hypot(sigma[a, 1][:, None],
                                                       sigma[a, 1][None, :])
        if not planar:
            with np.errstate(invalid="ignore"):
                near &= np.abs(el[a][:, None] - el[a][None, :]) <= GHOST_SIGMAS * np.hypot(
                    sigma[a, 2][:, None], sigma[a, 2][None, :])
        behind = rng[a][:, None] - rng[a][None, :] > GHOST_SIGMAS * np.hypot(
            sigma[a, 0][:, None], sigma[a, 0][None, :])
        other = label[a][:, None] != label[a][None, :]
        out[a] = (near & behind & other).any(axis=1)
    return out


def ghost_tracks(frame: np.ndarray, rng: np.ndarray, az: np.ndarray, el: np.ndarray,
                 sigma: np.ndarray, label: np.ndarray, planar: bool
                 ) -> tuple[np.ndarray, int]:
    """``label`` (N,) with every ghost track's plots returned to clutter (-1) and the other
    tracks numbered 0, 1, ... in their order, and the number of ghost tracks. A ghost track
    has at least ``GHOST_SHARE`` of its plots :func:`shadowed` (same arguments)."""
    if not (label >= 0).any():
        return label.copy(), 0
    behind = shadowed(frame, rng, az, el, sigma, label, planar)
    out = label.copy()
    ghosts = 0
    for k in np.unique(label[label >= 0]):
        mine = label == k
        if behind[mine].mean() >= GHOST_SHARE:
            out[mine] = -1
            ghosts += 1
    kept = np.unique(out[out >= 0])
    renumber = np.full(int(label.max()) + 1, -1, dtype=np.int64)
    renumber[kept] = np.arange(kept.size)
    return np.where(out >= 0, renumber[np.maximum(out, 0)], -1), ghosts
