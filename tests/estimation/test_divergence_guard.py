"""The divergence guard re-opens the covariance once per epoch, never compounding."""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.forward import (
    EKF,
    MAX_RESET_INFLATION,
    NO_FADING,
    NO_SPLINE,
    kalman_forward,
)
from rangeproc.estimation.rts import rts_smooth
from rangeproc.fusion.batch import empty_rows
from rangeproc.models.measurement import CARTESIAN


def test_thousands_of_rejected_rows_at_one_epoch_reset_once_and_smooth() -> None:
    """2,000 GPS rows sharing one stamp, all 50 km off: one reset at that epoch, a
    finite positive-definite covariance after it, and the smoother runs."""
    rng = np.random.default_rng(11)
    t_good = np.arange(0.0, 20.0, 0.1)
    n_bad = 2000
    t = np.sort(np.concatenate([t_good, np.full(n_bad, 10.05)]))
    a = empty_rows(t.size, CARTESIAN)
    a["z"][:, :3] = np.column_stack([100.0 * t, 0.0 * t, 1000.0 + 0.0 * t])
    a["z"][:, :3] += rng.normal(0.0, 1.0, (t.size, 3))
    at_once = np.flatnonzero(t == 10.05)
    a["z"][at_once, :3] += 50_000.0          # every component: no partial acceptance
    a["sigma"][:, :3] = 1.0
    epoch_t = np.unique(t)
    meas_epoch = np.searchsorted(epoch_t, t).astype(np.int64)
    x0 = np.zeros(9)
    x0[0:3] = a["z"][0, :3]
    x0[3] = 100.0
    P0 = np.diag([100.0] * 3 + [25.0] * 3 + [1.0] * 3)
    gate = np.full(7, np.inf)
    gate[1:] = [15.1, 18.4, 21.1, 23.5, 25.7, 27.9]
    xf, Pf, nis, dof, rej, ll, n_resets, *_ = kalman_forward(
        epoch_t, meas_epoch, a["model"], a["z"], a["sigma"], a["s"], a["sv"], a["Qr"],
        np.zeros(t.size, np.int64), x0, P0, np.full(epoch_t.size, 1.0), gate, 50, 100.0,
        np.empty((0, 9)), EKF, np.array([1.0, 2.0, -6.0]), 0, False, 0.0, NO_FADING, NO_SPLINE)
    assert n_resets == 1
    assert np.isfinite(Pf).all() and np.isfinite(xf).all()
    assert Pf.max() < MAX_RESET_INFLATION * 1e3
    xs, Ps, _ = rts_smooth(epoch_t, xf, Pf, np.full(epoch_t.size, 1.0), True, False)
    assert np.isfinite(xs).all()
    assert abs(xs[-1, 0] - 100.0 * epoch_t[-1]) < 5.0
