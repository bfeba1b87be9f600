"""Retrodiction of plot tracks (tracking.retrodiction): a track confirmed late gets its earlier
plots from the tracker run backward in time; nothing else changes hands."""
from __future__ import annotations

import numpy as np

import rangeproc.tracking.two_passes as two_passes
from rangeproc.tracking.plot_tracker import track_plots
from rangeproc.tracking.plots import INITIATION_SPEED
from rangeproc.tracking.retrodiction import MIN_SHARED, backward_labels, retrodicted


def test_a_backward_partner_gives_its_plots_outside_the_forward_span():
    clock = np.arange(12, dtype=float)
    forward = np.array([-1, -1, -1, 0, 0, 0, 0, -1, 1, 1, -1, -1])
    backward = np.array([2, 2, 2, 2, 2, 2, -1, 2, 2, -1, 0, 0])
    out = retrodicted(forward, backward, clock)
    # plots 0-2 come before track 0's span and belong to its partner; plot 7 lies after it
    # but was the partner's and no forward track's; plot 8 stays with track 1
    assert out.tolist() == [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, -1, -1]
    # the negative control: a backward track sharing fewer than MIN_SHARED plots adds nothing
    few = np.where(np.arange(12) < 3 + MIN_SHARED - 1, 2, -1)
    assert retrodicted(forward, few, clock).tolist() == forward.tolist()


def test_the_backward_run_sees_increasing_times_and_labels_come_back_in_place():
    t = np.array([0.0, 1.0, 2.0, 3.0])
    seen = {}

    def fake(t_, p_, R_, scan_, clock_):
        seen.update(t=t_, p=p_, scan=scan_, clock=clock_)
        return np.array([0, 0, 1, 1])            # in the order the tracker was given
    p, R = np.arange(12.0).reshape(4, 3), np.tile(np.eye(3), (4, 1, 1))
    lab = backward_labels(fake, t, p, R, np.arange(4), np.arange(4.0))
    assert np.all(np.diff(seen["t"]) > 0) and np.all(np.diff(seen["scan"]) > 0)
    assert np.all(np.diff(seen["clock"]) > 0) and seen["p"][0].tolist() == [9.0, 10.0, 11.0]
    assert lab.tolist() == [1, 1, 0, 0]          # the last plots were the first it saw


def _boat_leaving_clutter(seed: int):
    """A boat at 2 m/s seen by a 2.5 s scanning radar (plot sigma 5 m, planar, detection
    probability 0.9) for 100 s among 5 clutter plots a scan over 1 km^2, and 3 more a scan
    in the 100 m square where it starts (sea clutter by a quay): its first 20 s lie in
    dense clutter, the rest in open water. (t, p, R, scan, truth): truth 0 the boat's plots,
    -1 clutter."""
    rng = np.random.default_rng(seed)
    t, p, scan, truth = [], [], [], []
    for k in range(40):
        if rng.random() < 0.9:
            p.append([-40.0 + 5.0 * k + rng.normal(0, 5), 200.0 + rng.normal(0, 5), 0.0])
            t.append(2.5 * k), scan.append(k), truth.append(0)
        for _ in range(rng.poisson(5)):
            p.append(rng.uniform([-500.0, -500.0, 0.0], [500.0, 500.0, 0.0]))
            t.append(2.5 * k), scan.append(k), truth.append(-1)
        for _ in range(rng.poisson(3)):
            p.append(rng.uniform([-70.0, 150.0, 0.0], [30.0, 250.0, 0.0]))
            t.append(2.5 * k), scan.append(k), truth.append(-1)
    R = np.tile(np.diag([25.0, 25.0, 1e4]), (len(t), 1, 1))
    return np.array(t), np.array(p), R, np.array(scan), np.array(truth)


def test_a_boat_confirmed_late_gets_its_first_plots_back(monkeypatch):
    """Seeds 1-8: the forward pass confirms the boat's track late (its first plots lie in
    clutter 60 times denser than the open water); the backward pass gives most of them
    back, with far fewer clutter plots than boat plots. Retrodiction alone: both passes with
    the general speed bound (the fitted bound, ``tracking.speed_bound``, left out)."""
    monkeypatch.setattr(two_passes, "fitted_speed", lambda *args: INITIATION_SPEED)
    late, head, boat_gain, clutter_gain = [], [], 0, 0
    for seed in range(1, 9):
        t, p, R, scan, truth = _boat_leaving_clutter(seed)
        clock = scan.astype(float)
        fwd = track_plots(t, p, R, scan, clock, planar=True, retrodict=False)
        both = track_plots(t, p, R, scan, clock, planar=True)
        boat = truth == 0
        assert np.all(both[fwd >= 0] == fwd[fwd >= 0])        # no plot changes track
        late.append(int(np.argmax(fwd[boat] >= 0)))            # boat plots before its track
        head.append(int(np.argmax(both[boat] >= 0)))
        boat_gain += int(np.count_nonzero(both[boat] >= 0) - np.count_nonzero(fwd[boat] >= 0))
        clutter_gain += int(np.count_nonzero(both[~boat] >= 0)
                            - np.count_nonzero(fwd[~boat] >= 0))
    assert np.mean(late) >= 8.0                 # the forward pass alone confirms late
    assert np.mean(head) <= np.mean(late) - 8.0
    assert boat_gain >= 3 * clutter_gain
