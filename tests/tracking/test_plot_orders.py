"""Plots in any time order: rotating, framed, phased-array revisits, a feed merged from two
radars; and a tracking instrument without track numbers told apart from a plot sensor."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.tracking.clutter_map import stationary_returns
from rangeproc.tracking.plot_tracker import plot_timing, track_plots
from rangeproc.tracking.plots import jump_share, plot_positions, several_objects

SIG = np.array([30.0, 2e-3, 2e-3])
STARTS = np.array([[10_000.0, 20_000.0, 3_000.0], [-15_000.0, 5_000.0, 6_000.0],
                   [12_000.0, -8_000.0, 1_500.0], [-20_000.0, -20_000.0, 9_000.0]])
VEL = np.array([[200.0, -150.0, 0.0], [250.0, 30.0, -5.0], [-180.0, 180.0, 10.0],
                [120.0, 220.0, 0.0]])
SPAN = 240.0


def truth_at(j: int, t: np.ndarray) -> np.ndarray:
    """(len(t), 3) range ENU position (m) of object j at times t (s): straight lines."""
    return STARTS[j] + VEL[j] * np.asarray(t, dtype=float)[:, None]


def polar(p: np.ndarray, site: np.ndarray) -> np.ndarray:
    """(N, 3) range, azimuth, elevation of positions p (N, 3) seen from site (3,)."""
    d = p - site
    r = np.linalg.norm(d, axis=1)
    return np.column_stack([r, np.mod(np.arctan2(d[:, 0], d[:, 1]), 2 * np.pi),
                            np.arcsin(d[:, 2] / r)])


def clutter(rng: np.random.Generator, t: np.ndarray, site: np.ndarray) -> np.ndarray:
    """(len(t), 3) clutter positions uniform in range 1-60 km, azimuth, elevation 0-0.3."""
    r, az, el = rng.uniform(1e3, 6e4, t.size), rng.uniform(0, 2 * np.pi, t.size), \
        rng.uniform(0, 0.3, t.size)
    return site + np.column_stack([r * np.cos(el) * np.sin(az), r * np.cos(el) * np.cos(az),
                                   r * np.sin(el)])


def rotating_times(rng: np.random.Generator, site: np.ndarray, period: float, phase: float,
                   pd: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """Times and object labels of a radar at ``site`` rotating once per ``period`` s."""
    t, lab = [], []
    for k in range(int(SPAN / period)):
        for j in range(len(STARTS)):
            if rng.random() > pd:
                continue
            t0 = phase + k * period
            az = polar(truth_at(j, [t0]), site)[0, 1]
            t.append(t0 + az / (2 * np.pi) * period)
            lab.append(j)
    return np.array(t), np.array(lab)


def plots_of(rng, t: np.ndarray, lab: np.ndarray, site: np.ndarray, n_clutter: int,
             period: float | None = None, phase: float = 0.0):
    """Noisy plots (sorted by time) of objects ``lab`` at ``t`` and ``n_clutter`` clutter
    plots, seen from ``site``: t, polar (N, 3), truth label (-1 clutter). Clutter comes at
    uniform times, or for a radar rotating once per ``period`` s when the beam passes it."""
    tc = rng.uniform(0.0, SPAN, n_clutter)
    pc = clutter(rng, tc, site)
    if period is not None:
        k = np.floor((tc - phase) / period)
        tc = phase + k * period + polar(pc, site)[:, 1] / (2 * np.pi) * period
    p = np.concatenate([np.stack([truth_at(j, [tt])[0] for tt, j in zip(t, lab)]), pc])
    t = np.concatenate([t, tc])
    lab = np.concatenate([lab, np.full(n_clutter, -1)])
    z = polar(p, site) + rng.normal(size=(t.size, 3)) * SIG
    order = np.argsort(t, kind="stable")
    return t[order], z[order], lab[order]


def positions(z: np.ndarray, site: np.ndarray = np.zeros(3)):
    n = z.shape[0]
    return plot_positions(z[:, 0], z[:, 1], z[:, 2], np.tile(SIG, (n, 1)),
                          np.tile(site, (n, 1)), np.tile(np.eye(3), (n, 1, 1)))


def phased_array(seed: int = 1, revisit: float = 2.0, n_clutter: int = 600):
    """Each object revisited every ``revisit`` s (own phase, +-10 % jitter, pd 0.9)."""
    rng = np.random.default_rng(seed)
    t, lab = [], []
    for j in range(len(STARTS)):
        tj = rng.uniform(0, revisit) + np.arange(0.0, SPAN, revisit)
        tj = tj + rng.uniform(-0.1, 0.1, tj.size) * revisit
        keep = (rng.random(tj.size) < 0.9) & (tj > 0) & (tj < SPAN)
        t.append(tj[keep])
        lab.append(np.full(keep.sum(), j))
    return plots_of(rng, np.concatenate(t), np.concatenate(lab), np.zeros(3), n_clutter)


def merged_feed(seed: int = 1):
    """Two rotating radars (4 s at the origin, 5 s at 20 km east / 10 km south) merged into one
    feed whose plots are given from the origin (the feed's reference site)."""
    rng = np.random.default_rng(seed)
    other = np.array([20_000.0, -10_000.0, 0.0])
    ta, la = rotating_times(rng, np.zeros(3), 4.0, 0.3)
    tb, lb = rotating_times(rng, other, 5.0, 1.7)
    # the second radar's plots: its own polar noise, then given from the reference site
    ta, za, la = plots_of(rng, ta, la, np.zeros(3), 300, 4.0, 0.3)
    tb, zb, lb = plots_of(rng, tb, lb, other, 300, 5.0, 1.7)
    pb, _ = positions(zb, other)
    zb = polar(pb, np.zeros(3))
    t = np.concatenate([ta, tb])
    order = np.argsort(t, kind="stable")
    return t[order], np.concatenate([za, zb])[order], np.concatenate([la, lb])[order]


def rotating(seed: int = 1):
    rng = np.random.default_rng(seed)
    t, lab = rotating_times(rng, np.zeros(3), 4.0, 0.0)
    return plots_of(rng, t, lab, np.zeros(3), 1200, 4.0)


def framed(seed: int = 1):
    t, z, lab = rotating(seed)
    t = np.floor(t / 4.0) * 4.0
    order = np.argsort(t, kind="stable")
    return t[order], z[order], lab[order]


def _axes(n: int):
    return np.tile(SIG, (n, 1)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1))


FORMS = {"rotating": rotating, "framed": framed, "phased-array": phased_array,
         "merged-feed": merged_feed}


@pytest.mark.parametrize("form", list(FORMS))
def test_every_order_of_plots_is_taken_for_plots(form: str) -> None:
    t, z, _ = FORMS[form]()
    assert several_objects(t, z, *_axes(t.size)), form


@pytest.mark.parametrize("form", list(FORMS))
def test_every_order_of_plots_is_tracked_object_by_object(form: str) -> None:
    t, z, truth = FORMS[form]()
    p, R = positions(z)
    timing = plot_timing(t, z[:, 1], p, R)
    expected = {"rotating": "rotating", "framed": "framed", "phased-array": "free",
                "merged-feed": "free"}[form]
    assert timing.order == expected
    label = track_plots(t, p, R, timing.frame, timing.clock, stamp_sigma=timing.stamp_sigma)
    for j in range(len(STARTS)):
        mine = label[truth == j]
        main = np.bincount(mine[mine >= 0]).argmax()
        assert (mine == main).mean() >= 0.9, (form, j)     # one track holds the object
        assert (truth[label == main] == j).mean() >= 0.95, (form, j)   # and little else
    assert (label[truth == -1] >= 0).mean() < 0.05, form      # clutter stays clutter


def test_a_phased_array_revisit_is_estimated_from_its_tracks() -> None:
    for revisit in (1.0, 2.0, 6.0):
        t, z, _ = phased_array(seed=2, revisit=revisit, n_clutter=int(120 / revisit))
        p, R = positions(z)
        timing = plot_timing(t, z[:, 1], p, R)
        assert timing.order == "free"
        assert abs(timing.revisit - revisit) <= 0.2 * revisit, (revisit, timing.revisit)
        assert np.all(np.diff(timing.clock) >= 0)
        assert np.array_equal(timing.scan, np.floor(timing.clock).astype(np.int64))


def test_a_tracking_instrument_with_wild_points_is_one_track() -> None:
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 60.0, 0.05)
    z = polar(truth_at(0, t), np.zeros(3)) + rng.normal(size=(t.size, 3)) * SIG
    wild = rng.random(t.size) < 0.01
    z[wild, 0] += rng.choice([-1.0, 1.0], wild.sum()) * 3_000.0
    share = jump_share(t, z, *_axes(t.size))
    assert 0.005 < share < 0.05
    assert not several_objects(t, z, *_axes(t.size))


def test_rows_jumping_between_far_places_are_several_objects() -> None:
    rng = np.random.default_rng(6)
    t = np.sort(rng.uniform(0.0, 60.0, 600))       # irregular, no sweep, no frames
    obj = rng.integers(0, 3, t.size)
    p = np.stack([truth_at(j, [tt])[0] for tt, j in zip(t, obj)])
    z = polar(p, np.zeros(3)) + rng.normal(size=(t.size, 3)) * SIG
    assert jump_share(t, z, *_axes(t.size)) > 0.5
    assert several_objects(t, z, *_axes(t.size))


def test_angle_only_rows_jumping_between_objects_are_plots_one_line_of_sight_is_not() -> None:
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 60.0, 0.05)
    sig = np.array([np.nan, 1e-4, 1e-4])
    one = polar(truth_at(1, t), np.zeros(3)) + rng.normal(size=(t.size, 3)) * sig
    one[:, 0] = np.nan
    n = t.size
    axes = (np.tile(sig, (n, 1)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)))
    assert not several_objects(t, one, *axes)
    obj = rng.integers(0, 3, t.size)
    many = polar(np.stack([truth_at(j, [tt])[0] for tt, j in zip(t, obj)]), np.zeros(3))
    many[:, 0] = np.nan
    assert several_objects(t, many, *axes)
    many[:, 2] = np.nan                                        # bearings alone
    assert several_objects(t, many, *axes)


def test_a_fixed_reflector_is_reported_as_a_stationary_return_moving_objects_are_not() -> None:
    t, z, truth = rotating(seed=3)
    quay = np.array([5_000.0, -3_000.0, 50.0])               # a return in every scan
    tq = np.arange(0.0, SPAN, 4.0) + polar(quay[None], np.zeros(3))[0, 1] / (2 * np.pi) * 4.0
    zq = polar(np.tile(quay, (tq.size, 1)), np.zeros(3))
    zq = zq + np.random.default_rng(9).normal(size=zq.shape) * SIG
    t = np.concatenate([t, tq])
    order = np.argsort(t, kind="stable")
    t, z = t[order], np.vstack([z, zq])[order]
    p, R = positions(z)
    timing = plot_timing(t, z[:, 1], p, R)
    returns = stationary_returns(p, R, timing.scan, planar=False)
    assert len(returns) >= 1
    top = returns[0]
    assert np.hypot(top["e"] - quay[0], top["n"] - quay[1]) < 100.0
    assert top["share"] >= 0.5             # a cell boundary may split its plots
    # the moving objects pass through cells in a scan or two: none of them is stationary
    for r in returns:
        assert np.hypot(r["e"] - quay[0], r["n"] - quay[1]) < 300.0
