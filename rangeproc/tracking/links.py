"""Candidate links between pending segments and objects (track synthesis, step 3).

A pending segment is scored against every object it overlaps in time (or comes within
``relay.BRIDGE_SECONDS`` of, for relays): per-row log-likelihood ratios of its scored rows
(``tracking.score.segment_score``), cached per object version and computed side by side in
threads. A segment whose rows fit one object and then another is split where that gains
more than ``SPLIT_GAIN``; otherwise each object most of its rows fit is a candidate link,
scored by the sum of its rows' llr scaled to the segment's length; while associating (not
relaying), not where the two only meet at an end (most of the segment's scored rows beyond
the object's own rows, ``Objects.witnessed``, and most of the object's rows beyond the
segment's span) and a rival, a segment that will start an object later, explains the rows
both witness decisively better: such a segment waits for that object
(``hypotheses.best_hypotheses`` then picks the assignment). A segment whose candidate
objects are unchanged since it was last scored keeps its links (``Objects.link_cache``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from rangeproc.fusion.batch import SensorRows
from rangeproc.parallel import thread_map
from rangeproc.tracking.objects import (
    OBSERVED_GAP_SECONDS,
    Objects,
    Segment,
    as_batch,
    overlaps,
    same_sensor_conflict,
    spread,
)
from rangeproc.tracking.relay import BRIDGE_SECONDS, MIN_FIT_SHARE, SCORED_ROWS
from rangeproc.tracking.score import AMBIGUITY_NATS, ObjectTrack, segment_score

#: A segment is split in two when that gains more than this score (nats), each part holding
#: at least ``MIN_SPLIT_ROWS`` scored rows (a lock that jumped without a visible step).
SPLIT_GAIN = 50.0
MIN_SPLIT_ROWS = 10


def candidates(objects: Objects, seg: Segment, names: list[str], relay: bool
               ) -> list[tuple[int, str]]:
    """(index, name) of the objects whose span the segment comes within ``BRIDGE_SECONDS`` of
    (``relay``) or overlaps (not): the ones its rows are scored against."""
    out = []
    for j, name in enumerate(names):
        tr = objects.tracks.get(name)
        if tr is None or seg.t1 < tr.t[0] - BRIDGE_SECONDS or seg.t0 > tr.t[-1] + BRIDGE_SECONDS:
            continue
        if not relay and not overlaps(seg.t0, seg.t1, float(tr.t[0]), float(tr.t[-1])):
            continue
        out.append((j, name))
    return out


def _stale(objects: Objects, seg: Segment, name: str) -> bool:
    """True when the cached llr of ``seg`` against ``name`` is missing or out of date."""
    cached = objects.llr_cache.get((seg.id, name))
    return cached is None or cached[0] != objects.version.get(name, 0)


def _score_into_cache(objects: Objects, seg: Segment, name: str) -> None:
    """Per-row llr of the segment's scored rows against object ``name``, into the cache."""
    batch = as_batch(objects.rows[seg.sensor], objects.sensor_ids, seg.sensor)
    llr = segment_score(batch, spread(seg.rows, SCORED_ROWS), objects.tracks[name])[2]
    objects.llr_cache[(seg.id, name)] = (objects.version.get(name, 0), llr)


def _prefetch_scores(objects: Objects, segments: list[Segment], names: list[str],
                     relay: bool) -> None:
    """Score every (segment, candidate object) pair not cached yet, side by side in threads
    (``rangeproc.parallel``); the scores are the same as computing them one by one."""
    jobs = [(seg, name) for seg in segments for _, name in candidates(objects, seg, names, relay)
            if _stale(objects, seg, name)]
    thread_map(lambda job: _score_into_cache(objects, *job), jobs,
               cost=lambda job: min(job[0].rows.size, SCORED_ROWS))


def _scored_llr(objects: Objects, seg: Segment, among: list[tuple[int, str]], relay: bool
                ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Object index -> per-row llr (M,) of the segment's scored rows (``spread(seg.rows,
    SCORED_ROWS)``) against each of its candidate objects ``among`` (:func:`candidates`),
    and -> (M,) bool, the rows the object's own rows witness.

    While associating (not ``relay``), a row more than ``OBSERVED_GAP_SECONDS`` from every
    row of the object is neither evidence for it nor against it (llr 0): there the object's
    trajectory is only bridged, and a bridge's sigma lets the rows of any object nearby
    fit. A declared target's GPS outage of 20 s in a formation otherwise took the tracking
    radar's rows of the aircraft 100-300 m beside it (identity swaps). Rows in an object's
    gaps are scored when relays are (``relay``), among every
    object that could continue there.
    """
    out: dict[int, np.ndarray] = {}
    known: dict[int, np.ndarray] = {}
    t = objects.rows[seg.sensor].t[spread(seg.rows, SCORED_ROWS)]
    for j, name in among:
        if _stale(objects, seg, name):
            _score_into_cache(objects, seg, name)
        llr = objects.llr_cache[(seg.id, name)][1]
        known[j] = np.ones(t.size, dtype=bool) if relay else objects.witnessed(name, t)
        out[j] = llr if known[j].all() else np.where(known[j], llr, 0.0)
    return out, known


def best_split(llr: Mapping[int, np.ndarray], min_part: int) -> tuple[int, float]:
    """The split of a segment whose rows fit one object and then another (or none): the row
    index k (rows[:k] | rows[k:]) and the score gained over keeping it whole; (0, 0) when no
    split gains. ``llr``: object -> per-row llr (M,)."""
    if not llr:
        return 0, 0.0
    keys = list(llr)
    L = np.vstack([llr[j] for j in keys])                  # (J, M)
    m = L.shape[1]
    if m < 2 * min_part:
        return 0, 0.0
    head = np.concatenate([np.zeros((len(keys), 1)), np.cumsum(L, axis=1)], axis=1)
    tail = head[:, -1:] - head                             # (J, M + 1): sum of rows[k:]
    whole = max(0.0, float(head[:, -1].max()))
    ks = np.arange(min_part, m - min_part + 1)
    best_k, best = 0, whole
    for a in range(len(keys)):
        others = np.delete(np.arange(len(keys)), a)
        other_tail = np.maximum(tail[others][:, ks].max(axis=0), 0.0) if others.size \
            else np.zeros(ks.size)
        other_head = np.maximum(head[others][:, ks].max(axis=0), 0.0) if others.size \
            else np.zeros(ks.size)
        for value in (head[a, ks] + other_tail, tail[a, ks] + other_head):
            i = int(np.argmax(value))
            if value[i] > best:
                best, best_k = float(value[i]), int(ks[i])
    return best_k, best - whole


def _split(seg: Segment, k_rows: int, new_id: Callable[[], int], rows: SensorRows
           ) -> tuple[Segment, Segment]:
    """Two segments from ``seg``: its rows [:k_rows] and [k_rows:]."""
    parts = []
    for part in (slice(None, k_rows), slice(k_rows, None)):
        sel = seg.rows[part]
        t = rows.t[sel]
        parts.append(Segment(new_id(), seg.sensor, sel, seg.track, float(t[0]), float(t[-1]),
                             bool(np.isfinite(rows.z[sel, 0]).mean() > 0.5), seg.plot,
                             None if seg.scans is None else seg.scans[part]))
    return parts[0], parts[1]


def score_links(objects: Objects, pending: list[Segment], names: list[str],
                 new_id: Callable[[], int], replaced: dict[int, tuple[int, int]],
                 relay: bool, rivals: Mapping[int, Rival] | None = None
                 ) -> tuple[list[Segment], dict[tuple[int, int], float]]:
    """Candidate links (pending index, object index) -> score (``tracking.synthesis`` step 3),
    after splitting the segments whose rows fit one object and then another
    (``SPLIT_GAIN``): the pending list may change. ``rivals``: seed segment id -> the quick
    trajectory of a segment that will start an object later (:func:`_rival_better`)."""
    rivals = rivals or {}
    out: list[Segment] = []
    links: dict[tuple[int, int], float] = {}
    queue = list(pending)
    _prefetch_scores(objects, queue, names, relay)
    while queue:
        seg = queue.pop(0)
        # the same candidates at the same versions as last time: the same links, no split
        among = candidates(objects, seg, names, relay)
        versions = (tuple((j, name, objects.version.get(name, 0)) for j, name in among),
                    tuple(sorted(k for k in rivals if k != seg.id)))
        cached = objects.link_cache.get((seg.id, relay))
        if cached is not None and cached[0] == versions:
            seg_links = cached[1]
        else:
            scored = spread(seg.rows, SCORED_ROWS)
            llr, known = _scored_llr(objects, seg, among, relay)
            k, gain = best_split(llr, max(MIN_SPLIT_ROWS, scored.size // 50))
            if gain > SPLIT_GAIN:
                k_rows = int(np.searchsorted(seg.rows, scored[k]))
                a, b = _split(seg, k_rows, new_id, objects.rows[seg.sensor])
                replaced[seg.id] = (a.id, b.id)
                queue[:0] = [a, b]
                continue
            among_names = dict(among)
            seg_links = {j: float(v.sum()) * seg.rows.size / scored.size
                         for j, v in llr.items()
                         if v.sum() > 0.0 and known[j].any()
                         and (v[known[j]] > 0.0).mean() >= MIN_FIT_SHARE
                         and (relay or known[j].mean() >= MIN_FIT_SHARE
                              or _inside_share(objects, among_names[j], seg) >= MIN_FIT_SHARE
                              or not _rival_better(objects, seg, v, known[j], rivals))}
            if relay:
                seg_links = _decisive(seg_links)
            objects.link_cache[(seg.id, relay)] = (versions, seg_links)
        i = len(out)
        out.append(seg)
        for j, w in seg_links.items():
            links[(i, j)] = w
    return out, links


@dataclass(frozen=True)
class Rival:
    """A pending segment that will start an object later in discovery: its rows' times
    ``t`` (M,) s ascending and its quick trajectory."""

    t: np.ndarray
    track: ObjectTrack


def _rival_better(objects: Objects, seg: Segment, llr: np.ndarray, known: np.ndarray,
                  rivals: Mapping[int, Rival]) -> bool:
    """True when a rival (a segment that will start an object later) explains the segment's
    scored rows that both it and the object witness decisively better (``AMBIGUITY_NATS``)
    than the object does: ``llr`` (M,) the rows' llr against the object, ``known`` (M,) the
    rows its own rows witness."""
    scored = spread(seg.rows, SCORED_ROWS)
    t = objects.rows[seg.sensor].t[scored]
    batch = as_batch(objects.rows[seg.sensor], objects.sensor_ids, seg.sensor)
    for key, rival in rivals.items():
        if key == seg.id:
            continue
        k = np.searchsorted(rival.t, t)
        near = np.minimum(np.abs(t - rival.t[np.clip(k - 1, 0, rival.t.size - 1)]),
                          np.abs(rival.t[np.clip(k, 0, rival.t.size - 1)] - t))
        both = known & (near <= OBSERVED_GAP_SECONDS)
        if not both.any():
            continue
        theirs = segment_score(batch, scored, rival.track)[2]
        if float(theirs[both].sum() - llr[both].sum()) >= AMBIGUITY_NATS:
            return True
    return False


def _inside_share(objects: Objects, name: str, seg: Segment) -> float:
    """Share of object ``name``'s member rows whose times lie within the segment's span
    (widened by ``OBSERVED_GAP_SECONDS``): 1 for an object the segment spans, small for one
    it only meets at an end."""
    mt = objects.member_t[name]
    if mt.size == 0:
        return 0.0
    inside = (mt >= seg.t0 - OBSERVED_GAP_SECONDS) & (mt <= seg.t1 + OBSERVED_GAP_SECONDS)
    return float(inside.mean())


def _decisive(seg_links: dict[int, float]) -> dict[int, float]:
    """A relayed segment's links (object index -> score, nats): the best alone when it beats
    the runner-up by ``AMBIGUITY_NATS``, none when another object fits nearly as well."""
    if len(seg_links) < 2:
        return seg_links
    ranked = sorted(seg_links.items(), key=lambda kv: -kv[1])
    if ranked[0][1] - ranked[1][1] < AMBIGUITY_NATS:
        return {}
    return dict(ranked[:1])


def conflicts(pending: list[Segment]) -> list[tuple[int, int]]:
    """Pairs of pending segments that cannot share an object: of one sensor, overlapping in
    time (``objects.same_sensor_conflict``)."""
    return [(a, b) for a in range(len(pending)) for b in range(a + 1, len(pending))
            if same_sensor_conflict(pending[a], pending[b])]
