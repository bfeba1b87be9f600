"""Plot tracking with clutter: three objects seen by a rotating surveillance radar."""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plot_tracker import track_plots
from rangeproc.tracking.plots import (
    is_framed,
    is_rotating,
    plot_positions,
    scan_numbers,
)

SIG = np.array([30.0, 2e-3, 2e-3])


def surveillance(seed: int = 1, scans: int = 60, period: float = 4.0, clutter: int = 20,
                 pd: float = 0.9):
    """Plots (time ordered) of 3 objects + uniform clutter: t, r, az, el, truth label."""
    rng = np.random.default_rng(seed)
    starts = np.array([[10_000.0, 20_000.0, 3_000.0], [-15_000.0, 5_000.0, 6_000.0],
                       [12_000.0, -8_000.0, 1_500.0]])
    vel = np.array([[200.0, -150.0, 0.0], [250.0, 30.0, -5.0], [-180.0, 180.0, 10.0]])
    rows = []
    for k in range(scans):
        for j in range(3):
            if rng.random() > pd:
                continue
            # the beam passes the object's azimuth at a time within the scan
            p0 = starts[j] + vel[j] * k * period
            az = np.mod(np.arctan2(p0[0], p0[1]), 2 * np.pi)
            tt = k * period + az / (2 * np.pi) * period
            p = starts[j] + vel[j] * tt
            if j == 2 and tt > 120.0:                 # a turn: 3 g for the rest
                w = 30.0 / 255.0
                dt = tt - 120.0
                c = starts[2] + vel[2] * 120.0
                p = c + np.array([-180 * np.sin(w * dt) / w + 180 * (1 - np.cos(w * dt)) / w,
                                  180 * np.sin(w * dt) / w + 180 * (1 - np.cos(w * dt)) / w,
                                  10 * dt])
            r = np.linalg.norm(p)
            rows.append((tt, r, np.mod(np.arctan2(p[0], p[1]), 2 * np.pi),
                         np.arcsin(p[2] / r), j))
        for _ in range(rng.poisson(clutter)):
            az = rng.uniform(0, 2 * np.pi)
            rows.append((k * period + az / (2 * np.pi) * period, rng.uniform(1e3, 6e4), az,
                         rng.uniform(0, 0.3), -1))
    a = np.array(sorted(rows))
    noise = rng.normal(size=(a.shape[0], 3)) * SIG
    return a[:, 0], a[:, 1] + noise[:, 0], a[:, 2] + noise[:, 1], a[:, 3] + noise[:, 2], \
        a[:, 4].astype(int)


def test_scan_numbers_follow_the_azimuth_sweep() -> None:
    t, r, az, el, _ = surveillance(scans=10)
    assert is_rotating(t, az)
    scan = scan_numbers(t, az)
    assert scan.max() == 9 and np.all(np.diff(scan) >= 0)
    assert np.all(np.floor(t / 4.0).astype(int) == scan)


def test_three_objects_are_tracked_and_clutter_is_left_out() -> None:
    t, r, az, el, truth = surveillance()
    n = t.size
    p, R = plot_positions(r, az, el, np.tile(SIG, (n, 1)), np.zeros((n, 3)),
                          np.tile(np.eye(3), (n, 1, 1)))
    label = track_plots(t, p, R, scan_numbers(t, az))
    assert label.max() + 1 >= 3
    for j in range(3):
        mine = label[truth == j]
        main = np.bincount(mine[mine >= 0]).argmax()
        assert (mine == main).mean() >= 0.9, j           # one track holds the object's plots
        assert (truth[label == main] == j).mean() >= 0.97  # and hardly anything else
    assert (label[truth == -1] >= 0).mean() < 0.02           # clutter stays clutter


def test_a_two_d_radar_without_elevation_is_tracked() -> None:
    t, r, az, el, truth = surveillance(seed=2)
    n = t.size
    p, R = plot_positions(r, az, np.full(n, np.nan), np.tile(SIG, (n, 1)), np.zeros((n, 3)),
                          np.tile(np.eye(3), (n, 1, 1)))
    label = track_plots(t, p, R, scan_numbers(t, az))
    for j in range(2):                                      # the straight ones
        mine = label[truth == j]
        assert (mine == np.bincount(mine[mine >= 0]).argmax()).mean() >= 0.85, j


def test_an_instrument_following_one_object_is_not_a_rotating_radar() -> None:
    t = np.arange(2400) * 0.05
    az = np.mod(6.0 + 0.02 * t, 2 * np.pi)          # crosses north, slowly
    assert not is_rotating(t, az)


def test_plots_stamped_per_scan_are_framed_by_time_stamp() -> None:
    t, r, az, el, truth = surveillance(seed=3)
    scan = np.floor(t / 4.0)
    t_framed = scan * 4.0                            # every plot of a scan gets one stamp
    order = np.argsort(t_framed, kind="stable")
    assert is_framed(t_framed[order]) and not is_framed(t)
    assert np.array_equal(scan_numbers(t_framed[order], az[order]),
                          scan[order].astype(np.int64) - int(scan.min()))
    n = t.size
    p, R = plot_positions(r[order], az[order], el[order], np.tile(SIG, (n, 1)),
                          np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
    label = track_plots(t_framed[order], p, R, scan_numbers(t_framed[order], az[order]),
                        stamp_sigma=4.0 / np.sqrt(12.0))
    tr = truth[order]
    for j in range(2):
        mine = label[tr == j]
        assert (mine == np.bincount(mine[mine >= 0]).argmax()).mean() >= 0.85, j
