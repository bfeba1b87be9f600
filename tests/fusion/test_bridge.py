"""Bridging a gap between spans equals the RTS smoother with data only at the two ends."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.bridge import bridge_gaps, ca_noise, ca_transition

filterpy = pytest.importorskip("filterpy")
from filterpy.kalman import KalmanFilter  # noqa: E402


def random_cov(rng, scale):
    a = rng.normal(size=(9, 9)) * scale
    return a @ a.T + np.eye(9) * scale ** 2


def test_the_fit_equals_filterpy_rts_with_the_ends_as_measurements() -> None:
    rng = np.random.default_rng(3)
    rate, q = 10.0, 4.0
    ta, tb = 100.0, 130.0
    xa = np.r_[1000.0, 2000.0, 500.0, 100.0, -50.0, 5.0, 1.0, 2.0, 0.0]
    xb = ca_transition(np.array([tb - ta]))[0] @ xa + rng.normal(size=9)
    Pa, Pb = random_cov(rng, 1.0), random_cov(rng, 2.0)
    t = np.r_[np.arange(90.0, ta + 1e-9, 0.1), np.arange(tb, 140.0, 0.1)]
    x = np.zeros((t.size, 9))
    P = np.tile(np.eye(9), (t.size, 1, 1))
    ia, ib = int(np.argmin(np.abs(t - ta))), int(np.argmin(np.abs(t - tb)))
    x[ia], P[ia], x[ib], P[ib] = xa, Pa, xb, Pb
    tt, xx, PP, filled = bridge_gaps(t, x, P, np.full(t.size, q), rate, max_seconds=60.0)
    inside = np.flatnonzero(filled)
    assert np.allclose(tt[inside], np.arange(1001, 1300) / rate)
    # oracle: FilterPy KF from (xa, Pa) over the gap, (xb, Pb) as a full-state measurement at
    # tb, then its RTS smoother
    kf = KalmanFilter(dim_x=9, dim_z=9)
    kf.x, kf.P, kf.H, kf.R = xa.copy(), Pa.copy(), np.eye(9), Pb.copy()
    steps = np.arange(1001, 1301) / rate
    Fs, Qs, means, covs = [], [], [], []
    prev = ta
    for ti in steps:
        kf.F = ca_transition(np.array([ti - prev]))[0]
        kf.Q = ca_noise(np.array([ti - prev]), q)[0]
        kf.predict()
        if np.isclose(ti, tb):
            kf.update(xb)
        Fs.append(kf.F.copy())
        Qs.append(kf.Q.copy())
        means.append(kf.x.copy())
        covs.append(kf.P.copy())
        prev = ti
    xs, Ps, _, _ = kf.rts_smoother(np.array(means), np.array(covs), np.array(Fs), np.array(Qs))
    np.testing.assert_allclose(xx[inside], xs[:-1], rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(PP[inside], Ps[:-1], rtol=1e-6, atol=1e-6)
    sig = np.sqrt(PP[inside, 0, 0])
    assert sig.max() > 10 * np.sqrt(max(Pa[0, 0], Pb[0, 0]))       # grows inside the gap
    assert abs(np.argmax(sig) - inside.size / 2) < inside.size / 4  # most in the middle


def test_gaps_longer_than_the_limit_stay_empty() -> None:
    t = np.r_[np.arange(0.0, 10.0, 0.1), np.arange(200.0, 210.0, 0.1)]
    x = np.zeros((t.size, 9))
    P = np.tile(np.eye(9), (t.size, 1, 1))
    tt, _, _, filled = bridge_gaps(t, x, P, np.ones(t.size), 10.0, max_seconds=100.0)
    assert tt.size == t.size and not filled.any()
