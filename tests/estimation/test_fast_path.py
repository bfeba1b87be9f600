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
    s, sv = np.zeros((n, 3)), np.zeros((n, 3))
    for i in range(n):
        x = np.r_[truth[i], vel[i], np.zeros(3)]
        if model[i] == SPHERICAL:
            s[i] = site
            sv[i] = [4.0, -3.0, 0.5]                   # a moving sensor's velocity
            h, _ = measure_py(SPHERICAL, x, site, sv[i], np.eye(3))
            sigma[i, :4] = [5.0, 2e-4, 2e-4, 0.1]
            z[i, :4] = h[:4] + rng.normal(0.0, sigma[i, :4])
            if i % 3 == 0:
                z[i, 0] = np.nan                       # theodolite: angles only
            if i % 4 != 1:
                z[i, 3] = np.nan                       # range rate on some rows only
            if i % 5 == 2:
                z[i, :3] = np.nan                      # a range-rate station: rate only
        else:
            sigma[i] = [2.0, 2.0, 3.0, 0.1, 0.1, 0.1]
            z[i] = np.r_[truth[i], vel[i]] + rng.normal(0.0, sigma[i])
            if i % 2:
                z[i, 3:] = np.nan                      # GPS position only
    z[97::211, 1] += 0.05                              # wild azimuths: partly rejected rows
    z[600:640, :3] += 400.0                            # a jump: the guard re-opens P
    rows = FilterRows(t, np.arange(n), model, z, sigma, s, sv,
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



def test_the_smoother_into_fresh_arrays_leaves_the_filtered_history() -> None:
    """``rts_smooth(in_place=False)`` reads the filtered values and writes new arrays: the
    in-place result, bit for bit, with the inputs untouched (the rows reset the covariance,
    so the textbook steps hand over to the symmetric form and back)."""
    rows, prior = _rows()
    fwd = run_filter(rows, prior, FilterSettings(GATE, reset_after=5, reset_inflation=100.0))
    assert fwd.n_resets > 0
    xf, Pf = fwd.xf.copy(), fwd.Pf.copy()
    xs, Ps, em = rts_smooth(rows.epoch_t, xf, Pf, prior.q_steps)
    assert np.array_equal(xf, fwd.xf) and np.array_equal(Pf, fwd.Pf)
    xi, Pi, ei = rts_smooth(rows.epoch_t, xf, Pf, prior.q_steps, True, True)
    assert np.array_equal(xs, xi) and np.array_equal(Ps, Pi) and np.array_equal(em, ei)
    assert not np.array_equal(xf, fwd.xf)                  # negative control: in place

def _general_at_nine(rows: FilterRows, prior: FilterPrior, settings: FilterSettings):
    """The forward pass of ``settings`` through the general row code at nine states: the
    spline filter's specialisation with an anomaly threshold that no epoch reaches, which
    takes every row through the called moments and update (no knot, so no jerk input and
    no adapted sigmas: its steps change nothing)."""
    from rangeproc.estimation.forward import _f64, _i64
    from rangeproc.estimation.forward_loop import forward_kernel
    from rangeproc.families import family
    common = (_f64(rows.epoch_t, 1), _i64(rows.meas_epoch), _i64(rows.model), _f64(rows.z, 2),
              _f64(rows.sigma, 2), _f64(rows.s, 2), _f64(rows.sv, 2), _f64(rows.Qr, 3),
              _i64(rows.sensor), _f64(prior.x0, 1), _f64(prior.P0, 2),
              _f64(prior.q_steps, 1), _f64(settings.gate, 1), settings.reset_after,
              settings.reset_inflation)
    x_lin = np.empty((0, 9)) if prior.x_lin is None else _f64(prior.x_lin, 2)
    never = np.full(64, np.inf)                    # anomaly quantiles: never anomalous
    return forward_kernel(family("spline"), 9)(*common, x_lin, settings.method,
                                                _f64(settings.ukf, 1), never)


@pytest.mark.parametrize("method", [0, 1])
def test_fixed_size_plain_families_give_the_general_row_codes_bits(method: int) -> None:
    """The EKF's and the UKF's specialisations at nine states (fused moments and update)
    against the general row code at the same size, on rows that exercise every branch."""
    rows, prior = _rows()
    settings = FilterSettings(GATE, method=method, reset_after=5, reset_inflation=100.0)
    fast = run_filter(rows, prior, settings)
    xf, Pf, nis, dof, rejected, loglik, n_resets, ll_rows = _general_at_nine(rows, prior,
                                                                             settings)[:8]
    assert fast.n_resets > 0 and len(set(fast.rejected.tolist())) > 3
    assert np.array_equal(fast.xf, xf) and np.array_equal(fast.Pf, Pf)
    for a, b in ((fast.nis, nis), (fast.dof, dof), (fast.rejected, rejected),
                 (fast.ll_rows, ll_rows)):
        assert np.array_equal(a, b, equal_nan=True)
    assert fast.loglik == loglik and fast.n_resets == n_resets
