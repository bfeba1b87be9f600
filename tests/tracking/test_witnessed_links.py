"""While discovery grows an object, a segment that only meets it at an end (most of its rows
beyond the object's own, most of the object's rows beyond its span) does not link where a
segment that will start an object later explains the rows they share decisively better
(``tracking.links.score_links`` with ``rivals``): it would otherwise join on the evidence of
the overlap alone, before that object exists. It waits for that object."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import SensorRows, empty_rows
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.models.measurement import CARTESIAN
from rangeproc.tracking.links import Rival, score_links
from rangeproc.tracking.objects import Objects, Segment
from rangeproc.tracking.score import ObjectTrack

SIGMA_M = 3.0
SPEED = np.array([3.0, 1.0, 0.0])             # m/s, both objects' constant velocity
BESIDE = np.array([25.0, 0.0, 0.0])           # m, where object A moves beside B


def _positions(t: np.ndarray, offset: np.ndarray) -> np.ndarray:
    return t[:, None] * SPEED + offset


def _rows(t: np.ndarray, offset: np.ndarray, rng: np.random.Generator) -> SensorRows:
    rows = SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                      track=np.full(t.size, -1), **empty_rows(t.size, CARTESIAN))
    rows.z[:, :3] = _positions(t, offset) + rng.normal(size=(t.size, 3)) * SIGMA_M
    rows.sigma[:, :3] = SIGMA_M
    return rows


def _track(offset: np.ndarray, sigma_m: float) -> ObjectTrack:
    t = np.arange(0.0, 100.01, 0.1)
    x = np.zeros((t.size, 9))
    x[:, :3], x[:, 3:6] = _positions(t, offset), SPEED
    P = np.tile(np.diag([sigma_m ** 2] * 3 + [0.01] * 6), (t.size, 1, 1))
    return ObjectTrack(t, x, P, np.full(t.size, 0.2))


def _links(seg_span: tuple[float, float], rival_offset: np.ndarray | None
           ) -> dict[tuple[int, int], float]:
    """Links, while an object grows, of a segment of sensor 1 over ``seg_span`` (s) that
    follows B, against object A (its own rows, sensor 0, over 25-100 s, known to 20 m and
    25 m beside B); the rival B's quick trajectory at ``rival_offset`` (none: no rival)."""
    rng = np.random.default_rng(7)
    own = _rows(np.arange(25.0, 100.0, 0.5), BESIDE, rng)
    other = _rows(np.arange(seg_span[0], seg_span[1] + 0.01, 1.0), np.zeros(3), rng)
    objects = Objects({0: own, 1: other}, ("L1", "R1"), EstimatorSettings(), {})
    objects.members["A"] = [(0, np.arange(own.t.size))]
    objects.adopt("A", _track(BESIDE, 20.0))
    seg = Segment(0, 1, np.arange(other.t.size), -1, float(other.t[0]), float(other.t[-1]),
                  True)
    rivals = {} if rival_offset is None else {
        5: Rival(np.arange(27.0, 78.0, 0.5), _track(rival_offset, 1.0))}
    counter = iter(range(10, 100))
    return score_links(objects, [seg], ["A"], lambda: next(counter), {}, relay=False,
                       rivals=rivals)[1]


def test_a_segment_that_a_later_object_explains_better_waits_for_it() -> None:
    assert list(_links((0.0, 37.0), None)) == [(0, 0)]            # no rival: it joins A
    assert _links((0.0, 37.0), np.zeros(3)) == {}                 # B explains it: waits
    assert list(_links((0.0, 37.0), np.array([0.0, 400.0, 0.0]))) == [(0, 0)]  # B far off
    # a segment mostly where A is seen links to A whatever the rival
    assert list(_links((20.0, 37.0), np.zeros(3))) == [(0, 0)]
