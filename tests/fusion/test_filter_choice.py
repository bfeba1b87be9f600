"""filter = "auto" (``fusion.filter_choice``): range rates alone get the spline fit, checked
by the EKF smoother: a spline result far outside their joint uncertainty is not kept."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from rangeproc.fusion.batch import merge
from rangeproc.fusion.filter_choice import AGREE, choose_filter, spline_or_ekf
from rangeproc.fusion.batch import SensorRows


def _result(offset: float, sigma: float):
    """A fusion result's fields the check reads: 20 epochs, positions along east + offset."""
    n = 20
    xs = np.zeros((n, 9))
    xs[:, 0] = np.arange(n) * 10.0 + offset
    Ps = np.zeros((n, 45))
    for k in (0, 2, 5):
        Ps[:, k] = sigma ** 2
    return SimpleNamespace(epoch_t=np.arange(n, dtype=float), grid=np.ones(n, dtype=bool),
                           xs=xs, Ps=Ps)


def test_a_spline_result_within_the_joint_uncertainty_is_kept():
    spline, ekf = _result(2.0, 1.0), _result(0.0, 1.0)     # 2 m against sqrt(2) m: m2 = 2
    kept, used, why = spline_or_ekf(spline, ekf)
    assert kept is spline and used == "spline" and "agrees" in why


def test_a_diverged_spline_result_gives_way_to_the_ekf():
    spline, ekf = _result(5000.0, 10.0), _result(0.0, 1.0)
    kept, used, why = spline_or_ekf(spline, ekf)
    assert kept is ekf and used == "ekf" and "strays" in why
    assert 5000.0 ** 2 / 101.0 > AGREE


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
    assert choose_filter("auto", merge([(0, _rows(rr))], ("M",)))[0] == "spline"
    assert choose_filter("auto", merge([(0, _rows(angles))], ("R",)))[0] == "ekf"
    assert choose_filter("ukf", merge([(0, _rows(rr))], ("M",))) == ("ukf", "configured")
