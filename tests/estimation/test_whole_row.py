"""The fast path's fused whole-row update (``fast_update.whole_row``) against the gated update
it stands in for (``fast_update.update``, ``update.update_row``'s source): the same bits for a
row that passes, nothing touched for a row that fails (the caller then re-gates it through
``update``), and a negative control showing that the comparison tells two algebraically equal
covariance updates apart.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.estimation import fast_update as fu
from rangeproc.models.measurement import SPHERICAL, measure_py
from rangeproc.quantiles import chi2_ppf

GATE = np.array([math.inf] + [chi2_ppf(1.0 - 1e-3, k) for k in range(1, 7)])
SITE = np.array([300.0, -200.0, 10.0])


def _row(seed: int, wild: float = 0.0, angles_only: bool = False, rate: bool = False):
    """A radar row's fast-path moments at a predicted state: ``(x, P, moments, m)``, the
    azimuth off by ``wild`` rad; with its range rate (``rate``; the radar on a moving
    platform), then ``moments`` ends with the Jacobian's columns ``n_cols``."""
    rng = np.random.default_rng(seed)
    x = np.r_[20e3, 15e3, 5e3, 200.0, -50.0, 3.0, 0.5, 0.2, 0.0]
    A = rng.normal(size=(9, 9))
    P = 0.5 * A @ A.T + np.diag([400.0] * 3 + [25.0] * 3 + [1.0] * 3)
    sv = np.array([4.0, -3.0, 0.5])
    h, _ = measure_py(SPHERICAL, x, SITE, sv, np.eye(3))
    k = 4 if rate else 3
    sigma = np.zeros((1, 6))
    sigma[0, :4] = [5.0, 2e-4, 2e-4, 0.1]
    z = np.full((1, 6), np.nan)
    z[0, :k] = h[:k] + rng.normal(0.0, sigma[0, :k])
    z[0, 1] += wild
    if angles_only:
        z[0, 0] = np.nan
    idx, sig_row, y = np.empty(4, np.int64), np.empty(4), np.empty(4)
    C, Z, Hs = np.empty((4, 9)), np.empty((4, 4)), np.zeros((4, 6))   # fast_workspace's
    m, n_cols = fu.ekf_moments(SPHERICAL, z, sigma, SITE[None], sv[None], np.eye(3)[None], 0,
                               x, np.empty((0, 9)), 0, False, P, idx, sig_row, y, C, Z, Hs)
    assert n_cols == (6 if rate else 3)
    return x, P, (y, sig_row, C, Z, Hs, idx, n_cols), m


def _whole(x, P, mom, m, joseph=True):
    y, sig_row, C, Z, Hs, _, n_cols = mom
    x, P = x.copy(), P.copy()
    nis, ok, logdet = fu.whole_row(y, sig_row, C, Z, Hs, m, n_cols, x, P, GATE, joseph,
                                   np.empty(4), np.empty(6), np.empty((4, 9)),
                                   np.empty((4, 4)), np.empty(6), np.empty((4, 9)),
                                   np.empty((9, 9)), np.empty((9, 4)))
    return nis, ok, logdet, x, P


def _gated(x, P, mom, m, joseph=True):
    y, sig_row, C, Z, Hs, idx, _ = mom
    x, P = x.copy(), P.copy()
    out = fu.update(y, sig_row, C, Z, Hs, idx, m, x, P, GATE, joseph, False,
                    np.empty(4, np.int64), np.empty(4), np.empty(4), np.empty((4, 9)),
                    np.empty((4, 4)), np.empty((4, 9)), np.empty((9, 9)), np.empty((9, 4)),
                    np.empty(4), np.empty(4), np.empty((4, 4)))
    return out, x, P


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("angles_only", [False, True])
@pytest.mark.parametrize("rate", [False, True])
def test_a_passing_row_gives_the_gated_updates_bits(seed: int, angles_only: bool,
                                                    rate: bool) -> None:
    x, P, mom, m = _row(seed, angles_only=angles_only, rate=rate)
    assert m == (2 if angles_only else 3) + rate
    nis, ok, logdet, xw, Pw = _whole(x, P, mom, m)
    (val, accepted, n_acc, mask, ll), xg, Pg = _gated(x, P, mom, m)
    assert ok and accepted and n_acc == m and mask == 0
    assert nis == val and fu.row_loglik(nis, logdet, m) == ll
    assert np.array_equal(xw, xg) and np.array_equal(Pw, Pg)
    assert not np.array_equal(xw, x)                      # it did update


def test_a_failing_row_is_left_to_the_re_gating_untouched() -> None:
    x, P, mom, m = _row(4, wild=0.05)                     # azimuth 1.2 km off at 25 km
    nis, ok, _, xw, Pw = _whole(x, P, mom, m)
    (val, accepted, n_acc, mask, _), xg, Pg = _gated(x, P, mom, m)
    assert not ok and nis > GATE[m] and nis == val
    assert np.array_equal(xw, x) and np.array_equal(Pw, P)   # nothing touched
    assert accepted and n_acc == 2 and mask == 1 << 1         # range, elevation kept
    assert not np.array_equal(xg, x)


def test_negative_control_the_comparison_tells_the_short_form_from_joseph() -> None:
    """``P - K HP`` equals the Joseph form in exact arithmetic; the bitwise comparison above
    must see the difference (else it could not catch a changed update)."""
    x, P, mom, m = _row(1)
    _, _, _, _, P_joseph = _whole(x, P, mom, m, joseph=True)
    _, _, _, _, P_short = _whole(x, P, mom, m, joseph=False)
    _, _, Pg_short = _gated(x, P, mom, m, joseph=False)
    assert np.array_equal(P_short, Pg_short)               # each form matches its own
    assert not np.array_equal(P_joseph, P_short)
    np.testing.assert_allclose(P_joseph, P_short, rtol=1e-6, atol=1e-9 * np.abs(P).max())
