"""EKF: equivalence with FilterPy's EKF, gating, consistency over a 100,000-step radar run."""
import numpy as np
import pytest
from scipy.stats import chi2

from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.estimation.linalg import unpack
from rangeproc.estimation.rts import rts_smooth
from rangeproc.fusion.centralised import gate_thresholds
from rangeproc.models.measurement import SPHERICAL, measure_py, wrap_angle
from rangeproc.models.motion import ca_transition_py


def _truth(rng, n_steps, dt, q, x0):
    F, Q = ca_transition_py(dt, q)
    L = np.linalg.cholesky(Q + 1e-18 * np.eye(9))
    xs = np.empty((n_steps, 9))
    x = x0.copy()
    for k in range(n_steps):
        xs[k] = x
        x = F @ x + L @ rng.standard_normal(9)
    return xs


def _radar_rows(rng, truth, sig, site=np.zeros(3), Qr=np.eye(3)):
    n = len(truth)
    z = np.full((n, 6), np.nan)
    for k in range(n):
        h, _ = measure_py(SPHERICAL, truth[k], site, np.zeros(3), Qr)
        z[k, :3] = h[:3] + rng.standard_normal(3) * sig
    sigma = np.ones((n, 6))
    sigma[:, :3] = sig
    return z, sigma


def _run(t, z, sigma, x0, P0, q, gate, site=np.zeros(3), Qr=np.eye(3), reset_after=0):
    n = len(t)
    s = np.tile(site, (n, 1))
    rows = FilterRows(t, np.arange(n), np.full(n, SPHERICAL), z, sigma, s, np.zeros((n, 3)),
                      np.tile(Qr, (n, 1, 1)), np.zeros(n, np.int64))
    return run_filter(rows, FilterPrior(x0, P0, np.full(n, float(q))),
                      FilterSettings(gate, reset_after=reset_after, reset_inflation=100.0))


def test_ekf_matches_filterpy_extended_kalman_filter():
    filterpy = pytest.importorskip("filterpy.kalman")
    rng = np.random.default_rng(11)
    dt, q = 0.05, 5.0
    x0 = np.array([20e3, 15e3, 5e3, -200.0, 50.0, 0.0, 0.0, 0.0, 0.0])
    truth = _truth(rng, 400, dt, q, x0)
    sig = np.array([5.0, 2e-4, 2e-4])
    z, sigma = _radar_rows(rng, truth, sig)
    t = np.arange(len(truth)) * dt
    P0 = np.diag([100.0] * 3 + [400.0] * 3 + [25.0] * 3)
    out = _run(t, z, sigma, x0 + 10.0 * np.r_[1, 1, 1, 0, 0, 0, 0, 0, 0], P0, q,
               np.full(7, np.inf))
    xf, Pf = out.xf, out.Pf
    F, Q = ca_transition_py(dt, q)
    ekf = filterpy.ExtendedKalmanFilter(dim_x=9, dim_z=3)
    ekf.x = x0 + 10.0 * np.r_[1, 1, 1, 0, 0, 0, 0, 0, 0]
    ekf.P = P0.copy()
    ekf.F, ekf.Q, ekf.R = F, Q, np.diag(sig ** 2)

    def hx(x):
        return measure_py(SPHERICAL, x, np.zeros(3), np.zeros(3), np.eye(3))[0][:3]

    def hj(x):
        return measure_py(SPHERICAL, x, np.zeros(3), np.zeros(3), np.eye(3))[1][:3]

    def resid(a, b):
        d = a - b
        d[1] = wrap_angle(d[1])
        return d

    P = np.empty((9, 9))
    for k in range(len(t)):
        if k > 0:
            ekf.predict()
        ekf.update(z[k, :3], hj, hx, residual=resid)
        unpack(Pf[k], P)
        np.testing.assert_allclose(xf[k], ekf.x, rtol=1e-9, atol=1e-7)
        np.testing.assert_allclose(P, ekf.P, rtol=1e-7, atol=1e-9)


def test_gate_rejects_wild_points_and_carries_prediction():
    rng = np.random.default_rng(2)
    dt, q = 0.05, 1.0
    x0 = np.array([20e3, 15e3, 5e3, -200.0, 50.0, 0.0, 0.0, 0.0, 0.0])
    truth = _truth(rng, 2000, dt, q, x0)
    sig = np.array([5.0, 2e-4, 2e-4])
    z, sigma = _radar_rows(rng, truth, sig)
    wild = rng.choice(np.arange(200, 2000), 40, replace=False)
    z[wild, 0] += rng.choice([-1, 1], 40) * rng.uniform(200, 500, 40)
    t = np.arange(len(truth)) * dt
    P0 = np.diag([100.0] * 3 + [400.0] * 3 + [25.0] * 3)
    out = _run(t, z, sigma, x0, P0, q, gate_thresholds(0.9999), reset_after=50)
    xf, rej, resets = out.xf, out.rejected, out.n_resets
    # the wild range is rejected, the row's good angles are still used (component gating)
    assert ((rej[wild] & 1) == 1).all()
    assert ((rej[wild] & 0b110) == 0).mean() > 0.95
    clean = np.setdiff1d(np.arange(200, 2000), wild)
    assert (rej[clean] == 0).mean() > 0.995
    assert resets == 0
    err = np.linalg.norm(xf[200:, :3] - truth[200:, :3], axis=1)
    assert np.sqrt(np.mean(err ** 2)) < 10.0


def test_100k_step_radar_only_run_stays_consistent():
    """Radar noise mixes 25 m^2 with 4e-8 rad^2: the filter must not diverge (Stone Soup's does)."""
    rng = np.random.default_rng(20)
    n, dt, q = 100_000, 0.05, 0.05
    x0 = np.array([30e3, -20e3, 8e3, 150.0, 120.0, 0.0, 0.0, 0.0, 0.0])
    truth = _truth(rng, n, dt, q, x0)
    sig = np.array([5.0, 2e-4, 2e-4])
    z = np.full((n, 6), np.nan)
    d = truth[:, :3]
    r = np.linalg.norm(d, axis=1)
    z[:, 0] = r + sig[0] * rng.standard_normal(n)
    z[:, 1] = np.arctan2(d[:, 0], d[:, 1]) + sig[1] * rng.standard_normal(n)
    z[:, 2] = np.arcsin(d[:, 2] / r) + sig[2] * rng.standard_normal(n)
    sigma = np.ones((n, 6))
    sigma[:, :3] = sig
    t = np.arange(n) * dt
    P0 = np.diag([100.0] * 3 + [100.0] * 3 + [1.0] * 3)
    out = _run(t, z, sigma, x0, P0, q, np.full(7, np.inf))
    xf, Pf, nis = out.xf, out.Pf, out.nis
    assert np.isfinite(xf).all()
    # filtered NEES (position) over the second half: mean within the chi-square band
    P = np.empty((9, 9))
    nees = np.empty(n // 2)
    for j, k in enumerate(range(n // 2, n)):
        unpack(Pf[k], P)
        e = xf[k, :3] - truth[k, :3]
        nees[j] = e @ np.linalg.solve(P[:3, :3], e)
        if j == 0:
            assert np.all(np.linalg.eigvalsh(P) > 0)
    # successive epochs are strongly correlated: allow a generous band around 3 dof
    assert 2.0 < nees.mean() < 4.5
    unpack(Pf[-1], P)
    final_err = np.abs(xf[-1, :3] - truth[-1, :3]) / np.sqrt(np.diag(P)[:3])
    assert final_err.max() < 4.0
    # NIS over all steps consistent with 3 dof
    assert abs(np.mean(nis[1000:]) - 3.0) < 0.1
    xs, Ps, _ = rts_smooth(t, xf, Pf, np.full(len(t), float(q)))
    assert np.isfinite(xs).all()
    unpack(Ps[n // 2], P)
    assert np.all(np.linalg.eigvalsh(P) > 0)


def test_monte_carlo_smoothed_nees_inside_chi2_bounds():
    """Seeded Monte Carlo: the smoothed 9-state NEES at a fixed epoch is chi-square(9)."""
    rng = np.random.default_rng(99)
    runs, n, dt, q = 200, 120, 0.1, 2.0
    x0 = np.array([10e3, 10e3, 3e3, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    P0 = np.diag([100.0] * 3 + [100.0] * 3 + [4.0] * 3)
    sig = np.array([5.0, 5e-4, 5e-4])
    t = np.arange(n) * dt
    nees = np.empty(runs)
    P = np.empty((9, 9))
    for m in range(runs):
        start = x0 + np.linalg.cholesky(P0) @ rng.standard_normal(9)
        truth = _truth(rng, n, dt, q, start)
        z, sigma = _radar_rows(rng, truth, sig)
        out = _run(t, z, sigma, x0, P0, q, np.full(7, np.inf))
        xf, Pf = out.xf, out.Pf
        xs, Ps, _ = rts_smooth(t, xf, Pf, np.full(len(t), float(q)))
        k = n // 2
        unpack(Ps[k], P)
        e = xs[k] - truth[k]
        nees[m] = e @ np.linalg.solve(P, e)
    lo, hi = chi2.ppf([0.005, 0.995], 9 * runs) / runs
    assert lo < nees.mean() < hi
