"""A forward plot track that held two objects in turn, split by the backward pass.

Two boats that travel side by side, closer than the radar resolves, give one plot a scan
between them for a while; a forward track follows that plot, and where the two come apart it
keeps one of them. Which one is a coin toss in the scan they part: the forward track may go on
with the second boat, whose plots it met first after the merged stretch, and the first boat's
later plots then start a new track that must earn its confirmation again from a new-object
start among the plots of the track beside it (in a recording: tens of seconds of one boat's
plots left as clutter, and the second boat's plots in the scans they part as well). The
backward pass meets the place from the other side, where both boats have their tracks, and
follows each back through the merged stretch: two backward tracks, each sharing plots with
the one forward track, each with plots the forward pass left as clutter.

``tracking.two_passes`` settles the exchanges where two or more tracks stand on both sides and
leaves a forward track that the backward pass only splits to the segment-level search, as
fragmentation: one object whose track the backward pass breaks at a gap. The two cases differ
in time. One object gives at most one plot a scan (``tracking.plot_tracker``: *Scans and
revisits*), so the backward tracks of one object's fragments follow one another; backward
tracks with plots in the same scans, at least ``MIN_SHARED`` of them, are two objects at once,
and the forward track that shares plots with both held both in turn.

Such a split is settled by the rule of ``tracking.two_passes.settled`` (Reid 1979; Blackman
and Popoli 1999, 16.3): the forward grouping (the one track; the plots it left out are clutter)
and the backward grouping (the backward tracks, over the forward track's plots and the clutter
plots) are two global hypotheses scored by the sum of their tracks' scores (the log-likelihood
ratio object / clutter), and the backward grouping replaces the forward one when it is likelier
by the evidence asked of a new track for each object it adds: the confirmation score
``tracking.plot_tracker.CONFIRM_SCORE`` (Wald's threshold, a likelihood ratio of 900; a split
is a claim of one object more, and the excess of its score over the forward track's is that
object's evidence). Plots the forward pass gave to other tracks stay with them. Nothing here
depends on a sensor's numbers: the test is the tracker's own score and the one-plot-a-scan
rule of its scans.
"""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.retrodiction import MIN_SHARED


def swapped_splits(forward: np.ndarray, backward: np.ndarray, forward_scores: list[float],
                   backward_scores: list[float], clock: np.ndarray, confirm: float
                   ) -> tuple[np.ndarray, list[float]]:
    """``forward`` (N,) track labels (-1 clutter) with each forward track that held two
    objects in turn (module docstring) replaced by its backward tracks, and the scores
    (one per label) to go with them: (labels (N,), scores). A forward track is replaced when
    it shares at least ``MIN_SHARED`` plots with each of two or more backward tracks that
    share so many with no other forward track, two of them have plots in at least
    ``MIN_SHARED`` common scans (``clock`` (N,), scans or revisits) and their summed score
    (``backward_scores``, one per label of ``backward`` (N,)) beats the forward track's
    (``forward_scores``) by ``confirm`` (the tracker's confirmation score) for each backward
    track beyond the first. New tracks take fresh labels above the forward ones; the
    replaced label is left empty (``two_passes.settled`` numbers the tracks afresh)."""
    out = forward.copy()
    scores = list(forward_scores)
    if forward.size == 0 or forward.max() < 0 or backward.max() < 0:
        return out, scores
    nf, nb = int(forward.max()) + 1, int(backward.max()) + 1
    both = (forward >= 0) & (backward >= 0)
    shared = np.zeros((nf, nb), dtype=np.int64)
    np.add.at(shared, (forward[both], backward[both]), 1)
    link = shared >= MIN_SHARED
    fresh = nf
    for f in range(nf):
        bs = np.flatnonzero(link[f])
        if bs.size < 2 or link[:, bs].sum() != bs.size:     # an exchange: two_passes'
            continue
        if not _coexist([clock[backward == b] for b in bs]):
            continue
        # each object more than the forward grouping's must earn a confirmed track's score
        excess = sum(backward_scores[b] for b in bs) - forward_scores[f]
        if excess < (bs.size - 1) * confirm:
            continue
        mine = (forward == f) | (forward < 0)
        out[forward == f] = -1
        for b in bs:
            out[(backward == b) & mine] = fresh
            scores.append(backward_scores[b])
            fresh += 1
    return out, scores


def _coexist(scans: list[np.ndarray]) -> bool:
    """Whether two of the tracks whose plots lie in ``scans`` (one array of scans or
    revisits per track) have plots in at least ``MIN_SHARED`` common scans: two objects at
    once, not one object's fragments."""
    whole = [np.unique(np.floor(s + 0.5)) for s in scans]
    return any(np.intersect1d(a, b).size >= MIN_SHARED
               for i, a in enumerate(whole) for b in whole[i + 1:])
