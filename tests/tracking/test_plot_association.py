"""Plot-by-plot association with finished objects: each plot goes to the object it fits best
within the gate, an object takes at most one plot per scan, clutter stays out."""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plot_association import plot_owners, reassign_members
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
