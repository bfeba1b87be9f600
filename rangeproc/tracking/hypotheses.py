"""The global association: which segment belongs to which object, as a hypothesis search.

A hypothesis assigns every segment to one object or to none. Its score is the sum of the
chosen links' scores (``tracking.score``: log-likelihood ratios, so "none" scores 0). Two
segments of one sensor that overlap in time cannot belong to the same object (a sensor sees an
object once at a time; plot tracks sharing at most one scan excepted, see
``tracking.objects.same_sensor_conflict``), and a segment may be allowed only some objects
(gates: a link is a candidate only when its score is positive).

Search: track-oriented and best-first (A*): segments are decided in order of their start
time; a partial hypothesis is expanded by every admissible choice of the next segment, and
the open hypotheses are kept in a priority queue ordered by their optimistic bound (the score
so far plus each undecided segment's best candidate link, conflicts ignored). The first
complete hypothesis taken from the queue is therefore the exact optimum, and the second one
the runner-up. A bound on the number of expansions (``MAX_EXPANSIONS``) keeps a large problem
finite: past it, the open hypotheses are pruned to the ``BEAM`` best and the search goes on
greedily from them (the result is then flagged approximate). With three or fewer objects and
the segment counts of a flight this bound is not reached, so the result equals the exhaustive
optimum (``tests/tracking/test_hypotheses.py`` checks it against brute-force enumeration).
"""
from __future__ import annotations

import heapq
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: Expansions of the best-first search before it prunes to a beam.
MAX_EXPANSIONS = 200_000
#: Open hypotheses kept when pruning.
BEAM = 64


@dataclass(frozen=True, slots=True)
class Hypothesis:
    """A complete assignment: ``choice[i]`` the object of segment i (-1 = none), ``score``."""

    choice: tuple[int, ...]
    score: float


@dataclass(frozen=True, slots=True)
class SearchResult:
    """The best hypothesis, the runner-up (None when there is no other), whether the search
    was exact, and how many partial hypotheses it expanded."""

    best: Hypothesis
    runner_up: Hypothesis | None
    exact: bool
    expansions: int


def best_hypotheses(n_segments: int, links: Mapping[tuple[int, int], float],
                    conflicts: Sequence[tuple[int, int]]) -> SearchResult:
    """Search the assignment of segments to objects (module docstring).

    Args:
        n_segments: segments 0 .. n-1, in the order they are decided (by start time).
        links: (segment, object) -> score of the candidate link (links scoring <= 0 are
            never better than "none" and are dropped).
        conflicts: pairs of segments that may not share an object.
    """
    options: list[list[tuple[int, float]]] = [[] for _ in range(n_segments)]
    for (i, obj), w in links.items():
        if w > 0.0:
            options[i].append((obj, float(w)))
    for opts in options:
        opts.sort(key=lambda o: -o[1])
    clash: list[list[int]] = [[] for _ in range(n_segments)]
    for a, b in conflicts:
        clash[max(a, b)].append(min(a, b))          # checked when the later one is decided
    best_rest = np.zeros(n_segments + 1)
    for i in range(n_segments - 1, -1, -1):
        best_rest[i] = best_rest[i + 1] + (options[i][0][1] if options[i] else 0.0)
    counter = 0
    heap: list[tuple[float, int, float, tuple[int, ...]]] = [(-best_rest[0], counter, 0.0, ())]
    done: list[Hypothesis] = []
    expansions = 0
    exact = True
    while heap and len(done) < 2:
        _, _, score, partial = heapq.heappop(heap)
        k = len(partial)
        if k == n_segments:
            done.append(Hypothesis(partial, score))
            continue
        expansions += 1
        taken = {partial[j] for j in clash[k]}
        for obj, w in [(-1, 0.0), *options[k]]:
            if obj >= 0 and obj in taken:
                continue
            counter += 1
            s = score + w
            heapq.heappush(heap, (-(s + best_rest[k + 1]), counter, s, (*partial, obj)))
        if expansions >= MAX_EXPANSIONS and exact:
            exact = False
            heap = heapq.nsmallest(BEAM, heap)
            heapq.heapify(heap)
        elif not exact and len(heap) > BEAM:
            heap = heapq.nsmallest(BEAM, heap)
            heapq.heapify(heap)
    if not done:
        done.append(Hypothesis(tuple([-1] * n_segments), 0.0))
    return SearchResult(done[0], done[1] if len(done) > 1 else None, exact, expansions)
