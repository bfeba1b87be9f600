"""Stationary returns (tracking.stationary.moving_tracks): a moored boat, its position known
to its noise scan after scan, is no object even where its plots outscore the clutter map; a
moored boat that leaves keeps its one track, its plots at the berth included."""
from __future__ import annotations

import numpy as np
import pytest

import rangeproc.tracking.plot_tracker as pt

PERIOD = 0.1                    # s, a harbour lidar's scan
LEAVES = 30.0                   # s, when the second moored boat leaves


def _berths(seed: int):
    """60 s of a planar 10 Hz sensor (plot sigma 2.6 m, detection probability 0.9), 0.05
    clutter plots a scan over 300 m x 300 m, two quay scatterers seen in 30 % of the scans;
    a boat at 2 m/s; a moored boat (1 m about its berth); a second moored boat that leaves
    at ``LEAVES`` s at 1.5 m/s. (t, p, R, scan, kind): kind 0 clutter, 1 boat, 2 quay,
    3 moored boat, 4 the boat that leaves."""
    rng = np.random.default_rng(seed)
    rows = []
    for k in range(600):
        tk = k * PERIOD
        if rng.random() < 0.9:
            rows.append((tk, [-100.0 + 2.0 * tk + rng.normal(0, 2.6), 50.0 + rng.normal(0, 2.6)],
                         1))
        for q in ([-60.0, -120.0], [-30.0, -120.0]):
            if rng.random() < 0.3:
                rows.append((tk, list(np.array(q) + rng.normal(0, 1.0, 2)), 2))
        if rng.random() < 0.9:
            rows.append((tk, [60.0 + rng.normal(0, 1.0), -80.0 + rng.normal(0, 1.0)], 3))
        if rng.random() < 0.9:
            x = 1.5 * max(0.0, tk - LEAVES)
            rows.append((tk, [x + rng.normal(0, 1.0), -40.0 + rng.normal(0, 1.0)], 4))
        for _ in range(rng.poisson(0.05)):
            rows.append((tk, list(rng.uniform(-150.0, 150.0, 2)), 0))
    t = np.array([r[0] for r in rows])
    p = np.array([[*r[1], 0.0] for r in rows])
    kind = np.array([r[2] for r in rows])
    R = np.tile(np.diag([2.6 ** 2, 2.6 ** 2, 1e4]), (t.size, 1, 1))
    return t, p, R, np.round(t / PERIOD).astype(np.int64), kind


def _labels(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t, p, R, scan, kind = _berths(seed)
    return t, kind, pt.track_plots(t, p, R, scan, scan.astype(float), planar=True)


def _largest_track(label: np.ndarray) -> int:
    """The most plots of ``label`` (N,) in one track (0 if none)."""
    return int(np.bincount(label[label >= 0], minlength=1).max())


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_moored_boat_and_quay_scatterers_stay_stationary_returns(seed):
    _, kind, label = _labels(seed)
    assert _largest_track(label[kind == 3]) <= pt.CONFIRM_SCANS
    assert _largest_track(label[kind == 2]) <= pt.CONFIRM_SCANS


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_negative_control_without_the_test_of_motion_the_moored_boat_is_a_track(
        seed, monkeypatch):
    monkeypatch.setattr(pt, "moving_tracks", lambda label, p, R, planar: label)
    _, kind, label = _labels(seed)
    assert _largest_track(label[kind == 3]) > 400


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_moored_boat_that_leaves_keeps_its_one_track_and_a_boat_its_own(seed):
    t, kind, label = _labels(seed)
    for k in (1, 4):
        mine = label[kind == k]
        assert np.mean(mine == np.bincount(mine[mine >= 0]).argmax()) > 0.98   # one track
    leaving = int(np.bincount(label[(kind == 4) & (label >= 0)]).argmax())
    assert np.mean(kind[label == leaving] == 4) > 0.98                  # pure
    assert np.count_nonzero((label == leaving) & (t < LEAVES)) > 200   # at its berth too


def test_a_track_between_two_scatterers_of_a_quay_did_not_move_a_slow_boat_did():
    rng = np.random.default_rng(1)
    R = np.tile(np.diag([36.0, 36.0, 1e4]), (40, 1, 1))
    spot = np.where((np.arange(40) // 8) % 2 == 0, 0.0, 20.0)     # blocks 20 m apart
    quay = np.c_[spot, np.zeros(40), np.zeros(40)] + rng.normal(0, 6, (40, 3))
    boat = np.c_[2.0 * np.arange(40), np.zeros(40), np.zeros(40)] + rng.normal(0, 6, (40, 3))
    label = np.zeros(40, dtype=np.int64)
    assert (pt.moving_tracks(label, quay, R, True) == -1).all()
    assert (pt.moving_tracks(label, boat, R, True) == 0).all()
    both = pt.moving_tracks(np.repeat([0, 1], 40), np.concatenate([quay, boat]),
                            np.concatenate([R, R]), True)
    assert (both[:40] == -1).all() and (both[40:] == 0).all()    # renumbered from 0


def test_motion_is_judged_in_each_axis_own_noise():
    # eight plots of an aircraft closing 1 km in range under a surveillance radar whose
    # elevation error at long range is 600 m: judged on the mean of the axes' variances its
    # motion vanished, and a track of a real object was left as clutter (bench scale kind)
    R = np.tile(np.diag([40.0 ** 2, 40.0 ** 2, 600.0 ** 2]), (8, 1, 1))
    p = np.c_[np.linspace(0.0, 1000.0, 8), np.zeros(8), np.zeros(8)]
    assert (pt.moving_tracks(np.zeros(8, dtype=np.int64), p, R, False) == 0).all()
    d = p[:4].mean(axis=0) - p[4:].mean(axis=0)                # the negative control
    assert d @ d / np.mean(np.diag(R[0])) < float(pt.chi2_ppf(pt.GATE_PROBABILITY, 3))
    still = np.random.default_rng(0).normal(0.0, 40.0, (8, 3))
    assert (pt.moving_tracks(np.zeros(8, dtype=np.int64), still, R, False) == -1).all()


def test_a_track_too_short_to_tell_is_kept():
    # a lidar's 5 plots of a boat at 2 m/s in its last 0.4 s in view: no motion to see
    rng = np.random.default_rng(2)
    R = np.tile(np.diag([2.6 ** 2, 2.6 ** 2, 1e4]), (5, 1, 1))
    p = np.c_[0.2 * np.arange(5), np.zeros(5), np.zeros(5)] + rng.normal(0, 2.6, (5, 3))
    assert (pt.moving_tracks(np.zeros(5, dtype=np.int64), p, R, True) == 0).all()
    assert 5 < 2 * pt.CONFIRM_SCANS
