"""The plot tracker's extended objects: a track's extent (covariance matching) stays near 0 for a
point target and finds a hull's spread; a hull's further returns in one scan start no track."""
from __future__ import annotations

import numpy as np
import pytest

import rangeproc.tracking.plot_tracker as pt
from rangeproc.tracking.clutter_map import neighbour_share
from rangeproc.tracking.track_extent import HullSpread

def _mean_extent(update, spread: float, seed: int = 3) -> float:
    """Mean extent (m^2) a track reaches over 900 plots whose innovations scatter ``spread``
    m per axis about a prediction of covariance 4 m^2 per axis (planar)."""
    rng = np.random.default_rng(seed)
    c, S = np.array([1.0]), np.eye(3)[None] * 4.0
    e, seen = 0.0, []
    for n in range(1000):
        S_n = S + np.diag([max(e, 0.0)] * 2 + [0.0])[None]
        d = rng.normal(0.0, spread, (1, 3)) * [1, 1, 0]
        e = update(e, n, c, d, S_n, 2)
        seen.append(max(e, 0.0))
    return float(np.mean(seen[100:]))


def test_extent_update_stays_near_zero_for_a_point_target():
    """The extent's covariance matching: innovations of the stated noise give an extent near
    0 (the mean kept signed), wider ones their excess (25 - 4 = 21 m^2 per axis)."""
    assert _mean_extent(pt.extent_update, 2.0) < 0.8
    assert _mean_extent(pt.extent_update, 5.0) == pytest.approx(21.0, abs=2.5)

    # the negative control: each sample's excess clipped at 0 biases a point target's extent
    # up (it then takes the clutter a miss leaves in its wider gate)
    def clipped(extent, n, c, d, S, axes):
        dm = np.einsum("m,mi->i", c, d)[:axes]
        noise = float(np.einsum("m,mii->", c, S[:, :axes, :axes])) - axes * extent
        w = 1.0 / min(n + 1, pt.EXTENT_MEMORY)
        return (1.0 - w) * extent + w * max(0.0, (float(dm @ dm) - noise) / axes)
    assert _mean_extent(clipped, 2.0) > 1.1


def _scan_of_returns(extent: float):
    """One lidar scan: a confirmed track of ``extent`` (m^2) took plot 0, a tentative track
    took plot 1 (4 m along the hull), plot 2 (7 m off) no track took, plot 3 lies 60 m off.
    Returns what :func:`_other_returns` makes of it: (live tracks left, plots claimed)."""
    M = len(pt.MODEL_PSD)
    p = np.array([[0.0, 80.0, 0.0], [4.0, 80.0, 0.0], [-7.0, 80.0, 0.0], [60.0, 80.0, 0.0]])
    R = np.tile(np.diag([0.1**2, 0.1**2, 1.0]), (4, 1, 1))
    tracks = [pt._start_imm(p[i], R[i], 0.0, 0.0, i) for i in (0, 1)]
    tracks[0].confirmed, tracks[0].extent = True, extent
    tracks[0].rows, tracks[0].noise = list(range(pt.EXTENT_MEMORY)), 0.01  # a settled hull
    owner = np.array([0, 1, -1, -1])
    assert tracks[0].xs.shape == (M, 6)
    live, claimed = pt._other_returns(tracks, owner, owner >= 0, np.arange(4), p, R,
                                      float(pt.chi2_ppf(pt.GATE_PROBABILITY, 3)), True)
    return live, claimed


def test_further_returns_of_a_hull_start_no_track():
    live, claimed = _scan_of_returns(extent=25.0)          # a hull of about 17 m
    assert len(live) == 1 and live[0].confirmed            # the copy begun on plot 1 goes
    assert claimed.tolist() == [True, True, True, False]   # plot 3 is someone else's
    # the negative control: a point target (extent 0, noise 0.1 m) claims no neighbour
    live, claimed = _scan_of_returns(extent=0.0)
    assert len(live) == 2 and claimed.tolist() == [True, True, False, False]


def _hull_scans(returns: int, seed: int = 4):
    """A 20 m hull moving east at 8 m/s seen 10 times a second for 30 s by a sensor whose
    stated noise, 3 m, spans the hull (its residuals' spread against GNSS, planar): 1 to
    ``returns`` plots a scan along its side, and a clutter plot a scan over 1 km^2.
    (t, p, R, scan, truth): truth 0 the hull's plots, -1 clutter."""
    rng = np.random.default_rng(seed)
    return _hull_scene(rng, lambda k: [
        (np.array([0.8 * k + rng.uniform(-10.0, 10.0), 80.0 + rng.normal(0.0, 0.5), 0.0]), 0)
        for _ in range(rng.integers(1, returns + 1))])


def _hull_scene(rng: np.random.Generator, returns, scans: int = 300):
    """``scans`` scans 0.1 s apart; scan k's returns of the hulls are ``returns(k)``, a list
    of (position (3,) m, the hull's index), with a clutter plot a scan (Poisson mean 1) over
    1 km^2; stated noise 3 m, planar. (t, p, R, scan, truth): truth the hull's index, -1
    clutter."""
    t, p, scan, truth = [], [], [], []
    for k in range(scans):
        for pos, h in returns(k):
            p.append(pos)
            t.append(0.1 * k), scan.append(k), truth.append(h)
        for _ in range(rng.poisson(1)):
            p.append(rng.uniform([-500.0, -500.0, 0.0], [500.0, 500.0, 0.0]))
            t.append(0.1 * k), scan.append(k), truth.append(-1)
    n = len(t)
    return (np.array(t), np.array(p), np.tile(np.diag([9.0, 9.0, 1.0]), (n, 1, 1)),
            np.array(scan), np.array(truth))


def _hull_tracks(label: np.ndarray, truth: np.ndarray) -> int:
    """How many tracks hold at least 10 of the hull's plots."""
    held = label[(truth == 0) & (label >= 0)]
    return int((np.bincount(held) >= 10).sum()) if held.size else 0


def test_a_sensor_with_several_returns_gets_one_track_per_hull(monkeypatch):
    """A lidar's 1-6 returns of one hull a scan: the sensor is measured to give several
    returns (most plots have a neighbour within their noise) and the hull gets one track;
    one plot a scan, among the same clutter, gives no such evidence."""
    gate = float(pt.chi2_ppf(pt.GATE_PROBABILITY, 3))
    t, p, R, scan, truth = _hull_scans(6)
    assert neighbour_share(p, R, scan, gate, True) >= pt.SEVERAL_RETURNS_SHARE
    assert _hull_tracks(pt.track_plots(t, p, R, scan, planar=True), truth) == 1
    # the negative control: without the rule each return begins its own copy of the hull
    monkeypatch.setattr(pt, "SEVERAL_RETURNS_SHARE", 2.0)
    assert _hull_tracks(pt.track_plots(t, p, R, scan, planar=True), truth) >= 2
    t, p, R, scan, truth = _hull_scans(1)
    assert neighbour_share(p, R, scan, gate, True) < 0.2


def test_a_point_targets_extent_is_not_used():
    """A track whose signed extent mean is within 2 standard errors of 0 adds none to its
    plot noise; a hull's, well above, is used."""
    tr = pt._start_imm(np.zeros(3), np.eye(3), 0.0, 0.0, 0)
    tr.rows, tr.noise, tr.extent = list(range(10)), 4.0, 1.5       # se 4 * sqrt(0.1) = 1.3
    assert pt.extent_in_use(tr, 2) == 0.0
    tr.extent = 21.0
    assert pt.extent_in_use(tr, 2) == 21.0



def _twin_returns(hulls: tuple[float, ...], seed: int = 5):
    """Hulls 10 m long moving east at 3 m/s, each seen 10 times a second for 30 s as exactly
    two returns a scan anywhere along its side, stated noise 3.5 m east and 2.2 m north (a
    harbour lidar's residual spread against GNSS), south-west of the sensor at the east
    offsets ``hulls`` (m); a clutter plot a scan over 1 km^2. (t, p, R, scan, truth): truth
    the hull's index, -1 clutter."""
    rng = np.random.default_rng(seed)
    t, p, scan, truth = [], [], [], []
    for k in range(300):
        for h, east in enumerate(hulls):
            centre = np.array([east - 50.0 + 0.3 * k, -107.0, 0.0])
            for _ in range(2):
                p.append(centre + [rng.uniform(-5.0, 5.0), rng.normal(0.0, 0.5), 0.0])
                t.append(0.1 * k), scan.append(k), truth.append(h)
        p.append(rng.uniform([-500.0, -500.0, 0.0], [500.0, 500.0, 0.0]))
        t.append(0.1 * k), scan.append(k), truth.append(-1)
    n = len(t)
    return (np.array(t), np.array(p), np.tile(np.diag([3.5**2, 2.2**2, 1.0]), (n, 1, 1)),
            np.array(scan), np.array(truth))


def _copies(label: np.ndarray, truth: np.ndarray, hull: int) -> int:
    """How many tracks hold at least 10 of hull ``hull``'s plots."""
    held = label[(truth == hull) & (label >= 0)]
    return int((np.bincount(held) >= 10).sum()) if held.size else 0


def test_two_returns_of_one_hull_from_the_first_scan_start_one_track(monkeypatch):
    """Hulls that give two returns in every scan from the first: each gets one track, not
    two that each take one return a scan, are confirmed together and follow the one hull as
    two objects (eight seeded scenes of two hulls 60 m apart)."""
    def copies() -> list[int]:
        out = []
        for seed in range(8):
            t, p, R, scan, truth = _twin_returns((0.0, 60.0), seed)
            label = pt.track_plots(t, p, R, scan, planar=True)
            out += [_copies(label, truth, 0), _copies(label, truth, 1)]
        return out
    assert copies() == [1] * 16
    # the negative control: without the rule some hulls get two tracks (4 of 16)
    monkeypatch.setattr(pt, "_one_hull_each", lambda live, owner, taken, *a: taken)
    assert max(copies()) == 2


def test_hull_spread_measures_the_returns_along_a_hull():
    """A track's hull from its returns within each scan (``HullSpread``): 1-6 returns a scan
    uniform along a 30 m hull lying east, stated noise 3 m per axis (a lidar's residual
    spread against GNSS, far above its 0.5 m scatter across the hull): the hull's variance
    along it, 30^2 / 12 - 9 = 66 m^2, and none across (the stated noise exceeds the returns'
    scatter there); none before ``SPREAD_DOF``."""
    rng = np.random.default_rng(1)
    hull = HullSpread()
    R = np.tile(np.diag([9.0, 9.0]), (6, 1, 1))
    for k in range(300):
        n = int(rng.integers(1, 7))
        hull.add(np.c_[rng.uniform(-15.0, 15.0, n), rng.normal(0.0, 0.5, n)], R[:n])
        if k == 0:
            assert hull.extent() is None
    E = hull.extent()
    assert E[0, 0] == pytest.approx(66.0, rel=0.3)
    assert abs(E[0, 1]) < 5.0 and E[1, 1] < 1.0


def _long_hull(seed: int, half: float = 15.0):
    """A 30 m hull moving east at 3 m/s seen 10 times a second for 30 s, stated noise 3 m
    (planar): a return a scan from each end (the outer 40 % of each half: bow and stern give
    the strongest echoes) and 0-4 anywhere along it, so that its ends, 18-30 m apart, lie
    beyond the gate of their noise from the first scan; a clutter plot a scan over 1 km^2.
    (t, p, R, scan, truth): truth 0 the hull's plots, -1 clutter."""
    rng = np.random.default_rng(seed)

    def returns(k: int) -> list[tuple[np.ndarray, int]]:
        ends = [rng.uniform(0.6 * half, half), -rng.uniform(0.6 * half, half)]
        along = ends + list(rng.uniform(-half, half, rng.integers(0, 5)))
        return [(np.array([-40.0 + 0.3 * k + a, 100.0 + rng.normal(0.0, 0.5), 0.0]), 0)
                for a in along]
    return _hull_scene(rng, returns)


def test_a_hull_seen_at_both_ends_is_one_track(monkeypatch):
    """A 30 m hull whose bow and stern, beyond the gate of their noise, each begin a track:
    the returns between them, which no track takes, show the hull, and the two tracks are
    merged into one (eight seeded scenes: one track each)."""
    def copies() -> list[int]:
        out = []
        for seed in range(8):
            t, p, R, scan, truth = _long_hull(seed)
            out.append(_hull_tracks(pt.track_plots(t, p, R, scan, planar=True), truth))
        return out
    assert copies() == [1] * 8
    # the negative control: with the hull from each track's own innovations alone, the bow
    # and the stern keep a track each (8 of 8)
    monkeypatch.setattr(pt, "hull_tracks", lambda live, owner, *a: (live, owner))
    assert min(copies()) == 2


def _two_boats(seed: int, placement: str):
    """Two 12 m hulls 25 m apart (centre to centre), 2-4 returns a scan each, stated noise
    3 m, 10 scans a second for 40 s: ``"beside"`` side by side at the same speed, ``"line"``
    one behind the other at the same speed, ``"passing"`` on opposite courses 12 m apart.
    (t, p, R, scan, truth): truth the hull's index, -1 clutter."""
    rng = np.random.default_rng(seed)
    start, velocity = {"beside": ([[-40.0, 100.0], [-40.0, 125.0]], [3.0, 3.0]),
                       "line": ([[-60.0, 100.0], [-35.0, 100.0]], [3.0, 3.0]),
                       "passing": ([[-60.0, 100.0], [60.0, 112.0]], [3.0, -3.0])}[placement]
    def returns(k: int) -> list[tuple[np.ndarray, int]]:
        out = []
        for h in (0, 1):
            centre = np.array([start[h][0] + velocity[h] * 0.1 * k, start[h][1], 0.0])
            for a in rng.uniform(-6.0, 6.0, rng.integers(2, 5)):
                out.append((centre + [a, rng.normal(0.0, 0.5), 0.0], h))
        return out
    return _hull_scene(rng, returns, scans=400)


@pytest.mark.parametrize("placement", ["beside", "line", "passing"])
def test_two_boats_near_each_other_keep_a_track_each(placement):
    """Two boats 25 m apart (beside or behind each other) or passing 12 m apart: each keeps
    its own one track; the hull measured from the returns is not the pair's."""
    for seed in range(3):
        t, p, R, scan, truth = _two_boats(seed, placement)
        label = pt.track_plots(t, p, R, scan, planar=True)
        own = [np.flatnonzero(np.bincount(label[(truth == h) & (label >= 0)]) >= 10)
               for h in (0, 1)]
        assert [len(o) for o in own] == [1, 1] and own[0][0] != own[1][0]
