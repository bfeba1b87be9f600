"""A plot track that coasted onto another object (``tracking.plot_jumps``): cut where its
first plot after ``STRAY_MISSES`` missed scans or more lies outside the gate of its
cruise-model prediction; a track that only missed scans, or jumped without missing
``STRAY_MISSES`` of them, stays whole."""
from __future__ import annotations

import numpy as np

from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.plot_jumps import cruise_distance, cut_jumps
from rangeproc.tracking.plot_tails import STRAY_MISSES
from rangeproc.tracking.plot_tracker import GATE_PROBABILITY

SCAN = 4.0                      # s, a surveillance radar's scan
SIGMA = 40.0                    # m, its plot sigma per axis


def _plots(scans: list[int], start: tuple[float, float], velocity: tuple[float, float],
           rng: np.random.Generator, jump: tuple[float, float] = (0.0, 0.0),
           jump_scan: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(t, p) of an object at 5 km height flying straight at ``velocity`` m/s, seen in
    ``scans``; from ``jump_scan`` on the plots are another object's, ``jump`` m away."""
    s = np.asarray(scans, dtype=float)
    t = s * SCAN
    p = np.column_stack([start[0] + velocity[0] * t, start[1] + velocity[1] * t,
                         np.full(t.size, 5000.0)])
    if jump_scan is not None:
        p[s >= jump_scan, :2] += jump
    return t, p + rng.normal(0.0, SIGMA, p.shape)


def test_the_cruise_prediction_gates_a_straight_track_and_not_a_jump() -> None:
    rng = np.random.default_rng(3)
    t, p = _plots(list(range(10)), (0.0, 0.0), (200.0, 50.0), rng)
    R = np.broadcast_to(SIGMA ** 2 * np.eye(3), (t.size, 3, 3))
    t_next = (9 + STRAY_MISSES + 1) * SCAN
    on = np.array([200.0 * t_next, 50.0 * t_next, 5000.0])
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    assert cruise_distance(t, p, R, t_next, on, R[0]) < gate
    assert cruise_distance(t, p, R, t_next, on + [0.0, 3400.0, 0.0], R[0]) > gate
    # a stamp error along the velocity widens the gate along it only
    along = on + 0.06 * np.array([200.0, 50.0, 0.0]) * 40.0
    assert cruise_distance(t, p, R, t_next, along, R[0], stamp_sigma=40.0) < \
        cruise_distance(t, p, R, t_next, along, R[0])


def test_a_track_is_cut_where_it_jumped_across_missed_scans() -> None:
    """Track 0 follows an object to scan 15, misses ``STRAY_MISSES`` scans and then follows
    another 3.4 km away (cut); track 1 misses as many scans and goes on straight (whole);
    track 2 jumps after one scan fewer missed (whole: the tracker's gate decided); clutter
    stays clutter; the new piece is numbered on from the largest track number."""
    rng = np.random.default_rng(7)
    after = 15 + STRAY_MISSES + 1
    scans0 = [*range(16), *range(after, after + 10)]
    scans1 = [*range(2, 12), *range(12 + STRAY_MISSES, 24)]
    scans2 = [*range(3, 12), *range(11 + STRAY_MISSES, 24)]
    t0, p0 = _plots(scans0, (0.0, 0.0), (200.0, 0.0), rng, (0.0, 3400.0), after)
    t1, p1 = _plots(scans1, (0.0, 30000.0), (-150.0, 100.0), rng)
    t2, p2 = _plots(scans2, (20000.0, 0.0), (0.0, 250.0), rng, (0.0, 3400.0), 11 + STRAY_MISSES)
    tc, pc = np.array([5.0, 37.0, 90.0]), rng.normal(0.0, 10000.0, (3, 3))
    t = np.concatenate([t0, t1, t2, tc])
    p = np.concatenate([p0, p1, p2, pc])
    label = np.concatenate([np.zeros(t0.size), np.ones(t1.size), np.full(t2.size, 2),
                            np.full(tc.size, -1)]).astype(np.int64)
    order = np.argsort(t, kind="stable")
    t, p, label = t[order], p[order], label[order]
    clock = t / SCAN
    R = np.broadcast_to(SIGMA ** 2 * np.eye(3), (t.size, 3, 3))
    out = cut_jumps(t, p, R, clock, label)
    pieces = {k: sorted(set(out[label == k].tolist())) for k in (0, 1, 2)}
    assert len(pieces[0]) == 2 and len(pieces[1]) == 1 and len(pieces[2]) == 1
    head = (label == 0) & (clock < after)
    assert len(set(out[head].tolist())) == 1 and len(set(out[(label == 0) & ~head])) == 1
    assert (out[label == -1] == -1).all()
    assert sorted(set(out[out >= 0].tolist())) == [0, 1, 2, 3]
    assert (out[head] == 0).all() and (out[(label == 0) & ~head] == 3).all()
    assert (out[label == 1] == 1).all() and (out[label == 2] == 2).all()
    assert (cut_jumps(t, p, R, clock, np.full(t.size, -1)) == -1).all()
    assert cut_jumps(t[:0], p[:0], R[:0], clock[:0], label[:0]).size == 0
