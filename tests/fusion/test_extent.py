"""The hull's spread fitted from the plots' offsets about the track: recovered for a hull seen
from turning aspects, bounded (not 0) for a hull the rows cannot show, and for a point target
whose spread is the sensor's noise a bound below that noise that shrinks with the rows."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.fusion.extent import (Extent, extent_covariance, fit_extent, held_heading,
                                     lever_offset)

DEG = math.pi / 180.0


def _offsets(seed: int, length: float, beam: float, n: int = 400, sigma_r: float = 1.5,
             sigma_a: float = 0.5 * DEG, rng_m: float = 120.0
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A boat circling in front of a sensor: one return per row drawn uniformly over its hull
    (length x beam along/across its heading) plus range and azimuth noise about the line of
    sight. Returns offsets (n, 2), lines of sight (n, 2), ranges (n,), velocities (n, 2)."""
    g = np.random.default_rng(seed)
    t = np.linspace(0.0, 4 * math.pi, n)
    heading = t + 0.3 * np.sin(3 * t)                      # turning against the line of sight
    vel = 3.0 * np.c_[np.sin(heading), np.cos(heading)]
    bearing = 0.4 * np.sin(0.7 * t)
    los = np.c_[np.sin(bearing), np.cos(bearing)]
    r = rng_m + 20.0 * np.cos(t)
    u = vel / 3.0
    w = np.c_[-u[:, 1], u[:, 0]]
    hull = (g.uniform(-0.5, 0.5, n) * length)[:, None] * u \
        + (g.uniform(-0.5, 0.5, n) * beam)[:, None] * w
    across_los = np.c_[-los[:, 1], los[:, 0]]
    noise = (g.normal(0, sigma_r, n)[:, None] * los
             + (r * g.normal(0, sigma_a, n))[:, None] * across_los)
    return hull + noise, los, r, vel


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_hulls_spread_is_recovered_along_and_across(seed):
    d, los, r, vel = _offsets(seed, length=24.0, beam=7.0)
    e = fit_extent(d, los, r, vel)
    assert math.sqrt(e.along) == pytest.approx(24.0 / math.sqrt(12), rel=0.2)
    assert math.sqrt(e.across) == pytest.approx(7.0 / math.sqrt(12), rel=0.35)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_point_targets_bound_lies_below_its_noise_and_shrinks(seed):
    # the same noise without a hull (4 m in range, 4.2 m across at 120 m, nearly isotropic:
    # the hardest to tell from a hull): what the rows cannot exclude stays below the noise's
    # variance and shrinks with the rows, about as 1 / sqrt(rows)
    few = fit_extent(*_offsets(seed, length=0.0, beam=0.0, sigma_r=4.0, sigma_a=2.0 * DEG))
    many = fit_extent(*_offsets(seed, length=0.0, beam=0.0, n=6400, sigma_r=4.0,
                                sigma_a=2.0 * DEG))
    assert 0.0 < few.along < 16.0 and 0.0 < few.across < 16.0
    assert many.along < 0.35 * few.along and many.across < 0.35 * few.across


def test_a_hull_the_rows_cannot_show_is_bounded_not_zero():
    # 45 rows of a 30 m ship with noise of its hull's size (3 m, 2 deg at 200 m): about half
    # such draws do not show the hull at three sigma; its bound along the heading must still
    # reach its variance (L^2 / 12) where a hull of 0 would leave the reference point outside
    true_along = 30.0**2 / 12.0
    along = [fit_extent(*_offsets(seed, length=30.0, beam=7.0, n=45, sigma_r=3.0,
                                  sigma_a=2.0 * DEG, rng_m=200.0)).along
             for seed in range(1, 21)]
    assert sum(a >= 0.8 * true_along for a in along) >= 19, np.round(along, 1)


def test_a_spread_counted_as_noise_would_miss_the_hull():
    # the fit must give the hull, not the plots' whole spread and not nothing: a sigma made
    # of the noise alone (the track's) leaves the hull's offsets outside 3 sigma
    d, los, r, vel = _offsets(4, length=30.0, beam=8.0, sigma_r=0.2, sigma_a=0.05 * DEG)
    e = fit_extent(d, los, r, vel)
    C = extent_covariance(e, vel)
    u = vel / np.hypot(vel[:, 0], vel[:, 1])[:, None]
    along = (d * u).sum(axis=1)
    assert np.mean(np.abs(along) <= 3 * np.sqrt(C[:, 0, 0] + C[:, 1, 1])) > 0.99
    assert np.mean(np.abs(along) <= 3 * 0.2) < 0.2


def test_too_few_rows_give_their_whole_spread():
    # no fit from 10 rows: the hull is bounded by the rows' whole second moment along and
    # across the heading about the track (noise and hull together), not taken as 0
    d, los, r, vel = _offsets(1, length=24.0, beam=7.0, n=10)
    u = vel / np.hypot(vel[:, 0], vel[:, 1])[:, None]
    w = np.c_[-u[:, 1], u[:, 0]]
    e = fit_extent(d, los, r, vel)
    assert e.along == pytest.approx(np.mean(np.sum(d * u, axis=1) ** 2))
    assert e.across == pytest.approx(np.mean(np.sum(d * w, axis=1) ** 2))


def test_the_extent_turns_with_the_heading():
    e = Extent(along=9.0, across=1.0)
    C = extent_covariance(e, np.array([[0.0, 5.0], [5.0, 0.0], [3.0, 3.0], [0.1, 0.0]]))
    np.testing.assert_allclose(C[0], [[1.0, 0.0], [0.0, 9.0]])      # heading north
    np.testing.assert_allclose(C[1], [[9.0, 0.0], [0.0, 1.0]])      # heading east
    np.testing.assert_allclose(C[2], [[5.0, 4.0], [4.0, 5.0]])      # north-east
    np.testing.assert_allclose(C[3], [[5.0, 0.0], [0.0, 5.0]])      # too slow: no heading


def test_a_lever_arm_turns_with_the_heading():
    heading = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2])  # north, east, south, west
    off = lever_offset(heading, (2.0, 1.0, -0.5))                   # 2 m ahead, 1 m starboard
    np.testing.assert_allclose(off, [[1.0, 2.0, 0.5], [2.0, -1.0, 0.5],
                                     [-1.0, -2.0, 0.5], [-2.0, 1.0, 0.5]], atol=1e-12)


def test_a_slow_epoch_keeps_the_nearest_heading():
    vel = np.array([[0.0, 0.1], [0.0, 3.0], [0.2, 0.0], [0.1, 0.1], [3.0, 0.0], [0.0, 0.0]])
    np.testing.assert_allclose(held_heading(vel),
                               [0.0, 0.0, 0.0, math.pi / 2, math.pi / 2, math.pi / 2])
    assert np.isnan(held_heading(np.zeros((3, 2)))).all()          # never moving: unknown


def test_offsets_on_one_line_leave_the_fit_finite():
    # every offset (kilometres) along the line of sight, the heading along it: the fitted
    # covariance of each row has rank one and the fit must still return (a harbour run crashed)
    g = np.random.default_rng(5)
    n = 200
    los = np.tile([0.6, 0.8], (n, 1))
    d = g.normal(0.0, 5000.0, n)[:, None] * los              # km: rows of several things
    e = fit_extent(d, los, np.full(n, 100.0), 4.0 * los)
    assert np.isfinite(e.along) and np.isfinite(e.across)
