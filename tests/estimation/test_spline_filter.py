"""Seed 000's self-adaptive spline filter (``spline_forward``): the anomaly test flags the
knot of a piecewise-cubic trajectory seen by 8 range-rate stations (the document's experiment,
noise-free), the jerk input of the new segment is re-estimated, and with the option off (or
unable to fire) the loop is exactly the plain filter."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chi2

from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.estimation.rts import rts_smooth
from rangeproc.estimation.spline_filter import (
    SPL_TABLE,
    anomaly_threshold,
    spline_params,
)
from rangeproc.models.measurement import SPHERICAL, measure_py

H = 0.05                      # 20 Hz
KNOT = 20.0
JERK2 = np.array([1.5, -1.0, 0.5])    # m/s^3 on [20, 40] s; [0, 20] s: constant acceleration


def piecewise_cubic(t: np.ndarray) -> np.ndarray:
    """(T, 9) truth: a constant-acceleration arc, then a cubic (jerk JERK2) joined C2 at 20 s."""
    p0, v0, a0 = np.array([-3000., 2000., 8000.]), np.array([180., 90., 20.]), \
        np.array([2., -1., 0.5])
    x = np.empty((len(t), 9))
    for i, tt in enumerate(t):
        t1 = min(tt, KNOT)
        p, v, a = p0 + v0 * t1 + a0 * t1 ** 2 / 2, v0 + a0 * t1, a0.copy()
        d = max(tt - KNOT, 0.0)
        x[i] = np.r_[p + v * d + a * d ** 2 / 2 + JERK2 * d ** 3 / 6,
                     v + a * d + JERK2 * d ** 2 / 2, a + JERK2 * d]
    return x


def scene(seed: int = 3):
    """Noise-free range rates of 8 stations within +-20 km (stated sigma 0.3 m/s, seed 000)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 40.0 + 1e-9, H)
    truth = piecewise_cubic(t)
    st = np.column_stack([rng.uniform(-20e3, 20e3, 8), rng.uniform(-20e3, 20e3, 8),
                          rng.uniform(0.0, 100.0, 8)])
    n = len(t) * 8
    z = np.full((n, 6), np.nan)
    for k in range(len(t)):
        for j in range(8):
            z[8 * k + j, 3] = measure_py(SPHERICAL, truth[k], st[j], np.zeros(3), np.eye(3))[0][3]
    sigma = np.full((n, 6), np.nan)
    sigma[:, 3] = 0.3
    x0 = truth[0] + np.r_[rng.normal(0, 5, 3), rng.normal(0, 0.5, 3), np.zeros(3)]
    P0 = np.diag([10.0 ** 2] * 3 + [1.0 ** 2] * 3 + [1.0 ** 2] * 3)
    return t, truth, (t, np.repeat(np.arange(len(t)), 8), np.full(n, SPHERICAL), z, sigma,
                      np.tile(st, (len(t), 1)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                      np.zeros(n, np.int64), x0, P0)


def run(args, q: float, spl: np.ndarray | None):
    """The EKF over the scene's rows with the spline filter's quantiles ``spl`` (None:
    the plain EKF)."""
    t = args[0]
    return run_filter(FilterRows(*args[:9]), FilterPrior(args[9], args[10], np.full(len(t), q)),
                      FilterSettings(np.full(7, np.inf), spline=spl))


def test_anomaly_fires_at_the_knot_only_and_the_new_jerk_is_estimated() -> None:
    t, truth, args = scene()
    q = 1e-3
    out = run(args, q, spline_params(0.999))
    xf, Pf, fade, jerk, anomaly, knot = out.xf, out.Pf, out.fade, out.jerk, out.anomaly, out.knot
    fired = t[knot]
    assert fired.size >= 1 and np.all((fired > KNOT) & (fired < KNOT + 1.5)), fired
    before = t < KNOT
    assert np.all(anomaly[before & (anomaly[:, 1] > 0), 0] < chi2.ppf(0.999, 8))
    np.testing.assert_array_equal(jerk[t <= fired[0]], 0.0)     # segment 1: no input
    np.testing.assert_allclose(jerk[-1], JERK2, atol=0.25)      # segment 2: re-estimated
    plain = run(args, q, None).xf
    err = np.linalg.norm(xf[-40:, :3] - truth[-40:, :3], axis=1).mean()
    err_plain = np.linalg.norm(plain[-40:, :3] - truth[-40:, :3], axis=1).mean()
    assert err < 0.5 * err_plain, (err, err_plain)
    # the smoother of the model the filter ran: jerk input and the anomaly's inflation
    xs, _, _ = rts_smooth(t, xf.copy(), Pf.copy(), np.full(len(t), q), True, False, fade, jerk)
    assert np.linalg.norm(xs[:, :3] - truth[:, :3], axis=1).max() < 2.0


def test_spline_that_cannot_fire_is_bit_identical_to_the_plain_filter() -> None:
    """The machinery alone (jerk input of zero, stacked statistic, residual RMS) changes no
    bit of the filter (the spline kernel against the plain EKF kernel); without the spline
    filter its outputs are empty."""
    _, _, args = scene(seed=4)
    never = spline_params(0.999)
    never[:] = np.inf
    a = run(args, 1e-2, never)
    b = run(args, 1e-2, None)
    assert not a.knot.any() and np.all(a.jerk == 0.0)
    for name in ("xf", "Pf", "nis", "dof", "rejected", "loglik", "n_resets", "ll_rows",
                 "sigma_used"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert b.jerk.shape == (0, 3) and b.anomaly.shape == (0, 2) and b.knot.shape == (0,)
    assert b.fade.shape == (0, 9)


@pytest.mark.parametrize("p", [0.99, 0.999, 0.9999])
def test_threshold_table_and_wilson_hilferty(p: float) -> None:
    spl = spline_params(p)
    for m in (1, 8, SPL_TABLE):
        assert anomaly_threshold(spl, m) == pytest.approx(chi2.ppf(p, m), rel=1e-12)
    for m in (SPL_TABLE + 1, 200, 5000):
        assert anomaly_threshold(spl, m) == pytest.approx(chi2.ppf(p, m), rel=2e-3)
