"""The fast path (``estimation.fast_update``, ``rts._rts_fixed``) against the general code.

The general code runs the same rows when the state has a tenth, constant state (a
calibration state with no correlation): the fast path must give the same bits forward, and
the textbook smoother must agree with the symmetric form to round-off, on rows that exercise
every branch (radar, angle-only, range-rate and GPS rows, wild values, partly rejected rows,
divergence resets, linearisation at a previous trajectory).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.estimation.linalg import unpack_many
from rangeproc.estimation.rts import rts_smooth
from rangeproc.models.measurement import CARTESIAN, SPHERICAL, measure_py
from rangeproc.quantiles import chi2_ppf

GATE = np.array([math.inf] + [chi2_ppf(1.0 - 1e-3, k) for k in range(1, 7)])


def _rows(n: int = 1500, seed: int = 5) -> tuple[FilterRows, FilterPrior]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.05
    w = 250.0 / 20e3
    truth = np.column_stack([20e3 * np.sin(w * t), 20e3 * np.cos(w * t),
                             5e3 + 50.0 * np.sin(0.05 * t)])
    vel = np.gradient(truth, t, axis=0)
    site = np.array([300.0, -200.0, 10.0])
    model = np.where(np.arange(n) % 7 == 3, CARTESIAN, SPHERICAL)
    z = np.full((n, 6), np.nan)
    sigma = np.zeros((n, 6))
    s = np.zeros((n, 3))
    for i in range(n):
        x = np.r_[truth[i], vel[i], np.zeros(3)]
        if model[i] == SPHERICAL:
            s[i] = site
            h, _ = measure_py(SPHERICAL, x, site, np.zeros(3), np.eye(3))
            sigma[i, :4] = [5.0, 2e-4, 2e-4, 0.1]
            z[i, :4] = h[:4] + rng.normal(0.0, sigma[i, :4])
            if i % 3 == 0:
                z[i, 0] = np.nan                       # theodolite: angles only
            if i % 4 != 1:
                z[i, 3] = np.nan                       # range rate on some rows only
        else:
            sigma[i] = [2.0, 2.0, 3.0, 0.1, 0.1, 0.1]
            z[i] = np.r_[truth[i], vel[i]] + rng.normal(0.0, sigma[i])
            if i % 2:
                z[i, 3:] = np.nan                      # GPS position only
    z[97::211, 1] += 0.05                              # wild azimuths: partly rejected rows
    z[600:640, :3] += 400.0                            # a jump: the guard re-opens P
    rows = FilterRows(t, np.arange(n), model, z, sigma, s, np.zeros((n, 3)),
                      np.tile(np.eye(3), (n, 1, 1)), (model == CARTESIAN).astype(np.int64))
    x0 = np.r_[truth[0], vel[0], np.zeros(3)] + rng.normal(0.0, [20.0] * 3 + [5.0] * 3 + [1.0] * 3)
    P0 = np.diag([50.0 ** 2] * 3 + [20.0 ** 2] * 3 + [5.0 ** 2] * 3)
    return rows, FilterPrior(x0, P0, np.full(n, 2.0))


def _padded(prior: FilterPrior) -> FilterPrior:
    """The same prior with a tenth, uncorrelated constant state: the general code's size."""
    P0 = np.zeros((10, 10))
    P0[:9, :9] = prior.P0
    P0[9, 9] = 1.0
    x_lin = None if prior.x_lin is None else np.column_stack([prior.x_lin,
                                                              np.zeros(len(prior.x_lin))])
    return FilterPrior(np.r_[prior.x0, 0.0], P0, prior.q_steps, x_lin)


@pytest.mark.parametrize("linearised", [False, True])
def test_fast_path_gives_the_general_codes_bits(linearised: bool) -> None:
    rows, prior = _rows()
    settings = FilterSettings(GATE, reset_after=5, reset_inflation=100.0)
    if linearised:
        first = run_filter(rows, prior, settings)
        prior = prior._replace(x_lin=first.xf + 2.0)
    fast = run_filter(rows, prior, settings)
    general = run_filter(rows, _padded(prior), settings)
    assert fast.n_resets > 0 and (fast.rejected > 0).sum() > 20
    assert len(set(fast.rejected.tolist())) > 3                  # partial rejections too
    assert np.array_equal(fast.xf, general.xf[:, :9])
    Pf_fast = unpack_many(fast.Pf, 9)
    Pf_general = unpack_many(general.Pf, 10, 9)
    assert np.array_equal(Pf_fast, Pf_general)
    for name in ("nis", "dof", "rejected", "ll_rows"):
        assert np.array_equal(getattr(fast, name), getattr(general, name), equal_nan=True)
    assert fast.loglik == general.loglik and fast.n_resets == general.n_resets


def test_textbook_smoother_agrees_with_the_symmetric_form() -> None:
    rows, prior = _rows()
    settings = FilterSettings(GATE, reset_after=5, reset_inflation=100.0)
    fwd = run_filter(rows, prior, settings)
    gen = run_filter(rows, _padded(prior), settings)
    xs, Ps, em = rts_smooth(rows.epoch_t, fwd.xf, fwd.Pf, prior.q_steps)
    xg, Pg, eg = rts_smooth(rows.epoch_t, gen.xf, gen.Pf, prior.q_steps)
    P_fast, P_gen = unpack_many(Ps, 9), unpack_many(Pg, 10, 9)
    scale = np.sqrt(np.einsum("kii->ki", P_gen))
    norm = np.abs(P_fast - P_gen) / (scale[:, :, None] * scale[:, None, :])
    assert norm.max() < 1e-10
    assert np.all(np.einsum("kii->ki", P_fast) > 0.0)
    np.testing.assert_allclose(xs, xg[:, :9], rtol=0, atol=1e-9 * np.abs(xg).max())
    np.testing.assert_allclose(em, eg, rtol=1e-8, atol=1e-14)
    assert np.array_equal(P_fast, np.swapaxes(P_fast, 1, 2))
