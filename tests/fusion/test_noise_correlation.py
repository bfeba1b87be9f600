"""Errors correlated in time: the lag-1 correlation of a sensor's residuals and the information
discount it earns (``fusion.noise``), against seeded AR(1) sequences of known correlation."""
from __future__ import annotations

import numpy as np
import pytest

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.noise import (
    RHO_MAX,
    RHO_MIN,
    correlation_discount,
    correlation_factors,
    discounted_sigma,
    lag_correlation,
    residual_sigma,
)
from rangeproc.models.measurement import SPHERICAL


def _ar1(rho: float, n: int, seed: int, sigma: float = 1.0) -> np.ndarray:
    """A stationary AR(1) sequence (n,) of lag-1 correlation ``rho`` and sigma ``sigma``."""
    rng = np.random.default_rng(seed)
    e = rng.normal(0.0, sigma * np.sqrt(1.0 - rho**2), n)
    x = np.empty(n)
    x[0] = rng.normal(0.0, sigma)
    for k in range(1, n):
        x[k] = rho * x[k - 1] + e[k]
    return x


@pytest.mark.parametrize("rho", [0.0, 0.5, 0.85])
def test_lag_correlation_of_ar1_sequences(rho):
    t = 0.2 * np.arange(2000)
    got = [lag_correlation(t, _ar1(rho, t.size, s), np.ones(t.size, bool)) for s in range(5)]
    assert np.mean(got) == pytest.approx(rho, abs=0.03)


def test_lag_correlation_skips_gaps_and_unused_rows():
    t = 0.2 * np.arange(400)
    u = np.where(np.arange(400) % 2 == 0, 1.0, -1.0)       # alternating: rho = -1
    assert lag_correlation(t, u, np.ones(400, bool)) == pytest.approx(-1.0)
    keep = np.arange(400) % 2 == 0                          # the even rows only: 0.4 s apart
    ramp = np.where(keep, np.linspace(-1.0, 1.0, 400), -u)  # a slow drift there
    assert lag_correlation(t, ramp, keep) > 0.95
    assert lag_correlation(t, u + 5.0, np.ones(400, bool)) == pytest.approx(-1.0)  # a bias
    t_gappy = np.cumsum(np.r_[0.2, np.full(29, 0.2)] * np.r_[1, np.tile([1, 50], 14), 1])
    assert lag_correlation(t_gappy, u[:30], np.ones(30, bool)) == 0.0    # too few pairs


def test_discount_is_the_ar1_variance_ratio():
    assert correlation_discount(0.0) == 1.0 and correlation_discount(RHO_MIN) == 1.0
    assert correlation_discount(0.8) == pytest.approx(np.sqrt(1.8 / 0.2))
    assert correlation_discount(0.999) == pytest.approx(np.sqrt((1 + RHO_MAX) / (1 - RHO_MAX)))
    # the variance of the mean of n AR(1) samples over that of n white ones -> (1+rho)/(1-rho)
    n, rho = 400, 0.8
    means = [_ar1(rho, n, s).mean() for s in range(400)]
    assert np.var(means) * n == pytest.approx(correlation_discount(rho) ** 2, rel=0.2)


def _batch(res_az: np.ndarray) -> MeasurementBatch:
    """One camera's azimuth rows at 5 Hz with a-priori sigma 1 mrad."""
    n = res_az.size
    z = np.full((n, 6), np.nan)
    z[:, 1] = 0.1
    sigma = np.full((n, 6), 1e-3)
    return MeasurementBatch(0.2 * np.arange(n), np.full(n, SPHERICAL), z, sigma,
                            np.zeros((n, 3)), np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)),
                            np.zeros(n, np.int64), np.arange(n), np.full(n, -1),
                            np.full(n, -1), ("EO",))


@pytest.mark.parametrize("rho, inflated", [(0.0, False), (0.85, True)])
def test_residual_sigma_discounts_correlated_rows_only(rho, inflated):
    r = np.full((600, 6), np.nan)
    r[:, 1] = 2e-3 * _ar1(rho, 600, 7)
    used = np.isfinite(r)
    sigma, found, _ = residual_sigma(_batch(r[:, 1]), r, np.zeros_like(r), used)
    glob = found[(0, 1)]
    assert glob == pytest.approx(2e-3, rel=0.15)           # the white estimate is unchanged
    typical = np.median(sigma[:, 1]) / glob
    if inflated:
        want = correlation_discount(lag_correlation(0.2 * np.arange(600), r[:, 1] / glob,
                                                    np.ones(600, bool)))
        assert want > 3.0 and typical == pytest.approx(want, rel=0.1)
    else:
        assert typical == pytest.approx(1.0, abs=1e-12)


def test_first_pass_factors_name_the_correlated_component_only():
    """Two cameras in one batch, one with AR(1) bearing errors (0.85), one white: only the
    first earns a factor, the AR(1) variance ratio of its residuals' correlation, and only its
    rows' azimuth sigma carries it."""
    n = 600
    a, b = _batch(np.zeros(n)), _batch(np.zeros(n))
    both = MeasurementBatch(np.r_[a.t, b.t], np.r_[a.model, b.model], np.r_[a.z, b.z],
                            np.r_[a.sigma, b.sigma], np.r_[a.s, b.s], np.r_[a.sv, b.sv],
                            np.r_[a.Qr, b.Qr], np.r_[np.zeros(n, np.int64), np.ones(n, np.int64)],
                            np.r_[a.source_row, b.source_row], np.r_[a.station, b.station],
                            np.r_[a.track, b.track], ("EO", "IR"))
    r = np.full((2 * n, 6), np.nan)
    r[:n, 1] = 2e-3 * _ar1(0.85, n, 3)
    r[n:, 1] = 2e-3 * _ar1(0.0, n, 4)
    factors = correlation_factors(both, r, np.isfinite(r))
    assert list(factors) == [(0, 1)]
    rho = lag_correlation(both.t[:n], r[:n, 1], np.ones(n, bool))
    assert factors[(0, 1)] == pytest.approx(correlation_discount(rho)) and factors[(0, 1)] > 3.0
    sigma = discounted_sigma(both, factors)
    assert np.allclose(sigma[:n, 1], 1e-3 * factors[(0, 1)])
    others = np.ones(sigma.shape, bool)
    others[:n, 1] = False
    assert np.array_equal(sigma[others], both.sigma[others])


def test_summary_shows_each_sensors_correlation(sample_run, tmp_path):
    """The sample's white errors earn no discount (the aircraft kinds are left alone); the
    harbour kind's camera, whose bearing errors are AR(1) with lag-1 correlation 0.8-0.9, is
    discounted, and summary.json says so."""
    import json

    from conftest import invoke

    from rangeproc.simulate.harbour import simulate_harbour

    sample = json.loads((sample_run.out_dir / "summary.json").read_text())
    for s in sample["sensors"].values():
        for n in (s.get("noise") or {}).values():
            assert n["correlation"] <= RHO_MIN and n["discount"] == 1.0
    config = simulate_harbour(tmp_path / "harbour", seed=3, duration=120.0)
    res = invoke(["run", "--quiet", str(config)])
    assert res.exit_code == 0, res.output
    out = config.parent / "out" / "summary.json"
    eo = json.loads(out.read_text())["sensors"]["EO"]["noise"]["azimuth"]
    assert eo["correlation"] > RHO_MIN and eo["discount"] > 1.5
