"""The hypothesis search equals brute-force enumeration on small problems."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from rangeproc.tracking.hypotheses import best_hypotheses


def brute_force(n, links, conflicts, n_objects):
    scores = []
    for choice in itertools.product(range(-1, n_objects), repeat=n):
        if any(o >= 0 and (i, o) not in links for i, o in enumerate(choice)):
            continue
        if any(choice[a] >= 0 and choice[a] == choice[b] for a, b in conflicts):
            continue
        scores.append(sum(links[(i, o)] for i, o in enumerate(choice) if o >= 0))
    return sorted(scores, reverse=True)


@pytest.mark.parametrize("seed", range(40))
def test_equals_the_exhaustive_optimum_with_up_to_three_objects(seed) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 8))
    n_objects = int(rng.integers(1, 4))
    links = {(i, o): float(rng.normal(5.0, 10.0)) for i in range(n) for o in range(n_objects)
             if rng.random() < 0.8}
    links = {k: v for k, v in links.items() if v > 0}
    conflicts = [(a, b) for a in range(n) for b in range(a + 1, n) if rng.random() < 0.3]
    got = best_hypotheses(n, links, conflicts)
    truth = brute_force(n, links, conflicts, n_objects)
    assert got.exact
    assert got.best.score == pytest.approx(truth[0])
    choice = got.best.choice
    assert all(choice[a] < 0 or choice[a] != choice[b] for a, b in conflicts)
    assert sum(links[(i, o)] for i, o in enumerate(choice) if o >= 0) == pytest.approx(truth[0])
    if len(truth) > 1:
        assert got.runner_up is not None
        assert got.runner_up.score == pytest.approx(truth[1])


def test_a_conflict_sends_the_weaker_segment_elsewhere() -> None:
    links = {(0, 0): 50.0, (1, 0): 40.0, (1, 1): 30.0}
    got = best_hypotheses(2, links, [(0, 1)])
    assert got.best.choice == (0, 1) and got.best.score == 80.0
    assert got.runner_up.score == 50.0              # (0, none) beats (none, 0)=40 and ...


def test_no_candidates_means_everything_unassigned() -> None:
    got = best_hypotheses(3, {}, [])
    assert got.best.choice == (-1, -1, -1) and got.runner_up is None
