"""UKF measurement update against FilterPy's UnscentedKalmanFilter (same sigma points)."""
import numpy as np
import pytest

from rangeproc.estimation.forward import (
    EKF,
    UKF,
    FilterPrior,
    FilterRows,
    FilterSettings,
    run_filter,
)
from rangeproc.estimation.linalg import unpack
from rangeproc.estimation.rts import rts_smooth
from rangeproc.models.measurement import SPHERICAL, measure_py, wrap_angle
from rangeproc.models.motion import ca_transition_py

filterpy_kalman = pytest.importorskip("filterpy.kalman")


def _radar_case(n_steps=300, dt=0.05, q=5.0, seed=4):
    rng = np.random.default_rng(seed)
    F, Q = ca_transition_py(dt, q)
    x = np.array([-3e3, -20e3, 4e3, -50.0, 150.0, 0.0, 0.0, 0.0, 0.0])   # crosses az = +-pi
    truth = []
    for _ in range(n_steps):
        truth.append(x.copy())
        x = F @ x + np.linalg.cholesky(Q + 1e-15 * np.eye(9)) @ rng.standard_normal(9)
    truth = np.array(truth)
    sig = np.array([5.0, 3e-4, 3e-4, 0.1])
    z = np.full((n_steps, 6), np.nan)
    for k in range(n_steps):
        h, _ = measure_py(SPHERICAL, truth[k], np.zeros(3), np.zeros(3), np.eye(3))
        z[k, :4] = h[:4] + sig * rng.standard_normal(4)
        z[k, 1] = wrap_angle(z[k, 1])
    sigma = np.ones((n_steps, 6))
    sigma[:, :4] = sig
    return np.arange(n_steps) * dt, z, sigma, truth, F, Q


def test_ukf_update_matches_filterpy_with_redrawn_sigma_points():
    t, z, sigma, truth, F, Q = _radar_case()
    n = len(t)
    alpha, beta, kappa = 1.0, 2.0, 3.0 - 9        # seed 001: kappa = 3 - n
    x0 = truth[0] + np.r_[20.0, -20.0, 10.0, 2.0, -2.0, 1.0, 0.0, 0.0, 0.0]
    P0 = np.diag([400.0] * 3 + [25.0] * 3 + [4.0] * 3)
    q = np.full(n, 5.0)
    out = run_filter(
        FilterRows(t, np.arange(n), np.full(n, SPHERICAL), z, sigma, np.zeros((n, 3)),
                   np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64)),
        FilterPrior(x0, P0, q),
        FilterSettings(np.full(7, np.inf), method=UKF, ukf=(alpha, beta, kappa)))
    xf, Pf = out.xf, out.Pf

    points = filterpy_kalman.MerweScaledSigmaPoints(9, alpha=alpha, beta=beta, kappa=kappa)

    def hx(x):
        return measure_py(SPHERICAL, x, np.zeros(3), np.zeros(3), np.eye(3))[0][:4]

    def z_mean(sigmas, wm):
        # azimuth: weighted mean of deviations from the central point, wrapped
        out = wm @ sigmas
        dev = np.array([wrap_angle(a - sigmas[0, 1]) for a in sigmas[:, 1]])
        out[1] = sigmas[0, 1] + wm @ dev
        return out

    def residual_z(a, b):
        d = a - b
        d[1] = wrap_angle(d[1])
        return d

    ukf = filterpy_kalman.UnscentedKalmanFilter(
        dim_x=9, dim_z=4, dt=t[1] - t[0], hx=hx, fx=lambda x, dt: F @ x, points=points,
        z_mean_fn=z_mean, residual_z=residual_z)
    ukf.x, ukf.P, ukf.Q = x0.copy(), P0.copy(), Q
    ukf.R = np.diag(sigma[0, :4] ** 2)
    P = np.empty((9, 9))
    fp_x, fp_P = [], []
    for k in range(n):
        if k > 0:
            ukf.predict()
        ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)   # redraw from the predicted moments
        ukf.update(z[k, :4])
        unpack(Pf[k], P)
        np.testing.assert_allclose(xf[k], ukf.x, rtol=1e-10, atol=1e-7)
        np.testing.assert_allclose(P, ukf.P, rtol=1e-7, atol=1e-9)
        fp_x.append(ukf.x.copy())
        fp_P.append(ukf.P.copy())
    # Unscented RTS smoother (FilterPy propagates sigma points through fx): with the linear CA
    # transition it equals the RTS smoother exactly (Sarkka 2008), which is what rangeproc runs.
    xs_fp, Ps_fp, _ = ukf.rts_smoother(np.array(fp_x), np.array(fp_P), dts=np.diff(t, prepend=0))
    xs_rp, Ps_rp, _ = rts_smooth(t, xf.copy(), Pf.copy(), q)
    np.testing.assert_allclose(xs_rp, xs_fp, rtol=1e-9, atol=1e-6)
    for k in (0, n // 2, n - 2):
        unpack(Ps_rp[k], P)
        np.testing.assert_allclose(P, Ps_fp[k], rtol=1e-6, atol=1e-8)
    # consistency against truth and a working smoother on top
    err = xf[50:, :3] - truth[50:, :3]
    assert np.sqrt(np.mean(err ** 2)) < 10.0
    xs, Ps, _ = rts_smooth(t, xf.copy(), Pf.copy(), q)
    es = xs[50:-50, :3] - truth[50:-50, :3]
    assert np.sqrt(np.mean(es ** 2)) < np.sqrt(np.mean(err ** 2))


def test_ukf_and_ekf_agree_when_the_measurement_is_nearly_linear():
    """A far target seen with small relative uncertainty: EKF and UKF updates nearly coincide."""
    t, z, sigma, truth, F, Q = _radar_case(n_steps=200)
    n = len(t)
    P0 = np.diag([100.0] * 3 + [25.0] * 3 + [4.0] * 3)
    rows = FilterRows(t, np.arange(n), np.full(n, SPHERICAL), z, sigma, np.zeros((n, 3)),
                      np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), np.zeros(n, np.int64))
    prior = FilterPrior(truth[0].copy(), P0, np.full(n, 5.0))
    xe = run_filter(rows, prior, FilterSettings(np.full(7, np.inf), method=EKF)).xf
    xu = run_filter(rows, prior, FilterSettings(np.full(7, np.inf), method=UKF)).xf
    assert np.abs(xe[20:, :3] - xu[20:, :3]).max() < 0.05
