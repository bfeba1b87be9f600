"""The fitted speed bound of new plot tracks (``tracking.speed_bound``), the clock that counts
a sensor's silences (``tracking.plots.silent_clock``) and the plots of stationary returns
(``tracking.clutter_map.on_stationary_returns``), on small scenes with known truth."""
from __future__ import annotations

import numpy as np

from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.clutter_map import on_stationary_returns
from rangeproc.tracking.plots import INITIATION_SPEED, MAX_MISSES, silent_clock
from rangeproc.tracking.retrodiction import backward_labels
from rangeproc.tracking.speed_bound import (SPEED_FLOOR, SPEED_MARGIN, fitted_speed,
                                            track_speeds)


def _boat(speed: float, n: int, dt: float, sigma: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """Times (n,) s and ENU positions (n, 3) m of a boat going east at ``speed`` m/s, seen
    every ``dt`` s with ``sigma`` m of noise per axis."""
    t = np.arange(n) * dt
    p = np.column_stack([speed * t, np.zeros(n), np.zeros(n)])
    return t, p + rng.normal(0.0, sigma, (n, 3)) * [1.0, 1.0, 0.0]


def test_track_speeds_and_the_fitted_bound() -> None:
    """A 5 m/s boat seen by a 2.5 s radar (5 m noise) and a moored boat: the boat's speed is
    measured within a few m/s below its truth (less two sigmas of its error), the moored
    boat's near 0, a 3-plot track has none; the bound is the margin times the fastest, the
    floor when nothing moves, the general bound without a measured track."""
    rng = np.random.default_rng(1)
    tb, pb = _boat(5.0, 48, 2.5, 5.0, rng)
    tm, pm = _boat(0.0, 48, 2.5, 5.0, rng)
    t = np.concatenate([tb, tm, tb[:3]])
    p = np.concatenate([pb, pm + [300.0, 0.0, 0.0], pb[:3] + [0.0, 500.0, 0.0]])
    label = np.repeat([0, 1, 2], [48, 48, 3])
    order = np.argsort(t, kind="stable")
    speeds = track_speeds(label[order], t[order], p[order], 2)
    assert 3.0 <= speeds[0] <= 5.5
    assert speeds[1] < 1.0
    assert np.isnan(speeds[2])
    bound = fitted_speed(label[order], t[order], p[order], 2)
    assert bound == max(SPEED_FLOOR, SPEED_MARGIN * speeds[0])
    moored = label == 1
    assert fitted_speed(np.zeros(48, dtype=np.int64), tm, pm, 2) == SPEED_FLOOR
    assert fitted_speed(np.full(48, -1), t[moored], p[moored], 2) == INITIATION_SPEED


def test_silent_clock_counts_the_scans_of_a_silence() -> None:
    """A lidar at 10 Hz that writes nothing for 30 s: the clock adds the missing frames of
    the silence, at most MAX_MISSES + 1; without a silence it is the frame number."""
    t = np.concatenate([np.arange(20) * 0.1, 32.0 + np.arange(20) * 0.1])
    scan = np.arange(40)
    clock = silent_clock(t, scan, 0.1)
    assert np.array_equal(clock[:20], np.arange(20.0))
    assert clock[20] - clock[19] == MAX_MISSES + 2.0            # the silence, capped
    assert np.array_equal(silent_clock(t[:20], scan[:20], 0.1), np.arange(20.0))
    # two plots a frame: both get their frame's clock
    two = silent_clock(np.repeat(t, 2), np.repeat(scan, 2), 0.1)
    assert np.array_equal(two[::2], clock) and np.array_equal(two[1::2], clock)


def test_a_stray_head_after_a_silence_is_clutter_backward() -> None:
    """A backward track that crosses a 30 s silence of a lidar and takes three plots before
    it: in frame numbers the three are no gap away and stay with the track; with the
    silence counted they are a stray tail in mirrored time and return to clutter."""
    t = np.concatenate([np.arange(3) * 0.1, 30.0 + np.arange(20) * 0.1])
    scan = np.arange(t.size)
    p = np.zeros((t.size, 3))
    R = np.tile(np.eye(3), (t.size, 1, 1))

    def one_track(t, p, R, scan, clock):
        return np.zeros(t.size, dtype=np.int64)

    plain = backward_labels(one_track, t, p, R, scan, scan.astype(float))
    assert (plain == 0).all()
    silent = backward_labels(one_track, t, p, R, scan, scan.astype(float),
                             silent_clock(t, scan, 0.1))
    assert (silent[:3] == -1).all() and (silent[3:] == 0).all()


def test_plots_of_stationary_returns() -> None:
    """A moored boat's plots, one every scan at one place, are on a stationary return; a boat
    passing at 5 m/s and scattered clutter are not."""
    rng = np.random.default_rng(2)
    n = 40
    _, moored = _boat(0.0, n, 2.5, 5.0, rng)
    _, moving = _boat(5.0, n, 2.5, 5.0, rng)
    clutter = rng.uniform(-1000.0, 1000.0, (n, 3)) * [1.0, 1.0, 0.0]
    p = np.concatenate([moored + [200.0, 200.0, 0.0], moving, clutter])
    R = np.tile(np.diag([25.0, 25.0, 1.0]), (3 * n, 1, 1))
    scan = np.tile(np.arange(n), 3)
    gate = float(chi2_ppf(0.9999, 3))
    still = on_stationary_returns(p, R, scan, True, gate)
    assert still[:n].all()
    assert not still[n:2 * n].any()
    assert still[2 * n:].mean() < 0.1
