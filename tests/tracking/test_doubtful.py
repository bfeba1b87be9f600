"""Which objects' quick trajectories are refined before the plots are re-associated
(``tracking.reassociation.doubtful``)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rangeproc.tracking.score import ObjectTrack, score_rows_left_out
from rangeproc.tracking.reassociation import doubtful as _doubtful


def track(sigma_m: float) -> ObjectTrack:
    t = np.arange(0.0, 100.0, 1.0)
    P = np.tile(np.eye(9), (t.size, 1, 1)) * sigma_m ** 2
    return ObjectTrack(t, np.zeros((t.size, 9)), P, np.ones(t.size))


def test_an_object_missing_its_own_plots_where_it_is_uncertain_is_doubtful(plot_batch) -> None:
    """Plots of range sigma 40 m: the object with a 100 m position sigma (per axis) misses
    two of its own plots and is refined; the GPS-precise one (1 m) that misses one has met a
    wild plot; one whose plots all gate, or a plot of no object, calls for nothing."""
    t = np.arange(0.0, 100.0, 4.0)
    batch = plot_batch(t, np.tile([10_000.0, 0.1, 0.05], (t.size, 1)), [40.0, 1e-3, 1e-3])
    objects = SimpleNamespace(tracks={"loose": track(100.0), "precise": track(1.0),
                                      "fine": track(100.0)})
    keys = ["loose", "precise", "fine"]
    rows = np.arange(t.size)
    before = np.array([0, 1, 2, -1] * 6 + [0])[:t.size]
    gated = np.ones(t.size, dtype=bool)
    gated[[0, 4, 1, 3]] = False            # two of loose's, one of precise's, one of no one's
    assert _doubtful(objects, keys, batch, rows, before, gated) == ["loose"]
    objects.tracks["precise"] = track(30.0)           # 52 m in position: above the plot's 40
    assert _doubtful(objects, keys, batch, rows, before, gated) == ["loose", "precise"]
    assert _doubtful(objects, keys, batch, rows, before, np.ones(t.size, bool)) == []


def still_track(t: np.ndarray) -> ObjectTrack:
    """A trajectory at rest 10 km out at azimuth 0.1 rad, elevation 0.05 rad, 10 m sigma per
    axis, at times ``t`` (s)."""
    x = np.zeros((t.size, 9))
    x[:, 0] = 10_000.0 * np.sin(0.1) * np.cos(0.05)
    x[:, 1] = 10_000.0 * np.cos(0.1) * np.cos(0.05)
    x[:, 2] = 10_000.0 * np.sin(0.05)
    return ObjectTrack(t, x, np.tile(np.eye(9) * 100.0, (t.size, 1, 1)), np.ones(t.size))


def test_a_lone_outlier_is_one_a_run_is_not(plot_batch) -> None:
    """``_isolated_outliers``: of an object's plots, one far off between plots that fit is a
    lone outlier (clutter taken in a missed scan); two in a row are the trajectory's failure
    and are not called outliers."""
    from rangeproc.tracking.reassociation import isolated_outliers as _isolated_outliers

    t = np.arange(0.0, 100.0, 4.0)
    r = np.full(t.size, 10_000.0)
    r[5] += 2_000.0                                   # a lone plot 2 km off
    r[[12, 13]] += 2_000.0                            # a run of two
    batch = plot_batch(t, np.column_stack([r, np.full(t.size, 0.1), np.full(t.size, 0.05)]),
                       [40.0, 1e-3, 1e-3])
    track = still_track(t)
    rows = np.arange(t.size)
    lone = _isolated_outliers(track, batch, rows, np.ones(t.size, bool), rows)
    np.testing.assert_array_equal(np.flatnonzero(lone), [5])


def test_a_plot_between_plots_the_trajectory_barely_fits_is_no_lone_outlier(plot_batch) -> None:
    """A sparse object whose motion model went astray (a slow radar alone after a precise
    sensor stopped: its good plots lie at NIS 20-50 of the trajectory): the plot at NIS 60
    between neighbours at NIS 27 (inside the 1e-6 keep gate, outside the 1e-4 association
    gate) is the trajectory's failure, and is kept; so is one at the end beside such a
    neighbour. Judged against the keep gate alone, both neighbours looked fitting and the
    good plot was dropped (``make multi``, kind scale, seed 10: a 12 s hole in a
    surveillance-only stretch, 144 -> 238 m RMSE)."""
    from rangeproc.tracking.reassociation import isolated_outliers as _isolated_outliers

    t = np.arange(0.0, 100.0, 4.0)
    r = np.full(t.size, 10_000.0)
    r[[10, 12]] += 200.0                              # the trajectory barely fits these
    r[11] += 300.0                                    # and misses this one
    r[-2] += 200.0
    r[-1] += 300.0                                    # the last plot, beside a poor fit
    r[5] += 2_000.0                                   # a lone plot 2 km off
    batch = plot_batch(t, np.column_stack([r, np.full(t.size, 0.1), np.full(t.size, 0.05)]),
                       [40.0, 1e-3, 1e-3])
    track = still_track(t)
    rows = np.arange(t.size)
    _, nis, _ = score_rows_left_out(batch, rows, track, rows)
    assert 21.1 < nis[10] < 30.6 and 21.1 < nis[12] < 30.6 and nis[11] > 30.7
    lone = _isolated_outliers(track, batch, rows, np.ones(t.size, bool), rows)
    np.testing.assert_array_equal(np.flatnonzero(lone), [5])


def test_a_further_return_of_one_object_is_no_plot_of_another() -> None:
    """``further_returns``: a lidar gives several returns of a hull a frame, and each object
    takes one plot a frame, so the boat's second return, inside the ship's wide gate, went
    to the ship. A plot is left to no object where another object holding a plot of that
    frame explains it better; where none does, or the other object holds no plot of the
    frame, it stays."""
    from rangeproc.tracking.reassociation import further_returns

    inf = np.inf
    # frame 0: boat (0) holds plot 0, ship (1) holds plot 1, the boat's second return
    # frame 1: ship holds plot 2, which the boat explains better but holds nothing there
    # frame 2: ship holds plot 3 (its own), boat holds plot 4
    # frame 3: ship keeps plot 5, ungated by itself, which the boat gates
    llr = np.array([[12.0, 3.0], [9.0, 4.0], [8.0, 5.0], [-inf, 7.0], [11.0, -inf],
                    [6.0, -inf], [2.0, 1.0]])
    owner = np.array([0, 1, 1, 1, 0, 1, 0])
    frame = np.array([0, 0, 1, 2, 2, 3, 3])
    np.testing.assert_array_equal(further_returns(owner, llr, frame),
                                  [0, -1, 1, 1, 0, -1, 0])
