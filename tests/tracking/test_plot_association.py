"""Plot-by-plot association with finished objects: each plot goes to the object it fits best
within the gate, an object takes at most one plot per scan, clutter stays out."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.assemble import PLANE_ELEVATION_SIGMA
from rangeproc.tracking.plot_association import (
    azimuth_sector,
    clutter_floor,
    extend_objects,
    plot_owners,
    reassign_members,
)
from rangeproc.tracking.score import ObjectTrack

SIG = np.array([30.0, 2e-3, 2e-3])          # range m, azimuth and elevation rad


def _line(p0, v, t: np.ndarray) -> np.ndarray:
    return np.asarray(p0, float) + np.outer(t, v)


def _track(p0, v, t: np.ndarray, sigma: float) -> ObjectTrack:
    x = np.zeros((t.size, 9))
    x[:, :3] = _line(p0, v, t)
    x[:, 3:6] = v
    P = np.broadcast_to(np.diag([sigma**2] * 3 + [1.0] * 3 + [0.1] * 3), (t.size, 9, 9)).copy()
    return ObjectTrack(t, x, P, np.full(t.size, 1.0))


def _rae(p: np.ndarray) -> np.ndarray:
    r = np.linalg.norm(p, axis=1)
    return np.column_stack([r, np.mod(np.arctan2(p[:, 0], p[:, 1]), 2 * np.pi),
                            np.arcsin(p[:, 2] / r)])


def test_plots_go_to_the_object_they_fit_one_per_scan(plot_batch) -> None:
    rng = np.random.default_rng(4)
    period = 4.0
    scans = np.arange(20)
    ta = scans * period + 0.10                         # the beam passes A, then B just after
    tb = scans * period + 0.11
    a = _line((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), ta)
    b = _line((20_000.0, 20_300.0, 3_000.0), (-150.0, 0.0, 0.0), tb)   # 300 m apart
    ghost = _line((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), ta + 0.001) + 20.0
    tc = scans * period + 2.0
    clutter = rng.uniform(-40_000, 40_000, (scans.size, 3))
    clutter[:, 2] = rng.uniform(500, 5_000, scans.size)
    t = np.concatenate([ta, tb, ta + 0.001, tc])
    truth = np.concatenate([np.zeros(scans.size), np.ones(scans.size), np.full(scans.size, 2),
                            np.full(scans.size, -1)]).astype(int)
    p = np.vstack([a, b, ghost, clutter])
    order = np.argsort(t, kind="stable")
    t, p, truth = t[order], p[order], truth[order]
    rae = _rae(p) + rng.normal(size=(t.size, 3)) * SIG * 0.3
    grid = np.arange(-1.0, 80.0, 0.1)
    tracks = [_track((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), grid, 3.0),
              _track((20_000.0, 20_300.0, 3_000.0), (-150.0, 0.0, 0.0), grid, 3.0)]
    scan = np.floor(t / period).astype(np.int64)
    owner, gated = plot_owners(plot_batch(t, rae, SIG), np.arange(t.size), tracks, scan)
    assert not gated[truth == -1].any()
    assert (owner[truth == 0] == 0).mean() >= 0.95       # A's plots to A (the ghost echo
    assert (owner[truth == 1] == 1).all()                # 20 m off A loses to A's own plot)
    assert (owner[truth == -1] == -1).all()              # clutter gates into nothing
    for k in np.unique(scan):                            # at most one plot per object and scan
        for j in (0, 1):
            assert ((scan == k) & (owner == j)).sum() <= 1
    # an object that does not exist yet takes nothing
    late = [_track((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), grid[grid > 40], 3.0)]
    owner, _ = plot_owners(plot_batch(t, rae, SIG), np.arange(t.size), late, scan)
    assert (owner[t < 38.0] == -1).all()


def test_reassign_members_moves_only_that_sensors_plots() -> None:
    members = {"A": [(0, np.array([1, 2, 3])), (1, np.array([7, 8]))], "B": [(0, np.array([4]))]}
    out = reassign_members(members, 0, np.array([2, 3, 4]), np.array([1, -1, 0]), ["A", "B"])
    got = {k: [(i, sel.tolist()) for i, sel in v] for k, v in out.items()}
    assert got == {"A": [(0, [1]), (1, [7, 8]), (0, [4])], "B": [(0, [2])]}


def test_orphan_plots_before_an_objects_span_join_it_while_they_reach_it(plot_batch) -> None:
    """``extend_objects``: A's track starts at 40 s (another sensor's), its plots from 0 s
    were orphaned; they join A as one run reaching its span. B's orphans stop 30 s before
    B's span (a gap of 7 revisits): they stay orphans. Clutter stays out; plots other
    objects own are not touched."""
    rng = np.random.default_rng(7)
    period = 4.0
    scans = np.arange(20)
    ta = scans * period + 0.10
    a = _line((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), ta)
    b_scans = scans[:3]
    tb = b_scans * period + 1.0
    b = _line((-20_000.0, 10_000.0, 3_000.0), (100.0, 50.0, 0.0), tb)
    tc = scans * period + 2.0
    clutter = rng.uniform(-40_000, 40_000, (scans.size, 3))
    clutter[:, 2] = rng.uniform(500, 5_000, scans.size)
    t = np.concatenate([ta, tb, tc])
    truth = np.concatenate([np.zeros(ta.size), np.ones(tb.size), np.full(tc.size, -1)])
    p = np.vstack([a, b, clutter])
    order = np.argsort(t, kind="stable")
    t, p, truth = t[order], p[order], truth[order].astype(int)
    rae = _rae(p) + rng.normal(size=(t.size, 3)) * SIG
    late = np.arange(40.0, 80.0, 0.1)
    tracks = [_track((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), late, 3.0),
              _track((-20_000.0, 10_000.0, 3_000.0), (100.0, 50.0, 0.0), late, 3.0)]
    scan = np.floor(t / period).astype(np.int64)
    owner = np.where((truth == 0) & (t > 40.0), 0, -1)          # A's own plots in its span
    owner[np.flatnonzero(truth == -1)[-1]] = 1                  # a plot B already holds
    orphan = truth >= 0
    out = extend_objects(plot_batch(t, rae, SIG), np.arange(t.size), tracks, scan, owner,
                         orphan | (truth == -1))
    assert (out[(truth == 0)] == 0).all()                  # A's orphans joined A
    assert (out[truth == 1] == -1).all()                   # B's never reach B's span
    assert (out[truth == -1][:-1] == -1).all()             # clutter stays out
    assert out[np.flatnonzero(truth == -1)[-1]] == 1       # B's plot stays B's


@pytest.mark.parametrize("blanks", [False, True])
def test_an_object_that_hardly_knows_where_it_is_takes_no_clutter(plot_batch, blanks) -> None:
    """``clutter_floor``: an object with a 30 km sigma gates every plot, and without the
    floor takes the best clutter plot of every scan; with it, a plot must be more likely
    the object's than clutter (the sensor's clutter density), and A keeps its own plots.
    With ``blanks`` the editor blanked one clutter plot's azimuth and another's range: a
    blank spans nothing (it made the floor NaN, which no llr reaches, and every plot of the
    sensor then went to no object). A 2-D radar's plots (all at the assumed elevation 0)
    have no floor."""
    rng = np.random.default_rng(11)
    period = 4.0
    scans = np.arange(30)
    ta = scans * period + 0.10
    a = _line((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), ta)
    n_clutter = 5
    tc = np.repeat(scans * period, n_clutter) + rng.uniform(0.2, 3.8, scans.size * n_clutter)
    clutter = np.column_stack([rng.uniform(-40_000, 40_000, (tc.size, 2)),
                               rng.uniform(500, 5_000, tc.size)])
    t = np.concatenate([ta, tc])
    truth = np.concatenate([np.zeros(ta.size), np.full(tc.size, -1)]).astype(int)
    p = np.vstack([a, clutter])
    order = np.argsort(t, kind="stable")
    t, p, truth = t[order], p[order], truth[order]
    rae = _rae(p) + rng.normal(size=(t.size, 3)) * SIG
    if blanks:
        rae[np.flatnonzero(truth == -1)[3], 1] = np.nan
        rae[np.flatnonzero(truth == -1)[7], 0] = np.nan
    grid = np.arange(-1.0, 125.0, 0.1)
    tracks = [_track((20_000.0, 20_000.0, 3_000.0), (-150.0, 0.0, 0.0), grid, 3.0),
              _track((-10_000.0, 5_000.0, 3_000.0), (0.0, 0.0, 0.0), grid, 30_000.0)]
    scan = np.floor(t / period).astype(np.int64)
    batch = plot_batch(t, rae, SIG)
    plots = np.arange(t.size)
    without, _ = plot_owners(batch, plots, tracks, scan)
    assert (without == 1).sum() >= scans.size // 2          # the vague object takes clutter
    floor = clutter_floor(batch, plots, scan, int((truth == -1).sum()))
    assert np.isfinite(floor).all()
    owner, _ = plot_owners(batch, plots, tracks, scan, floor=floor)
    assert (owner == 1).sum() == 0
    assert (owner[truth == 0] == 0).all()
    flat = rae.copy()
    flat[:, 2] = 0.0
    two_d = plot_batch(t, flat, np.array([SIG[0], SIG[1], PLANE_ELEVATION_SIGMA]))
    assert np.isneginf(clutter_floor(two_d, plots, scan, int((truth == -1).sum()))).all()


def test_the_azimuth_sector_leaves_blanks_out() -> None:
    assert azimuth_sector(np.array([0.1, np.nan, 0.3])) == pytest.approx(0.2)
    assert azimuth_sector(np.array([np.nan])) == pytest.approx(2 * np.pi)
