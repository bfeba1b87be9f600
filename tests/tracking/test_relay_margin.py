"""A relayed segment (scored across objects' gaps, ``tracking.links.score_links`` with
``relay``) links only to an object that explains it decisively better than every other."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import SensorRows, empty_rows
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.models.measurement import CARTESIAN
from rangeproc.tracking.links import score_links
from rangeproc.tracking.objects import Objects, Segment
from rangeproc.tracking.score import ObjectTrack

SIGMA_M = 3.0


def _track(p0: tuple[float, float], v: tuple[float, float], t: np.ndarray) -> ObjectTrack:
    """A trajectory at constant velocity v (m/s) from p0 (m) at t[0], known to 1 m, 0.1 m/s."""
    x = np.zeros((t.size, 9))
    x[:, 0] = p0[0] + v[0] * (t - t[0])
    x[:, 1] = p0[1] + v[1] * (t - t[0])
    x[:, 3], x[:, 4] = v
    P = np.tile(np.diag([1.0] * 3 + [0.01] * 3 + [0.01] * 3), (t.size, 1, 1))
    return ObjectTrack(t, x, P, np.full(t.size, 0.2))


def _links(others: dict[str, ObjectTrack]) -> dict[tuple[int, int], float]:
    """Links of a 6-row segment at (75, 5) m, 25-27.5 s, scored in relay mode against
    ``others`` (which all end at 20 s)."""
    t = np.arange(25.0, 27.6, 0.5)
    rows = SensorRows(t=t, source_row=np.arange(t.size), station=np.full(t.size, -1),
                      track=np.full(t.size, -1), **empty_rows(t.size, CARTESIAN))
    rng = np.random.default_rng(1)
    rows.z[:, :3] = np.array([75.0, 5.0, 0.0]) + rng.normal(size=(t.size, 3)) * SIGMA_M
    rows.sigma[:, :3] = SIGMA_M
    objects = Objects({0: rows}, ("L1",), EstimatorSettings(), {})
    for name, track in others.items():
        objects.members[name] = []
        objects.adopt(name, track)
    seg = Segment(0, 0, np.arange(t.size), -1, float(t[0]), float(t[-1]), True)
    counter = iter(range(1, 100))
    _, links = score_links(objects, [seg], list(others), lambda: next(counter), {},
                           relay=True)
    return links


def test_a_relay_that_two_objects_explain_alike_joins_neither() -> None:
    t = np.arange(0.0, 20.01, 0.5)
    moving = _track((0.0, 0.0), (3.0, 0.0), t)            # at (75, 0) by 25 s
    still = _track((75.0, 10.0), (0.0, 0.0), t)            # at (75, 10) throughout
    alone = _links({"A": moving})
    assert list(alone) == [(0, 0)] and alone[(0, 0)] > 0.0  # it fits the moving one alone
    assert _links({"A": moving, "B": still}) == {}          # and the still one as well
    far = _track((75.0, 400.0), (0.0, 0.0), t)
    assert list(_links({"A": moving, "B": far})) == [(0, 0)]  # one far away: decisive
