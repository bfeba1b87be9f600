"""Which times an object's own rows witness (``Objects.witnessed``): while associating, a row
elsewhere is no evidence for or against the object (``tracking.links._scored_llr``)."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import SensorRows, empty_rows
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.models.measurement import CARTESIAN
from rangeproc.tracking.objects import OBSERVED_GAP_SECONDS, Objects
from rangeproc.tracking.score import ObjectTrack


def rows_at(t: np.ndarray) -> SensorRows:
    return SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                      track=np.full(t.size, -1), **empty_rows(t.size, CARTESIAN))


def test_rows_in_a_gap_of_the_objects_data_are_not_witnessed() -> None:
    gps = rows_at(np.concatenate([np.arange(0.0, 20.0, 0.5), np.arange(40.0, 60.0, 0.5)]))
    radar = rows_at(np.arange(75.0, 95.0, 0.1))
    objects = Objects({0: gps, 1: radar}, ("G1", "R1"), EstimatorSettings(), {})
    objects.members["T1"] = [(0, np.arange(gps.t.size)), (1, np.arange(0, 50))]
    t_track = np.arange(0.0, 80.0, 0.1)
    objects.adopt("T1", ObjectTrack(t_track, np.zeros((t_track.size, 9)),
                                    np.tile(np.eye(9), (t_track.size, 1, 1)),
                                    np.ones(t_track.size)))
    gap = OBSERVED_GAP_SECONDS
    # members: GPS 0-19.5 s and 40-59.5 s, the radar's first 50 rows 75-79.9 s
    t = np.array([0.0, 19.5 + gap - 0.1, 19.5 + gap + 0.1, 30.0, 40.0 - gap + 0.1, 45.0,
                  59.5 + gap + 0.1, 75.0 - gap + 0.1, 79.9 + gap + 0.1])
    np.testing.assert_array_equal(objects.witnessed("T1", t),
                                  [True, True, False, False, True, True, False, True, False])
