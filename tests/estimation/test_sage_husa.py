"""Improved Sage-Husa adaptive measurement noise (seed 002) in the compiled filter."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.estimation.adaptive import SH_WARMUP
from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.fusion.batch import empty_rows
from rangeproc.models.measurement import CARTESIAN

Q = 0.5


def gps_case(n: int, true_sigma: float, stated_sigma: float, seed: int):
    """A constant-acceleration target, position measured with white noise ``true_sigma``
    while the rows state ``stated_sigma``. Returns (t, rows, truth (n, 9))."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    acc = np.array([0.5, -0.2, 0.1])
    truth = np.zeros((n, 9))
    truth[:, 0:3] = np.outer(t, [100.0, 50.0, 5.0]) + 0.5 * np.outer(t * t, acc)
    truth[:, 3:6] = np.array([100.0, 50.0, 5.0]) + np.outer(t, acc)
    truth[:, 6:9] = acc
    a = empty_rows(n, CARTESIAN)
    a["z"][:, :3] = truth[:, :3] + rng.normal(0.0, true_sigma, (n, 3))
    a["sigma"][:, :3] = stated_sigma
    return t, a, truth


def run(t, a, truth, window: int, mean: bool = False):
    n = t.size
    x0 = truth[0].copy()
    P0 = np.diag([25.0] * 3 + [4.0] * 3 + [1.0] * 3)
    gate = np.full(7, np.inf)
    rows = FilterRows(t, np.arange(n), a["model"], a["z"], a["sigma"], a["s"], a["sv"],
                      a["Qr"], np.zeros(n, np.int64))
    return run_filter(rows, FilterPrior(x0, P0, np.full(n, Q)),
                      FilterSettings(gate, adapt_window=window, adapt_mean=mean))


def test_window_bookkeeping_alone_changes_nothing() -> None:
    """During warm-up the adaptive path records but never alters: identical to the EKF."""
    t, a, truth = gps_case(SH_WARMUP - 1, 2.0, 2.0, seed=1)
    ekf = run(t, a, truth, 0)
    sh = run(t, a, truth, 100)
    np.testing.assert_array_equal(ekf.xf, sh.xf)
    np.testing.assert_array_equal(ekf.Pf, sh.Pf)
    assert ekf.sigma_used.shape == (0, 6) and sh.sigma_used.shape == (t.size, 6)


@pytest.mark.parametrize("stated", [0.4, 2.0, 10.0])
def test_adapted_sigma_recovers_the_true_noise(stated: float) -> None:
    t, a, truth = gps_case(3000, 2.0, stated, seed=2)
    sigma_used = run(t, a, truth, 100).sigma_used
    late = sigma_used[1000:, :3]
    assert np.all(np.isfinite(late))
    assert np.median(late) == pytest.approx(2.0, rel=0.1)


def test_filtered_nees_is_consistent_with_wrong_stated_sigmas() -> None:
    """Monte Carlo, stated sigma 4x too small: the EKF is far overconfident, Sage-Husa is not.
    Mean NEES of the filtered position after warm-up inside the chi-square 99 % band."""
    nees_sh, nees_ekf = [], []
    for seed in range(8):
        t, a, truth = gps_case(600, 2.0, 0.5, seed=10 + seed)
        for window, out in ((100, nees_sh), (0, nees_ekf)):
            res = run(t, a, truth, window)
            xf, Pf = res.xf, res.Pf
            e = xf[200:, :3] - truth[200:, :3]
            P = np.empty((len(e), 3, 3))
            # packed lower triangle, row-major: (0,0), (1,0), (1,1), (2,0), (2,1), (2,2)
            p = Pf[200:]
            P[:, 0, 0], P[:, 1, 0], P[:, 1, 1] = p[:, 0], p[:, 1], p[:, 2]
            P[:, 2, 0], P[:, 2, 1], P[:, 2, 2] = p[:, 3], p[:, 4], p[:, 5]
            P[:, 0, 1], P[:, 0, 2], P[:, 1, 2] = P[:, 1, 0], P[:, 2, 0], P[:, 2, 1]
            out.extend(np.einsum("ni,ni->n", e, np.linalg.solve(P, e[..., None])[..., 0]))
    # correlated epochs: a generous band around 3 for the adaptive filter
    assert 2.0 < np.mean(nees_sh) < 4.5, np.mean(nees_sh)
    assert np.mean(nees_ekf) > 3 * np.mean(nees_sh)


def test_noise_mean_and_variance_are_told_apart() -> None:
    """Against a tightly known trajectory (stiff prior, no process noise) a sensor offset of
    30 m shows as innovation mean: with the mean estimated the adapted sigma is the true 2 m,
    without it the offset is absorbed as noise (about sqrt(2^2 + 30^2) m)."""
    t, a, truth = gps_case(2000, 2.0, 2.0, seed=3)
    a["z"][:, 0] += 30.0                               # a constant offset on east
    n = t.size
    x0 = truth[0].copy()
    P0 = np.diag([1e-14] * 9)

    def sigma_east(mean: bool) -> float:
        rows = FilterRows(t, np.arange(n), a["model"], a["z"], a["sigma"], a["s"], a["sv"],
                          a["Qr"], np.zeros(n, np.int64))
        out = run_filter(rows, FilterPrior(x0, P0, np.full(n, 1e-15)),
                         FilterSettings(np.full(7, np.inf), adapt_window=100, adapt_mean=mean))
        return float(np.median(out.sigma_used[1000:, 0]))

    assert sigma_east(True) == pytest.approx(2.0, rel=0.15)
    assert sigma_east(False) == pytest.approx(np.hypot(2.0, 30.0), rel=0.15)
