"""Retrodiction of plot tracks: the plot tracker run backward in time gives each forward track
the plots before its confirmation that the forward pass left as clutter.

A forward track is confirmed only once its score (``tracking.plot_tracker``, Wald's sequential
test) has gathered enough evidence: a slow boat among quay and sea clutter, one plot a scan,
can need tens of seconds (its second plot, its velocity unknown up to
``tracking.plots.INITIATION_SPEED``, costs the score several units, and each later plot gains
only the log of its likelihood over the dense clutter's), and its plots before that moment
stay clutter although they are its plots. Offline every plot is at hand, so the tracker also
runs over
the plots in reverse time order, with the same models, gates, scores and deletion (the
evidence asked of a track is the same in both directions): a backward track is confirmed near
the object's last plots and followed back toward its first. Each backward track that shares at
least ``MIN_SHARED`` plots with a forward track, more with it than with any other, gives that
forward track the plots it shares with none and that lie outside the forward track's span
(before its first plot or after its last): fixed-interval smoothing of the association, the
retrodiction of Koch (1996) with the tracker itself as the backward model.

A backward track's own last plots (the object's first) obey the stray-tail rule of
``tracking.plot_tails`` in mirrored time: a run of fewer plots than confirm a track, after
missed scans, is clutter the coasting track took, not the object. A backward track that shares
no forward track's plots adds nothing (a track confirmed in one direction only is not taken on
less evidence than the forward pass asks); plots the forward pass gave to a track stay with it.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rangeproc.tracking.plot_tails import stray_tails

#: A backward track lends its plots to the forward track with which it shares at least this
#: many plots (more than a crossing of two tracks shares; fewer than confirm a track).
MIN_SHARED = 3

#: The tracker's signature as used here: (t, p, R, scan, clock) -> label (N,), -1 clutter.
Tracker = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def backward_labels(track: Tracker, t: np.ndarray, p: np.ndarray, R: np.ndarray,
                    scan: np.ndarray, clock: np.ndarray, tails: np.ndarray | None = None,
                    per_plot: tuple[np.ndarray, ...] = ()) -> np.ndarray:
    """(N,) the labels of ``track`` run over the plots in reverse time order (times, scans
    and clocks mirrored so that they increase; t (N,) s, p (N, 3) m, R (N, 3, 3) m^2, scan
    (N,), clock (N,) float as for ``tracking.plot_tracker.track_plots``), each backward
    track's stray tail returned to clutter (in the clock ``tails`` (N,), default ``clock``:
    one that counts a sensor's silences, ``tracking.plots.silent_clock``), given back in the
    plots' own order. ``per_plot``: further (N,) arrays, passed to ``track`` after the clock
    in the same reversed order (the new-track speed bound of ``tracking.two_passes``)."""
    rev = np.arange(t.size)[::-1]
    mirrored = (clock.max() - clock)[rev]
    tails = clock if tails is None else tails
    label = stray_tails((tails.max() - tails)[rev],
                        track(-t[rev], p[rev], R[rev], (scan.max() - scan)[rev], mirrored,
                              *(a[rev] for a in per_plot)))
    out = np.empty_like(label)
    out[rev] = label
    return out


def retrodicted(forward: np.ndarray, backward: np.ndarray, clock: np.ndarray) -> np.ndarray:
    """``forward`` (N,) track labels (-1 clutter) with each forward track given the plots of
    its backward partner in ``backward`` (N,) (module docstring) that ``forward`` leaves as
    clutter before its first or after its last plot in ``clock`` (N,) (scans or revisits)."""
    out = forward.copy()
    for b in np.unique(backward[backward >= 0]):
        mine = backward == b
        shared = forward[mine & (forward >= 0)]
        if shared.size < MIN_SHARED:
            continue
        f = int(np.bincount(shared).argmax())
        if np.count_nonzero(shared == f) < MIN_SHARED:
            continue
        span = clock[forward == f]
        outside = (clock < span.min()) | (clock > span.max())
        out[mine & (forward < 0) & outside] = f
    return out
