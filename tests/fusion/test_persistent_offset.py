"""The returns' offset from the track that persists from scan to scan: a hull point that
wanders slowly over the hull is found (its second moment, along and across the heading), the
white noise of a point target is not (the negative control), and the reference spread takes
the largest of its estimates."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.fusion.extent import Extent
from rangeproc.fusion.persistent_offset import MIN_PAIRS, lag_one_offset
from rangeproc.fusion.reference_point import reference_extent

PERIOD = 2.0        # s: the radar's scan
SPEED = 3.0         # m/s: a boat heading north-east


def _scans(seed: int, n: int, along: float, across: float, noise: float,
           tau: float = 60.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One plot a scan of a boat heading 45 deg: its offset from the track a Gauss-Markov
    process of time constant ``tau`` s with 1-sigma ``along``/``across`` m (the point of the
    hull the radar sees, wandering with the aspect) plus white ``noise`` m per axis, the scan
    missed now and then (detection probability 0.9). Returns times (M,), offsets (M, 2),
    velocities (M, 2)."""
    g = np.random.default_rng(seed)
    t = np.arange(n) * PERIOD
    rho = math.exp(-PERIOD / tau)
    o = np.zeros((n, 2))
    o[0] = g.normal(0.0, 1.0, 2)
    for k in range(1, n):
        o[k] = rho * o[k - 1] + math.sqrt(1 - rho**2) * g.normal(0.0, 1.0, 2)
    u = np.array([1.0, 1.0]) / math.sqrt(2.0)
    w = np.array([-u[1], u[0]])
    d = (along * o[:, :1]) * u + (across * o[:, 1:]) * w + g.normal(0.0, noise, (n, 2))
    seen = g.random(n) < 0.9
    vel = np.tile(SPEED * u, (n, 1))
    return t[seen], d[seen], vel[seen]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_hull_point_that_wanders_slowly_is_found(seed):
    # 600 scans (20 min); 8 m along and 2 m across the heading under 4 m of radar noise
    e = lag_one_offset(*_scans(seed, 600, along=8.0, across=2.0, noise=4.0))
    assert math.sqrt(e.along) == pytest.approx(8.0, rel=0.35)
    assert math.sqrt(e.across) < 4.0
    assert e.along > 4.0 * e.across


@pytest.mark.parametrize("seed", range(1, 11))
def test_white_noise_about_the_track_gives_nothing(seed):
    # negative control: a point target, its offsets the radar's white noise (4 m, twice the
    # hull above): nothing persists from one scan to the next
    assert lag_one_offset(*_scans(seed, 600, along=0.0, across=0.0, noise=4.0)) == Extent()


def test_too_few_scans_give_nothing():
    t, d, v = _scans(4, MIN_PAIRS, along=8.0, across=8.0, noise=0.1)
    assert lag_one_offset(t, d, v) == Extent()


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_same_offsets_in_random_order_give_nothing(seed):
    # negative control: the hull offsets above about their mean (a mean offset persists, and
    # is found), shuffled in time: the same spread (8 m, more than the noise), but nothing
    # persists from one scan to the next
    t, d, v = _scans(seed, 600, along=8.0, across=2.0, noise=4.0)
    d = (d - d.mean(axis=0))[np.random.default_rng(seed).permutation(t.size)]
    assert lag_one_offset(t, d, v) == Extent()


def test_slow_scans_count_on_both_axes():
    # below 1 m/s there is no heading: each axis gets half of the persistent trace
    t, d, v = _scans(6, 600, along=6.0, across=6.0, noise=1.0)
    e = lag_one_offset(t, d, 0.1 * v)
    assert e.along == pytest.approx(e.across)
    assert math.sqrt(e.along) == pytest.approx(6.0, rel=0.35)


def test_the_reference_spread_takes_the_largest_estimate():
    got = reference_extent(4.0, Extent(along=9.0, across=1.0), Extent(along=2.0, across=16.0))
    assert got == Extent(along=9.0, across=16.0)
    assert reference_extent(4.0, Extent()) == Extent(along=4.0, across=4.0)


def test_rows_far_outside_their_stated_noise_are_left_out():
    # a stretch where the track has left its rows (km off): not the hull; the stated noise's
    # 99.9 % keeps a hull's offsets of a few sigma
    from rangeproc.fusion.persistent_offset import CHI2_2_999, stated_m2
    los = np.tile([0.0, 1.0], (3, 1))
    d = np.array([[4.0, 3.0], [0.0, 2000.0], [30.0, 0.0]])
    m2 = stated_m2(d, los, np.full(3, 100.0), np.full(3, 5.0), np.full(3, 0.05))
    assert m2 == pytest.approx([(3 / 5) ** 2 + (4 / 5) ** 2, (2000 / 5) ** 2, (30 / 5) ** 2])
    assert list(m2 <= CHI2_2_999) == [True, False, False]
