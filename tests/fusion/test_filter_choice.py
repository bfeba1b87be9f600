"""filter = "auto" (``fusion.filter_choice``): range rates alone get the EKF's passes and the
batch spline fit; everything else the EKF; a configured filter is kept."""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import SensorRows, merge
from rangeproc.fusion.filter_choice import EKF_SPLINE_FIT, choose_filter


def _rows(z: np.ndarray) -> SensorRows:
    n = len(z)
    return SensorRows(t=np.arange(n, dtype=float), model=np.ones(n, dtype=np.int64), z=z,
                      sigma=np.ones((n, 6)), s=np.zeros((n, 3)), sv=np.zeros((n, 3)),
                      Qr=np.tile(np.eye(3), (n, 1, 1)), source_row=np.arange(n),
                      station=np.zeros(n, dtype=np.int64), track=np.full(n, -1))


def test_auto_chooses_by_what_is_measured():
    rr = np.full((5, 6), np.nan)
    rr[:, 3] = 1.0
    angles = rr.copy()
    angles[:, 1] = 0.1
    assert choose_filter("auto", merge([(0, _rows(rr))], ("M",)))[0] == EKF_SPLINE_FIT
    assert choose_filter("auto", merge([(0, _rows(angles))], ("R",)))[0] == "ekf"
    assert choose_filter("ukf", merge([(0, _rows(rr))], ("M",))) == ("ukf", "configured")
