"""Relay between objects (track synthesis step 5; He 2015 relays between sensors): a
discovered object that continues another across a gap, or continues one of the other's sensor
tracks, joins it when its rows near the gap fit the other's trajectory carried across; with one
declared target, an object alone in time is that target. Used by ``tracking.synthesis``.
"""
from __future__ import annotations

from collections.abc import Sequence

from rangeproc.tracking.objects import (
    Objects,
    Segment,
    as_batch,
    member_conflict,
    overlaps,
    spread,
)
from rangeproc.tracking.score import ObjectTrack, segment_score

#: A segment is scored against an object whose span it comes within this many seconds of.
BRIDGE_SECONDS = 60.0
#: Two objects are joined across a gap on the rows within this many seconds of the gap (or
#: the gap's length, if longer): the carried trajectory predicts the other object only near
#: its end, and a manoeuvre later on is no evidence against the join.
RELAY_WINDOW_SECONDS = 10.0
#: Share of a segment's rows that must fit an object (positive llr) for a candidate link.
MIN_FIT_SHARE = 0.5
#: Rows of a segment scored against an object: at most these many, evenly spread.
SCORED_ROWS = 1_500


def stitch(objects: Objects, anchored: list[str], discovered: list[str],
            segs_of: dict[str, list[Segment]]) -> list[str]:
    """Relay between objects (step 5): a discovered object that lies before or after another
    object in time (overlapping it by less than ``OVERLAP_SECONDS``, within
    ``BRIDGE_SECONDS``), or continues one of the other's sensor tracks across a gap while
    overlapping it (:func:`_track_relay`), joins it when its rows within
    ``RELAY_WINDOW_SECONDS`` of the gap fit
    that object's trajectory carried across it (positive score, ``MIN_FIT_SHARE`` of the
    rows). Joins are made best score first, each only when the two groups hold no segments of
    one sensor overlapping in time (``objects.same_sensor_conflict``; greedy stitching: where a
    formation splits, the better continuation takes the track and the other one is then
    excluded). Returns the discovered objects left."""
    names = [*anchored, *discovered]
    spans = {k: _span(objects, k) for k in names if k in objects.tracks}
    pair_score: dict[tuple[str, str], float] = {}
    for k in discovered:
        if k not in spans:
            continue
        a0, a1 = spans[k]
        for other in names:
            if other == k or other not in spans:
                continue
            b0, b1 = spans[other]
            if overlaps(a0, a1, b0, b1):      # only where it continues one of other's tracks
                relay = _track_relay(segs_of.get(k, []), segs_of.get(other, []))
                if relay is None:
                    continue
                after, gap, edge = relay
            elif a1 < b0 - BRIDGE_SECONDS or a0 > b1 + BRIDGE_SECONDS:
                continue
            else:
                after, gap, edge = a0 >= b0, a0 - b1 if a0 >= b0 else b0 - a1, \
                    a0 if a0 >= b0 else a1
            score = _relay_score(objects, segs_of.get(k, []), objects.tracks[other],
                                 after=after, gap=gap, edge=edge)
            if score is not None:
                key = (min(k, other), max(k, other))
                pair_score[key] = max(pair_score.get(key, score), score)
    root = {k: k for k in names}

    def find(k: str) -> str:
        while root[k] != k:
            k = root[k]
        return k

    changed: set[str] = set()
    for (p, q), _ in sorted(pair_score.items(), key=lambda kv: -kv[1]):
        a, b = find(p), find(q)
        if a == b or (a in anchored and b in anchored) or any(
                member_conflict(objects, b, seg, segs_of) for seg in segs_of.get(a, [])):
            continue
        keep, gone = (b, a) if b in anchored or (a not in anchored
                                                and spans[b][0] <= spans[a][0]) else (a, b)
        root[gone] = keep
        objects.members[keep].extend(objects.members.pop(gone))
        segs_of.setdefault(keep, []).extend(segs_of.pop(gone, []))
        changed.add(keep)
    objects.estimate_many(sorted({find(k) for k in changed}))
    return [k for k in discovered if root[k] == k]


def _track_relay(segs: list[Segment], other: list[Segment]
                 ) -> tuple[bool, float, float] | None:
    """Where an object overlapping another in time is a piece of one of the other's sensor
    tracks cut out by a gap (a radar that lost its object for a few seconds while another
    sensor, e.g. a theodolite, kept the other object's span going): ``(after, gap, edge)``
    for :func:`_relay_score` of the closest such join (a segment of ``segs`` that ends
    before, or starts after, a segment of ``other`` of the same sensor and ``track_id``
    hint, within ``BRIDGE_SECONDS``), or None."""
    best: tuple[bool, float, float] | None = None
    for seg in segs:
        if seg.track < 0:
            continue
        for o in other:
            if o.sensor != seg.sensor or o.track != seg.track:
                continue
            if o.t0 >= seg.t1:
                cand = (False, o.t0 - seg.t1, seg.t1)
            elif seg.t0 >= o.t1:
                cand = (True, seg.t0 - o.t1, seg.t0)
            else:
                continue
            if cand[1] <= BRIDGE_SECONDS and (best is None or cand[1] < best[1]):
                best = cand
    return best


def _relay_score(objects: Objects, segs: list[Segment], track: ObjectTrack, *, after: bool,
                 gap: float, edge: float) -> float | None:
    """Score (nats) of segments ``segs`` continuing ``track`` across a gap of ``gap`` s
    (``after``: they come after it; ``edge``: their own start, else their end, s), on their
    rows within ``max(RELAY_WINDOW_SECONDS, gap)`` of the edge; None unless it is positive
    and ``MIN_FIT_SHARE`` of those rows fit."""
    window = max(RELAY_WINDOW_SECONDS, gap)
    total, fit, n = 0.0, 0, 0
    for seg in segs:
        t = objects.rows[seg.sensor].t[seg.rows]
        near = seg.rows[t <= edge + window] if after else seg.rows[t >= edge - window]
        if near.size == 0:
            continue
        batch = as_batch(objects.rows[seg.sensor], objects.sensor_ids, seg.sensor)
        scored = spread(near, SCORED_ROWS)
        llr = segment_score(batch, scored, track)[2]
        total += float(llr.sum()) * near.size / scored.size
        fit += int((llr > 0.0).sum())
        n += llr.size
    return total if total > 0.0 and n and fit / n >= MIN_FIT_SHARE else None


def _span(objects: Objects, key: str) -> tuple[float, float]:
    """Time span (s) of an object's estimated trajectory."""
    t = objects.tracks[key].t
    return float(t[0]), float(t[-1])


def relay_lone_objects(objects: Objects, declared: Sequence[str], anchored: list[str],
                        discovered: list[str], segs_of: dict[str, list[Segment]]
                        ) -> list[str]:
    """With one declared target, anchored: a discovered object that overlaps no other object
    in time (within ``BRIDGE_SECONDS``) is that target seen at another time (one object in the
    air at a time, e.g. a GPS on another time scale or a long outage); it joins the target.
    Returns the discovered objects left."""
    if len(declared) != 1 or declared[0] not in anchored:
        return discovered
    target = declared[0]
    spans = {k: _span(objects, k) for k in [target, *discovered]}
    left = []
    for k in discovered:
        a0, a1 = spans[k]
        alone = all(b1 + BRIDGE_SECONDS < a0 or a1 + BRIDGE_SECONDS < b0
                    for j, (b0, b1) in spans.items() if j != k)
        if not alone:
            left.append(k)
            continue
        objects.members[target].extend(objects.members.pop(k))
        segs_of.setdefault(target, []).extend(segs_of.pop(k, []))
    return left
