"""The plot tracker's forward and backward passes over a sensor's plots, combined (used by
``tracking.plot_tracker.track_plots``): where the two exchange plots between tracks, the
grouping with the higher summed track score; then each forward track given its backward
partner's plots before and after it (``tracking.retrodiction``).

The tracker is one hypothesis per track and decides each scan on that scan alone. When a new
object's first plot appears beside a confirmed track's object (two boats 18 m apart) in a scan
that misses the track's own object, the track may take the new object's plot and follow it
from there; its own object's next plots then start another track, and the first track holds
both objects. The forward pass meets this place at the new object's *first* plot, before the
new object has a track; the backward pass meets it at the new object's *last* plot, with both
objects' tracks confirmed there, and may group the plots the other way. The passes then
exchange plots: a forward track shares its plots with two backward tracks (before and after
the jump), one of which shares plots with a second forward track.

Such an exchange is settled as a track-oriented multiple-hypothesis tracker settles it after
seeing every scan (Reid 1979; Blackman and Popoli 1999, 16.3): the two groupings of the plots
involved are two global hypotheses, each scored by the sum of its tracks' scores (the
log-likelihood ratio object / clutter of a track's plots: its new-object start, the plots it
took and the scans it missed, as its pass reached it; plots a grouping leaves out are clutter
and add nothing), and the backward grouping replaces the forward one when it is likelier by at
least ``SETTLE_MARGIN``. Tracks are linked when they share at least
``tracking.retrodiction.MIN_SHARED`` plots; a linked set with two or more tracks on both sides
is an exchange. A forward track that the backward pass only splits, or two that it only joins,
is fragmentation, left to the segment-level search (``tracking.hypotheses``) as every track's
gaps are: a join taken from one sensor's plots alone would settle on one sensor's evidence
what the segment search weighs across every sensor.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rangeproc.tracking.pass_splits import swapped_splits
from rangeproc.tracking.plots import INITIATION_SPEED
from rangeproc.tracking.retrodiction import MIN_SHARED, backward_labels, retrodicted
from rangeproc.tracking.speed_bound import fitted_speed

#: The backward grouping replaces the forward one only when its summed track score is higher
#: by at least this much (a likelihood ratio of e^2, about 7): near ties stay as tracked.
SETTLE_MARGIN = 2.0

#: The tracker as run here: (t, p, R, scan, clock, bound, scores) -> label (N,), -1 clutter,
#: the speed of a new track on each plot bounded at ``bound`` (N,) m/s, the score of each
#: confirmed track appended to
#: ``scores`` in label order (arguments as ``tracking.plot_tracker.track_plots``).
Tracker = Callable[..., np.ndarray]


def both_passes(track: Tracker, t: np.ndarray, p: np.ndarray, R: np.ndarray,
                scan: np.ndarray, clock: np.ndarray, axes: int = 3,
                tails: np.ndarray | None = None, confirm: float | None = None,
                stationary: Callable[[], np.ndarray] | None = None) -> np.ndarray:
    """(N,) the track labels (-1 clutter) of ``track`` over plots t (N,) s, p (N, 3) m,
    R (N, 3, 3) m^2, scan (N,), clock (N,) (as ``tracking.plot_tracker.track_plots``;
    ``axes`` 2 for a planar sensor; ``tails`` the clock of the backward tracks' stray-tail
    rule, default ``clock``): a first forward pass with the general speed bound
    ``INITIATION_SPEED`` fits the bound of new tracks to the speeds of its confirmed tracks
    (``tracking.speed_bound``), except on the plots ``stationary()`` (N,) bool marks (called
    once, only when the bound narrows: stationary returns keep the general bound); with it, the
    forward and the backward pass; with ``confirm``
    (the tracker's confirmation score) the forward tracks that held two objects in turn
    first given the backward grouping (``tracking.pass_splits.swapped_splits``); then the
    passes' exchanges settled (:func:`settled`) and each forward track given its backward
    partner's plots before and after it (``retrodiction.retrodicted``)."""
    scores: list[float] = []
    back_scores: list[float] = []
    bound = np.full(t.size, INITIATION_SPEED)
    label = track(t, p, R, scan, clock, bound, scores)
    speed = fitted_speed(label, t, p, axes)
    if speed < INITIATION_SPEED:
        keep = np.zeros(t.size, dtype=bool) if stationary is None else stationary()
        bound = np.where(keep, INITIATION_SPEED, speed)
        scores.clear()
        label = track(t, p, R, scan, clock, bound, scores)
    back = backward_labels(lambda *a: track(*a, back_scores), t, p, R, scan, clock, tails,
                           (bound,))
    if confirm is not None:
        label, scores = swapped_splits(label, back, scores, back_scores, clock, confirm)
    return retrodicted(settled(label, back, scores, back_scores), back, clock)


def disagreements(forward: np.ndarray, backward: np.ndarray
                  ) -> list[tuple[list[int], list[int]]]:
    """The forward and backward tracks (labels of ``forward`` and ``backward`` (N,), -1
    clutter) linked by at least ``MIN_SHARED`` shared plots, grouped into connected sets:
    (forward labels, backward labels) of each set with more than one track on both sides: an
    exchange of plots between tracks. A forward track the backward pass splits, or two it
    joins, is fragmentation, left to the segment-level search as every track's gaps are."""
    nf, nb = int(forward.max()) + 1, int(backward.max()) + 1
    both = (forward >= 0) & (backward >= 0)
    shared = np.zeros((max(nf, 0), max(nb, 0)), dtype=np.int64)
    np.add.at(shared, (forward[both], backward[both]), 1)
    link = shared >= MIN_SHARED
    seen = np.zeros(nf, dtype=bool)
    out = []
    for f0 in range(nf):
        if seen[f0]:
            continue
        fs, bs = np.zeros(nf, dtype=bool), np.zeros(nb, dtype=bool)
        fs[f0] = True
        while True:                              # grow the set until it is closed
            bs_new = link[fs].any(axis=0) | bs
            fs_new = link[:, bs_new].any(axis=1) | fs
            if (bs_new == bs).all() and (fs_new == fs).all():
                break
            fs, bs = fs_new, bs_new
        seen |= fs
        if fs.sum() > 1 and bs.sum() > 1:
            out.append((np.flatnonzero(fs).tolist(), np.flatnonzero(bs).tolist()))
    return out


def settled(forward: np.ndarray, backward: np.ndarray, forward_scores: list[float],
            backward_scores: list[float]) -> np.ndarray:
    """(N,) ``forward``'s track labels (-1 clutter) with each disagreement with ``backward``
    (:func:`disagreements`) given the backward grouping where its summed track score (of
    ``backward_scores``, one per backward label) beats the forward one's (of
    ``forward_scores``) by ``SETTLE_MARGIN``; tracks numbered 0, 1, ... by first plot."""
    out = forward.copy()
    if forward.size == 0 or forward.max() < 0 or backward.max() < 0:
        return out
    fresh = int(forward.max()) + 1
    for fs, bs in disagreements(forward, backward):
        ahead = sum(forward_scores[f] for f in fs)
        behind = sum(backward_scores[b] for b in bs)
        if behind < ahead + SETTLE_MARGIN:
            continue
        mine = np.isin(forward, fs) | (forward < 0)
        out[np.isin(out, fs)] = -1
        for b in bs:
            out[(backward == b) & mine] = fresh
            fresh += 1
    labels = np.unique(out[out >= 0])
    first = np.array([np.flatnonzero(out == k)[0] for k in labels], dtype=np.int64)
    renum = np.full(fresh, -1, dtype=np.int64)
    renum[labels[np.argsort(first)]] = np.arange(labels.size)
    return np.where(out >= 0, renum[np.maximum(out, 0)], -1)
