"""Range rates alone: the batch spline fit and the smoother disagree; whichever is kept, its
sigma covers the other.

``fusion.spline_refine`` keeps the fit or the smoothed track by a test; on range rates alone
the kept covariance is widened by the outer product of their difference
(``DISAGREEMENT_SHARE``). Hand-made MISTRAM-like rows (six stations, 10 Hz) of a straight
flight, and two smoothed tracks: one 30 m off in height (the fit, which explains the data, is
kept with a sigma of a few metres), and one that follows a wiggle of the data that the fit's
8 s knots cannot (the smoother is kept: its stated sigma is 0.1 m, the fit farther away).
Without the widening the kept sigma covers neither difference; with position fixes in the
data (GPS) nothing is widened.
"""
from __future__ import annotations

import numpy as np

from conftest import gps_line_batch
from rangeproc.fusion import spline_refine as sr
from rangeproc.fusion.batch import SensorRows, empty_rows, merge
from rangeproc.models.measurement import SPHERICAL, measure_py

TRIL = np.tril_indices(9)
DIAG = [k for k, (i, j) in enumerate(zip(*TRIL)) if i == j]
VELOCITY = np.array([100.0, 50.0, 0.0])
START = np.array([-3000.0, -1500.0, 3000.0])
STATIONS = np.array([[-15e3, -12e3, 10.0], [14e3, -10e3, 50.0], [-9e3, 16e3, 0.0],
                     [12e3, 13e3, 120.0], [0.0, -18e3, 30.0], [2e3, 5e3, 400.0]])
SIGMA_RR = 0.1      #: m/s


def _line(t: np.ndarray) -> np.ndarray:
    x = np.zeros((t.size, 9))
    x[:, :3] = START + np.outer(t, VELOCITY)
    x[:, 3:6] = VELOCITY
    return x


def _wiggle(t: np.ndarray, amplitude: float) -> np.ndarray:
    """(E, 9) a height wiggle of 4 s period (position, velocity, acceleration)."""
    w = 2.0 * np.pi / 4.0
    x = np.zeros((t.size, 9))
    x[:, 2], x[:, 5] = amplitude * np.sin(w * t), amplitude * w * np.cos(w * t)
    x[:, 8] = -amplitude * w * w * np.sin(w * t)
    return x


def _range_rates(epoch_t: np.ndarray, truth: np.ndarray, seed: int = 3):
    """Every station's range rate at every epoch, noisy; (batch, meas_epoch)."""
    rng = np.random.default_rng(seed)
    k = len(STATIONS)
    meas_epoch = np.repeat(np.arange(epoch_t.size), k)
    rows = empty_rows(meas_epoch.size, SPHERICAL)
    rows["s"][:] = np.tile(STATIONS, (epoch_t.size, 1))
    for i, e in enumerate(meas_epoch):
        h, _ = measure_py(SPHERICAL, truth[e], rows["s"][i], np.zeros(3), np.eye(3))
        rows["z"][i, 3] = h[3] + rng.normal(0.0, SIGMA_RR)
    rows["sigma"][:, 3] = SIGMA_RR
    n = meas_epoch.size
    part = SensorRows(t=epoch_t[meas_epoch], source_row=np.arange(n),
                      station=np.tile(np.arange(k), epoch_t.size), track=np.full(n, -1),
                      **rows)
    return merge([(0, part)], ("MISTRAM",)), meas_epoch


def _refine(batch, epoch_t, meas_epoch, xs: np.ndarray, Ps: np.ndarray, spacing: float):
    """spline_refine's (xs, Ps) and the fit it judged, evaluated at the epochs."""
    used = np.isfinite(batch.z)
    res = np.full(batch.z.shape, np.nan)
    for i, e in enumerate(meas_epoch):
        h, _ = measure_py(int(batch.model[i]), xs[e], batch.s[i], batch.sv[i], batch.Qr[i])
        res[i, used[i]] = batch.z[i, used[i]] - h[used[i]]
    q, none = np.ones(epoch_t.size), np.empty(0)
    fit = sr._best_fit(batch, epoch_t, meas_epoch, xs, Ps, used, q, none, spacing, None)
    xs_out, Ps_out, _, _ = sr.spline_refine(batch, epoch_t, meas_epoch, xs, Ps, used, res,
                                            np.zeros(batch.z.shape), q, none, spacing, None)
    return xs_out, Ps_out, fit.evaluate(epoch_t)[0]


def test_kept_fit_covers_a_smoother_30_m_off():
    t = np.arange(0.0, 60.0, 0.1)
    truth = _line(t)
    batch, meas_epoch = _range_rates(t, truth)
    smooth = truth.copy()
    smooth[:, 2] += 30.0
    Ps = np.tile(np.diag([4.0] * 3 + [0.01] * 6)[TRIL], (t.size, 1))
    xs, Ps_out, fit = _refine(batch, t, meas_epoch, smooth, Ps, spacing=5.0)
    np.testing.assert_allclose(xs, fit, atol=1e-9)                  # the fit is kept as it is
    d = np.abs(fit - smooth)
    assert d[:, 2].min() > 20.0                                     # they do disagree
    own = np.sqrt((Ps_out - sr.disagreement(fit, smooth))[:, 5])    # the fit's own sigma
    assert np.all(own < d[:, 2])                                    # which does not cover it
    assert np.all(np.sqrt(Ps_out[:, DIAG]) >= d * (1 - 1e-9))      # the kept sigma does


def test_kept_smoother_covers_a_fit_that_strays():
    t = np.arange(0.0, 60.0, 0.1)
    truth = _line(t) + _wiggle(t, 0.3)
    batch, meas_epoch = _range_rates(t, truth)
    Ps = np.tile(np.diag([0.01] * 3 + [0.0025] * 3 + [0.01] * 3)[TRIL], (t.size, 1))
    xs, Ps_out, fit = _refine(batch, t, meas_epoch, truth, Ps, spacing=8.0)
    np.testing.assert_array_equal(xs, truth)                        # the smoother is kept
    d = np.abs(fit - truth)
    assert np.any(d[:, :6] > 3.0 * np.sqrt(Ps[:, DIAG[:6]]))       # beyond its stated 3 sigma
    assert np.all(np.sqrt(Ps_out[:, DIAG]) >= d * (1 - 1e-9))
    np.testing.assert_allclose(Ps_out - Ps, sr.disagreement(fit, truth), atol=1e-12)


def test_position_fixes_are_not_widened():
    t = np.arange(0.0, 60.0, 0.5)
    batch = gps_line_batch(t, np.random.default_rng(3), noise=2.0, sigma=2.0)
    smooth = _line(t)
    smooth[:, :3] += np.array([0.0, 0.0, 3000.0]) - START        # gps_line_batch's start
    smooth[:, 2] += 30.0
    Ps = np.tile(np.diag([1.0] * 3 + [0.01] * 6)[TRIL], (t.size, 1))
    xs, Ps_out, fit = _refine(batch, t, np.arange(t.size), smooth, Ps, spacing=5.0)
    np.testing.assert_allclose(xs, fit, atol=1e-9)
    assert np.sqrt(Ps_out[:, 5]).max() < 2.0                        # the fit's own sigma
