"""The plot tracker's track score begins at the new-object density (tracking.initiation.
new_track_score): a narrower velocity bound for new tracks confines their gates but does not by
itself confirm clutter."""
from __future__ import annotations

import numpy as np
import pytest

import rangeproc.tracking.plot_tracker as pt
from rangeproc.tracking.initiation import INITIATION_SPEED, new_track_score

PERIOD = 2.5                    # s, the radar's scan


def _sea_clutter(seed: int):
    """40 scans of a planar scanning radar (plot sigma 5 m stated), clutter only: six patches
    of sea clutter (each a plot in 40 % of the scans, 30 m about its centre) among 6 plots a
    scan over 800 m x 800 m. (t, p, R, scan)."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-300.0, 300.0, (6, 2))
    rows = []
    for k in range(40):
        for c in centres:
            if rng.random() < 0.4:
                rows.append((k * PERIOD, c + rng.normal(0.0, 30.0, 2)))
        for _ in range(rng.poisson(6.0)):
            rows.append((k * PERIOD, rng.uniform(-400.0, 400.0, 2)))
    t = np.array([r[0] for r in rows])
    p = np.array([[*r[1], 0.0] for r in rows])
    R = np.tile(np.diag([25.0, 25.0, 1e4]), (t.size, 1, 1))
    return t, p, R, np.round(t / PERIOD).astype(np.int64)


def _clutter_tracks(speed: float) -> int:
    """Confirmed tracks of the forward tracker over seeds 0-9 of :func:`_sea_clutter` (all of
    them clutter), new tracks bounded at ``speed`` m/s."""
    n = 0
    for seed in range(10):
        t, p, R, scan = _sea_clutter(seed)
        label = pt._track_scans(t, p, R, scan, scan.astype(float), True, 0.0, False,
                                 np.full(t.size, speed))
        n += int(label.max()) + 1
    return n


def test_the_score_begins_at_the_new_object_density():
    assert new_track_score(INITIATION_SPEED, 2) == 0.0
    assert new_track_score(INITIATION_SPEED / 10.0, 2) == pytest.approx(-2.0 * np.log(10.0))
    assert new_track_score(INITIATION_SPEED / 10.0, 3) == pytest.approx(-3.0 * np.log(10.0))
    tr = pt._start_imm(np.zeros(3), np.eye(3), 0.0, 0.0, 0, 20.0, 2)
    assert tr.score == tr.best == pytest.approx(new_track_score(20.0, 2))


def test_a_narrow_velocity_bound_confirms_no_sea_clutter():
    # with the general bound, no clutter track is confirmed; with a harbour's 20 m/s neither
    assert _clutter_tracks(INITIATION_SPEED) == 0
    assert _clutter_tracks(20.0) == 0


def test_negative_control_a_score_begun_at_zero_confirms_clutter(monkeypatch):
    # the score begun at 0 whatever the bound (the rule before): the second plot's likelihood
    # under a 20 m/s prior is (1500 / 20)^2 times that under the general one, and the patches
    # of sea clutter are confirmed as tracks (7-8 over the ten seeds)
    monkeypatch.setattr(pt, "new_track_score", lambda speed, axes: 0.0)
    assert _clutter_tracks(INITIATION_SPEED) == 0
    assert _clutter_tracks(20.0) >= 4
