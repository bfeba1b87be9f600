"""Which objects' quick trajectories are refined before the plots are re-associated
(``tracking.reassociation.doubtful``)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rangeproc.tracking.score import ObjectTrack
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
    x = np.zeros((t.size, 9))
    x[:, 0] = 10_000.0 * np.sin(0.1) * np.cos(0.05)
    x[:, 1] = 10_000.0 * np.cos(0.1) * np.cos(0.05)
    x[:, 2] = 10_000.0 * np.sin(0.05)
    track = ObjectTrack(t, x, np.tile(np.eye(9) * 100.0, (t.size, 1, 1)), np.ones(t.size))
    rows = np.arange(t.size)
    lone = _isolated_outliers(track, batch, rows, np.ones(t.size, bool), rows)
    np.testing.assert_array_equal(np.flatnonzero(lone), [5])
