"""Batch cubic-spline trajectory fit (seed 000's post-flight counterpart of the spline filter).

Truths are exact cubic splines on the fitted knots, so noise-free data must be recovered to
rounding, and noisy fits must have honest covariances (NEES). Measurements are generated with
the shared model ``measure_py`` (SPHERICAL: A = atan2(d_e, d_n) clockwise from north,
E = atan2(d_u, hypot(d_e, d_n)), Rdot = d.w / |d|).
"""
import math
import warnings

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.stats import chi2 as chi2_dist

from rangeproc.estimation.spline_fit import fit_spline
from rangeproc.models.measurement import CARTESIAN, SPHERICAL, innovation, measure_py

GPS_SIGMA = np.array([2.0, 2.0, 3.0, 0.1, 0.1, 0.1])
RADAR_SIGMA = np.array([5.0, 1e-3, 1e-3, 0.0, 0.0, 0.0])


def truth_spline(rng, interior, t1, jitter=20.0):
    """Clamped knots on [0, t1] and (n_coef, 3) control points: ~200 m/s flight at 8 km plus
    random wiggles (accelerations of a few m/s^2, jerk jumps at every knot)."""
    knots = np.r_[[0.0] * 4, np.sort(interior), [t1] * 4]
    xi = (knots[1:-3] + knots[2:-2] + knots[3:-1]) / 3.0          # Greville abscissae
    coef = (np.array([-4000.0, 3000.0, 8000.0]) + xi[:, None] * np.array([180.0, 90.0, 20.0])
            + rng.normal(0.0, jitter, (len(xi), 3)))
    return knots, coef


def states(knots, coef, t):
    spl = BSpline(knots, coef, 3)
    return np.hstack([spl(t), spl(t, 1), spl(t, 2)])


def make_rows(model, t, x, s, comps, sigma):
    """Noise-free rows of one model at times t (N,), true states x (N, 9), sensor sites s."""
    n = len(t)
    s = np.broadcast_to(np.asarray(s, float), (n, 3)).copy()
    z = np.full((n, 6), np.nan)
    for i in range(n):
        h, _ = measure_py(model, x[i], s[i], np.zeros(3), np.eye(3))
        z[i, comps] = h[comps]
    return dict(t=np.asarray(t, float), model=np.full(n, model), z=z,
                sigma=np.tile(np.asarray(sigma, float), (n, 1)), s=s, sv=np.zeros((n, 3)),
                Qr=np.tile(np.eye(3), (n, 1, 1)))


def cat(*parts):
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def mistram_scene(seed=1, gps=True):
    """Seed 000's experiment: 40 s, 8 range-rate stations within +-20 km at 20 Hz (sigma 0.3
    m/s), a regular knot every 6 s plus the anomaly knot at 20 s; optional 1 Hz GPS."""
    rng = np.random.default_rng(seed)
    interior = np.r_[np.arange(6.0, 40.0, 6.0), 20.0]
    knots, coef = truth_spline(rng, interior, 40.0)
    stations = np.c_[rng.uniform(-20e3, 20e3, (8, 2)), rng.uniform(0.0, 500.0, 8)]
    t20 = np.repeat(np.arange(0.0, 40.0 + 1e-9, 0.05), 8)
    st = np.tile(stations, (len(t20) // 8, 1))
    rows = make_rows(SPHERICAL, t20, states(knots, coef, t20), st, [3], [0, 0, 0, 0.3, 0, 0])
    if gps:
        t1 = np.arange(0.0, 41.0, 1.0)
        rows = cat(rows, make_rows(CARTESIAN, t1, states(knots, coef, t1), 0.0, slice(0, 6),
                                   GPS_SIGMA))
    x = states(knots, coef, rows["t"])
    x_init = x.copy()
    x_init[:, :3] += rng.normal(0.0, 50.0, (len(x), 3))
    x_init[:, 3:6] += rng.normal(0.0, 5.0, (len(x), 3))
    return rows, interior, knots, coef, x_init


def assert_recovered(fit, knots, coef, tol_rel=1e-6, tol_abs=1e-6):
    assert fit.converged
    np.testing.assert_allclose(fit.knots, knots)
    assert np.abs(fit.coef - coef).max() <= tol_rel * np.abs(coef).max()
    te = np.linspace(knots[0], knots[-1], 401)
    xs, P = fit.evaluate(te)
    xt = states(knots, coef, te)
    assert np.abs(xs[:, :6] - xt[:, :6]).max() < tol_abs
    assert P.shape == (401, 9, 9) and np.all(np.isfinite(P))
    assert np.all(np.linalg.eigvalsh(P[:, :6, :6]) > 0)


def test_noise_free_range_rate_and_gps_recovered_from_perturbed_start():
    rows, interior, knots, coef, x_init = mistram_scene()
    fit = fit_spline(**rows, interior_knots=interior, x_init=x_init)
    assert_recovered(fit, knots, coef)
    assert fit.n_iter >= 2 and fit.chi2 < 1e-8
    assert fit.dof == 801 * 8 + 41 * 6 - 3 * len(coef)
    # without x_init: the initial spline is the linear fit to the GPS position fixes
    assert_recovered(fit_spline(**rows, interior_knots=interior), knots, coef)


def test_rejected_components_are_excluded():
    rows, interior, knots, coef, x_init = mistram_scene(seed=4)
    use = np.ones((len(rows["t"]), 6), bool)
    bad = np.flatnonzero(rows["model"] == SPHERICAL)[::97]
    rows["z"][bad, 3] += 50.0                       # gross range-rate outliers ...
    use[bad, 3] = False                             # ... rejected by the caller
    fit = fit_spline(**rows, interior_knots=interior, x_init=x_init, use=use)
    assert_recovered(fit, knots, coef)
    assert fit.dof == 801 * 8 - len(bad) + 41 * 6 - 3 * len(coef)
    assert not fit_spline(**rows, interior_knots=interior, x_init=x_init).chi2 < 1.0


def test_range_rate_only_with_prior_recovered():
    rows, interior, knots, coef, x_init = mistram_scene(seed=2, gps=False)
    x0 = states(knots, coef, np.array([0.0]))[0]
    prior = (0.0, x0, np.diag([100.0] * 3 + [1.0] * 3))
    fit = fit_spline(**rows, interior_knots=interior, x_init=x_init, prior=prior)
    assert_recovered(fit, knots, coef)
    assert fit.dof == 801 * 8 + 6 - 3 * len(coef)
    # from the prior's constant-velocity line alone (no x_init, no position fixes)
    assert_recovered(fit_spline(**rows, interior_knots=interior, prior=prior), knots, coef)
    with pytest.raises(ValueError):
        fit_spline(**rows, interior_knots=interior)


def test_covariance_is_inverse_of_finite_difference_normal_matrix():
    rng = np.random.default_rng(5)
    interior = np.array([3.0, 6.0, 9.0])
    knots, coef = truth_spline(rng, interior, 12.0)
    stations = np.c_[rng.uniform(-20e3, 20e3, (4, 2)), np.zeros(4)]
    t = np.repeat(np.arange(0.0, 12.01, 0.25), 4)
    st = np.tile(stations, (len(t) // 4, 1))
    t1 = np.arange(0.0, 12.1, 2.0)
    rows = cat(make_rows(SPHERICAL, t, states(knots, coef, t), st, [3], [0, 0, 0, 0.3, 0, 0]),
               make_rows(CARTESIAN, t1, states(knots, coef, t1), 0.0, slice(0, 6), GPS_SIGMA))
    rows["z"] += rng.normal(size=rows["z"].shape) * rows["sigma"]
    fit = fit_spline(**rows, interior_knots=interior)

    def resid(c):
        x = states(knots, c.reshape(-1, 3), rows["t"])
        out = []
        for i in range(len(x)):
            h, _ = measure_py(rows["model"][i], x[i], rows["s"][i], np.zeros(3), np.eye(3))
            y = np.empty(6)
            innovation(int(rows["model"][i]), rows["z"][i], h, y)
            out.append(y[np.isfinite(y)] / rows["sigma"][i][np.isfinite(y)])
        return np.concatenate(out)

    c0 = fit.coef.ravel()
    r0 = resid(c0)
    J = np.column_stack([(resid(c0 + e) - resid(c0 - e)) / 2e-4 for e in 1e-4 * np.eye(len(c0))])
    assert fit.chi2 == pytest.approx(r0 @ r0, rel=1e-10)
    assert np.abs(J.T @ r0).max() < 1e-4 * np.abs(J).max()          # a minimum
    C = np.linalg.inv(J.T @ J)
    band = fit.cov.toarray()
    inside = np.abs(np.subtract.outer(np.arange(len(c0)), np.arange(len(c0)))) <= 12
    np.testing.assert_allclose(band[inside], C[inside], rtol=0, atol=1e-6 * np.abs(C).max())


def test_monte_carlo_position_nees_is_consistent():
    """200 noisy fits (1 Hz GPS + 10 Hz radar R/A/E): the mean NEES of the position at a few
    times lies in the two-sided 99% chi-square bounds for 3 dof; a covariance off by a factor
    of 2 either way would not."""
    rng = np.random.default_rng(7)
    interior = np.arange(4.0, 20.0, 4.0)
    knots, coef = truth_spline(rng, interior, 20.0)
    tr, tg = np.arange(0.0, 20.0 + 1e-9, 0.1), np.arange(0.0, 20.5, 1.0)
    site = np.array([10e3, -5e3, 50.0])
    clean = cat(make_rows(SPHERICAL, tr, states(knots, coef, tr), site, [0, 1, 2], RADAR_SIGMA),
                make_rows(CARTESIAN, tg, states(knots, coef, tg), 0.0, slice(0, 6), GPS_SIGMA))
    te = np.array([0.7, 6.3, 13.1, 19.6])
    pt = states(knots, coef, te)[:, :3]
    runs = 200
    nees = np.empty((runs, len(te)))
    chi2s = np.empty(runs)
    for k in range(runs):
        rows = dict(clean, z=clean["z"] + rng.normal(size=clean["z"].shape) * clean["sigma"])
        fit = fit_spline(**rows, interior_knots=interior)
        assert fit.converged
        xs, P = fit.evaluate(te)
        e = xs[:, :3] - pt
        nees[k] = np.einsum("ti,tij,tj->t", e, np.linalg.inv(P[:, :3, :3]), e)
        chi2s[k] = fit.chi2
    lo, hi = chi2_dist.ppf([0.005, 0.995], 3 * runs) / runs
    mean = nees.mean(axis=0)
    assert np.all((lo < mean) & (mean < hi)), (lo, mean, hi)
    assert np.all(mean / 2 < lo) and np.all(mean * 2 > hi)      # the test has teeth
    lo, hi = chi2_dist.ppf([0.005, 0.995], fit.dof * runs) / runs
    assert lo < chi2s.mean() < hi


def test_azimuth_straddling_pi_is_wrapped():
    """A radar north of the track sees it due south: A = atan2(d_e, d_n) crosses +-pi. Half the
    rows report azimuth in [0, 2 pi) and the start is offset across the cut: only wrapped
    residuals give an exact, zero-chi2 fit."""
    rng = np.random.default_rng(3)
    interior = np.arange(5.0, 40.0, 5.0)
    knots, coef = truth_spline(rng, interior, 40.0, jitter=5.0)
    coef[:, 1] = 0.0                                   # fly east along y = 0 through x = 0
    coef[:, 0] -= coef[len(coef) // 2, 0]
    t = np.arange(0.0, 40.0 + 1e-9, 0.1)
    site = np.array([0.0, 12e3, 0.0])
    radar = make_rows(SPHERICAL, t, states(knots, coef, t), site, [0, 1, 2], RADAR_SIGMA)
    az = radar["z"][:, 1]
    assert az.min() < -3.0 and az.max() > 3.0        # straddles +-pi
    radar["z"][::2, 1] = np.mod(az[::2], 2 * math.pi)
    tg = np.arange(0.0, 41.0, 10.0)
    rows = cat(radar, make_rows(CARTESIAN, tg, states(knots, coef, tg), 0.0, [0, 1, 2],
                                GPS_SIGMA))
    x_init = states(knots, coef, rows["t"])
    x_init[:, 0] += 300.0
    fit = fit_spline(**rows, interior_knots=interior, x_init=x_init)
    assert_recovered(fit, knots, coef)
    assert fit.chi2 < 1e-10


def test_empty_knot_intervals_are_bridged_by_the_jerk_regularisation():
    """No rows in (8, 22) s, knots every 2 s: seven knot intervals hold no data, so without
    regularisation the normal matrix is singular (the gap's pieces have more unknowns than
    continuity conditions). The tiny jerk-jump pseudo-observations keep it definite (no warning); a
    truth with no jerk change (one cubic) is recovered exactly; the gap's covariance is
    larger than where data exist."""
    rng = np.random.default_rng(11)
    interior = np.arange(2.0, 30.0, 2.0)
    tt = np.linspace(0.0, 30.0, 61)
    poly = np.array([[-4000.0, 3000.0, 8000.0], [180.0, 90.0, 20.0], [1.5, -2.0, 0.3],
                     [0.05, 0.02, -0.01]])
    pts = np.vander(tt, 4, increasing=True) @ poly
    knots = np.r_[[0.0] * 4, interior, [30.0] * 4]
    D = BSpline.design_matrix(tt, knots, 3).toarray()
    coef = np.linalg.lstsq(D, pts, rcond=None)[0]                 # exact: a cubic is a spline
    stations = np.c_[rng.uniform(-20e3, 20e3, (8, 2)), np.zeros(8)]
    t = np.repeat(np.r_[np.arange(0.0, 8.01, 0.1), np.arange(22.0, 30.01, 0.1)], 8)
    st = np.tile(stations, (len(t) // 8, 1))
    tg = np.r_[0.0:9.0:1.0, 22.0:31.0:1.0]
    rows = cat(make_rows(SPHERICAL, t, states(knots, coef, t), st, [3], [0, 0, 0, 0.3, 0, 0]),
               make_rows(CARTESIAN, tg, states(knots, coef, tg), 0.0, slice(0, 6), GPS_SIGMA))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = fit_spline(**rows, interior_knots=interior)
    assert_recovered(fit, knots, coef)
    _, P = fit.evaluate(np.array([5.0, 15.0, 25.0]))
    sd = np.sqrt(np.trace(P[:, :3, :3], axis1=1, axis2=2))
    assert sd[1] > 5 * max(sd[0], sd[2])
    with pytest.raises(ValueError):
        fit.evaluate(np.array([30.5]))


def test_unobservable_position_warns_and_keeps_the_start():
    """Velocity-only rows: a common position offset is unobservable. The ridge fallback warns,
    keeps the initial position, recovers the velocity and reports a huge position variance."""
    rng = np.random.default_rng(2)
    interior = np.arange(5.0, 40.0, 5.0)
    knots, coef = truth_spline(rng, interior, 40.0)
    t = np.arange(0.0, 40.01, 0.5)
    x = states(knots, coef, t)
    rows = make_rows(CARTESIAN, t, x, 0.0, [3, 4, 5], GPS_SIGMA)
    with pytest.warns(RuntimeWarning, match="singular"):
        fit = fit_spline(**rows, interior_knots=interior, x_init=x + 30.0)
    xs, P = fit.evaluate(t)
    assert np.abs(xs[:, 3:6] - x[:, 3:6]).max() < 1e-6
    np.testing.assert_allclose(xs[:, :3] - x[:, :3], 30.0, atol=1e-6)
    assert np.all(np.sqrt(P[:, 0, 0]) > 1e3) and np.all(np.sqrt(P[:, 3, 3]) < 1.0)
