"""A lost plot track's stray tail: the plots it took after coasting through missed scans.

A plot track that loses its object (a manoeuvre out of its gate, missed detections) coasts on
with a widening gate until its score falls ``DELETE_DROP`` below its best
(``tracking.plot_tracker``: ``MAX_MISSES`` misses in a row). Among 20 clutter plots a scan,
the wide gate of its last scans often holds one, which a confirmed track takes when it is
likelier the track's than clutter: the track then ends with a stray plot, tens of seconds
after its object's last plot and far from wherever the object went. Carried into track
synthesis, that plot puts the track in time beside the object's later segments (another
sensor's track of it, the plot tracker's new track on it) and scores it against them as a
miss of hundreds of metres: the object's early and late pieces stay two objects (the
benchmark kind ``scale``, seed 10: U6's first 54 s became an object of their own, an
identity swap).

For an object still present, ``STRAY_MISSES`` missed scans in a row have probability
``(1 - PD)^STRAY_MISSES`` (1e-3 at ``PD`` 0.9, ``tracking.plot_tracker.DETECTION_PROBABILITY``),
while a coasting track's gate, grown over those scans, holds a clutter plot far more often;
and fewer than ``CONFIRM_SCANS`` plots could not have confirmed a track on their own (Wald's
sequential test of the tracker). So a track's last run of plots, when it follows at least
``STRAY_MISSES`` missed scans and holds fewer than ``CONFIRM_SCANS`` plots, is returned to
clutter, as if the tracker had deleted the track at the gap; and so is the run before it
when it too follows such a gap and holds as few plots (a track that coasted out of a lidar's
view took one clutter plot 22 s later and another 10 s after that: deleted at the first
gap, it would have taken neither), back to the last run that could have confirmed a track.
Nothing is lost for an object whose plots they are: step 5 of synthesis
(``tracking.reassociation``) scores every clutter plot against the finished objects and gives
it to the object that gates it or whose span it continues. The track's head is left to
``tracking.plot_swaps`` (a tentative track that misses scans does not live to be confirmed).
"""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plots import CONFIRM_SCANS

#: Missed scans (or revisits) in a row before a track's last plots that make them a stray
#: tail (module docstring).
STRAY_MISSES = 3


def stray_tails(clock: np.ndarray, label: np.ndarray) -> np.ndarray:
    """``label`` (N,) (the plot tracker's: track number, -1 clutter) with each track's stray
    tail (module docstring) returned to clutter (-1). ``clock`` (N,) float: each plot's time
    in scans or revisits (``tracking.plot_tracker.PlotTiming.clock``); a gap of k + 1 between
    consecutive plots of a track is k missed scans."""
    out = label.copy()
    for k in np.unique(label[label >= 0]):
        mine = np.flatnonzero(label == k)
        mine = mine[np.argsort(clock[mine], kind="stable")]
        gaps = np.flatnonzero(np.diff(clock[mine]) - 1.0 >= STRAY_MISSES - 0.5)
        end = mine.size
        for g in gaps[::-1]:              # the last run, then the one before it, ...
            if end - (g + 1) >= CONFIRM_SCANS:
                break
            end = g + 1
        out[mine[end:]] = -1
    return out
