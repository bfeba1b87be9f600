"""Bridging a gap between spans equals the RTS smoother with data only at the two ends, its
process noise the ends' white jerk plus the manoeuvre the ends' speed allows."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.bridge import bridge_gaps, ca_transition
from rangeproc.models.motion import MANOEUVRE_FLOOR, MANOEUVRE_PSD, manoeuvre_psd

filterpy = pytest.importorskip("filterpy")
from filterpy.kalman import KalmanFilter  # noqa: E402


def random_cov(rng, scale):
    a = rng.normal(size=(9, 9)) * scale
    return a @ a.T + np.eye(9) * scale ** 2


def _gap_q(dt: float, q: float, qm: float) -> np.ndarray:
    """(9, 9) the gap's process noise written out (state [p, v, a] per axis blocks): the
    continuous white-jerk noise of PSD q on position, velocity and acceleration, plus the
    white-acceleration noise of PSD qm on position and velocity."""
    jerk = q * np.array([[dt ** 5 / 20, dt ** 4 / 8, dt ** 3 / 6],
                         [dt ** 4 / 8, dt ** 3 / 3, dt ** 2 / 2],
                         [dt ** 3 / 6, dt ** 2 / 2, dt]])
    jerk[:2, :2] += qm * np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    Q = np.zeros((9, 9))
    for k in range(3):
        idx = [k, 3 + k, 6 + k]
        Q[np.ix_(idx, idx)] = jerk
    return Q


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
    qm = float(manoeuvre_psd(np.array([xa[3:6], xb[3:6]]),
                             np.array([Pa[3:6, 3:6], Pb[3:6, 3:6]])).max())
    assert MANOEUVRE_FLOOR < qm < MANOEUVRE_PSD
    kf = KalmanFilter(dim_x=9, dim_z=9)
    kf.x, kf.P, kf.H, kf.R = xa.copy(), Pa.copy(), np.eye(9), Pb.copy()
    steps = np.arange(1001, 1301) / rate
    Fs, Qs, means, covs = [], [], [], []
    prev = ta
    for ti in steps:
        kf.F = ca_transition(np.array([ti - prev]))[0]
        kf.Q = _gap_q(ti - prev, q, qm)
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


@pytest.mark.parametrize("speed, psd", [(300.0, MANOEUVRE_PSD), (0.5, MANOEUVRE_FLOOR)])
def test_an_unseen_manoeuvre_widens_the_bridge_by_its_speed(speed: float, psd: float) -> None:
    """Ends known exactly (no jerk noise): the middle of a gap of T s has the variance of an
    integrated Wiener process pinned in position and velocity at both ends,
    ``q T^3 / 192`` per axis (the posterior variance of the cubic smoothing spline's prior,
    Wahba 1978), with q the manoeuvre PSD of the ends' speed: a fighter's bridge is hundreds
    of metres wide, a drifting boat's a few metres."""
    T, rate = 30.0, 10.0
    t = np.r_[np.arange(0.0, 1.0, 0.1), np.arange(T + 0.9, T + 2.0, 0.1)]
    v = np.r_[speed, 0.0, 0.0]
    x = np.zeros((t.size, 9))
    x[:, 0], x[:, 3] = speed * t, speed
    P = np.tile(np.eye(9) * 1e-12, (t.size, 1, 1))
    tt, xx, PP, filled = bridge_gaps(t, x, P, np.zeros(t.size), rate, max_seconds=60.0)
    mid = np.flatnonzero(filled)[np.argmin(np.abs(tt[filled] - (0.9 + T / 2 + 0.45)))]
    ta, tb = 0.9, T + 0.9
    gap = tb - ta
    u = (tt[mid] - ta) / gap
    expected = psd * gap ** 3 * u ** 3 * (1 - u) ** 3 / 3.0
    assert manoeuvre_psd(v[None], np.zeros((1, 3, 3)))[0] == psd
    np.testing.assert_allclose(PP[mid, [0, 1, 2], [0, 1, 2]], expected, rtol=1e-6)
    np.testing.assert_allclose(xx[mid, 0], speed * tt[mid], rtol=1e-9)
