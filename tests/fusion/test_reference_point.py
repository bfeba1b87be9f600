"""The reference point of an object measured by plots: the part of a radar's stated sigma
(calibrated against the reference) that the residuals about the track do not show."""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.reference_point import reference_variance
from rangeproc.models.measurement import CARTESIAN, SPHERICAL

DEG = math.pi / 180.0
STATED = np.array([[2.0, 2.0 * DEG, 2.0 * DEG],       # 0: a lidar of plots
                   [5.0, 1.0 * DEG, 1.0 * DEG],       # 1: a radar of plots
                   [np.nan, 1.0 * DEG, 1.0 * DEG],    # 2: a camera (angles only)
                   [3.0, 3.0, 3.0]])                  # 3: a GPS (e, n, u)
RADAR = np.array([True, True, False, False])


def _batch(sensor: np.ndarray, model: np.ndarray, track: np.ndarray,
           rng: float = 100.0) -> MeasurementBatch:
    n = sensor.size
    z = np.full((n, 6), np.nan)
    z[:, 0] = np.where(model == SPHERICAL, rng, 1.0)
    z[:, 1] = 0.3
    return MeasurementBatch(np.arange(n) * 0.1, model, z, np.ones((n, 6)), np.zeros((n, 3)),
                            np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), sensor,
                            np.arange(n), np.full(n, -1), track, ("L", "R", "EO", "GPS"))


def _plots(*sensors: int) -> MeasurementBatch:
    s = np.repeat(np.asarray(sensors), 10)
    return _batch(s, np.full(s.size, SPHERICAL), np.full(s.size, -1))


def test_the_stated_spread_the_track_absorbs_is_the_reference_points():
    noise = {(0, 0): 0.5, (0, 1): 1.0 * DEG}
    want = 0.5 * ((2.0**2 - 0.5**2) + 100.0**2 * ((2 * DEG) ** 2 - DEG**2))
    assert reference_variance(_plots(0), noise, STATED, RADAR) == pytest.approx(want)
    # the largest of two radars' estimates; a radar whose noise exceeds its stated sigma by
    # less than its rows' sampling error says nothing of it (0), and a camera is no radar
    noise.update({(1, 0): 6.0, (1, 1): 1.2 * DEG})       # ratios 1.44, 1.44 < 1 + 3 sqrt(0.2)
    assert reference_variance(_plots(0, 1, 2), noise, STATED, RADAR) == pytest.approx(want)
    assert reference_variance(_plots(1), noise, STATED, RADAR) == 0.0


def test_a_spread_beyond_the_stated_sigma_is_the_reference_points_too():
    # a radar whose rows spread about the track far more than stated (a ship's returns along
    # its hull, 3 times the stated azimuth sigma): the excess counts, where it is significant
    noise = {(1, 0): 5.0, (1, 1): 3.0 * DEG}
    want = 0.5 * 100.0**2 * ((3 * DEG) ** 2 - DEG**2)
    assert reference_variance(_plots(1), noise, STATED, RADAR) == pytest.approx(want)
    noise = {(1, 0): 5.0, (1, 1): 1.5 * DEG}              # ratio 2.25 < 2.34 with 10 rows
    assert reference_variance(_plots(1), noise, STATED, RADAR) == 0.0


def test_no_reference_term_where_a_point_is_measured():
    noise = {(0, 0): 0.5, (0, 1): 1.0 * DEG}
    gps = _batch(np.array([0] * 10 + [3] * 10),
                 np.array([SPHERICAL] * 10 + [CARTESIAN] * 10), np.full(20, -1))
    assert reference_variance(gps, noise, STATED, RADAR) == 0.0          # a GPS: its antenna
    tracked = _batch(np.zeros(10, np.int64), np.full(10, SPHERICAL), np.full(10, 3))
    assert reference_variance(tracked, noise, STATED, RADAR) == 0.0      # a tracking radar
    assert reference_variance(_plots(0), {}, STATED, RADAR) == 0.0       # no noise estimate
    assert reference_variance(_plots(2), noise, STATED, RADAR) == 0.0    # angles only
