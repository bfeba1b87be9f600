"""Seed 004's maneuver-norm constraint: the step against a brute-force constrained
minimisation, and the constrained smoother on a constant-thrust target."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from rangeproc.estimation.constraint import (
    CONSTRAINT_SIGMA_FRACTION,
    MANEUVER,
    estimate_norm,
    norm_update,
)
from rangeproc.fusion.batch import MeasurementBatch, SensorRows, empty_rows, merge
from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.models.measurement import CARTESIAN
from rangeproc.settings import ProcessingSettings


@pytest.mark.parametrize("seed, rho", [(1, 2.0), (2, 0.5), (3, 7.0)])
def test_constraint_step_equals_brute_force_minimisation(seed: int, rho: float) -> None:
    """The update is the minimum of (x - x^-)^T P^-1 (x - x^-) on u^T d = rho (u the unit
    direction at the linearisation point), up to the constraint's own tiny noise."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(9, 9))
    P = A @ A.T + np.eye(9)
    x_prior = rng.normal(size=9) * 3.0
    x, Pc = x_prior.copy(), P.copy()
    assert norm_update(x, Pc, x_prior.copy(), rho, np.empty(9))
    d = slice(MANEUVER, MANEUVER + 3)
    u = x_prior[d] / np.linalg.norm(x_prior[d])
    W = np.linalg.inv(P)
    best = minimize(lambda v: (v - x_prior) @ W @ (v - x_prior), x_prior, method="SLSQP",
                    constraints=[{"type": "eq", "fun": lambda v: u @ v[d] - rho}],
                    options={"ftol": 1e-15, "maxiter": 500})
    assert best.success, best.message
    tol = 50 * CONSTRAINT_SIGMA_FRACTION * rho
    np.testing.assert_allclose(x, best.x, atol=tol)
    assert u @ x[d] == pytest.approx(rho, abs=tol)
    assert np.all(np.linalg.eigvalsh(Pc) > 0)                  # still positive definite


def test_norm_estimate_only_when_the_magnitude_is_constant() -> None:
    rng = np.random.default_rng(7)
    turn = np.linspace(0.0, 1.0, 200)
    const = 5.0 * np.column_stack([np.cos(turn), np.sin(turn), 0 * turn])
    const += rng.normal(0.0, 0.05, const.shape)
    assert estimate_norm(const) == pytest.approx(5.0, rel=0.02)
    assert estimate_norm(const * np.linspace(0.2, 2.0, 200)[:, None]) is None
    assert estimate_norm(np.zeros((50, 3))) is None


def thrust_case(seed: int, growth: float = 0.0
                ) -> tuple[MeasurementBatch, np.ndarray, np.ndarray, np.ndarray]:
    """A target under an 8 m/s^2 thrust whose direction turns slowly (seed 004's experiment;
    ``growth`` > 0 makes the magnitude grow by that many m/s^2 per minute), seen by a GPS-like
    position sensor (sigma 5 m, 2 Hz) for 120 s. Returns the batch and the truth (t,
    position, acceleration) at 100 Hz."""
    rng = np.random.default_rng(seed)
    dt = 0.01
    t = np.arange(0.0, 120.0 + dt / 2, dt)
    ang = 0.02 * t
    mag = 8.0 + growth * t / 60.0
    acc = mag[:, None] * np.column_stack([np.cos(ang), np.sin(ang), 0.0 * t])
    vel = np.array([300.0, 0.0, 50.0]) + np.cumsum(acc, axis=0) * dt
    pos = np.cumsum(vel, axis=0) * dt
    keep = np.arange(0, t.size, 50)
    a = empty_rows(keep.size, CARTESIAN)
    a["z"][:, :3] = pos[keep] + rng.normal(0.0, 5.0, (keep.size, 3))
    a["sigma"][:, :3] = 5.0
    rows = SensorRows(t=t[keep], source_row=np.arange(keep.size),
                      station=np.full(keep.size, -1), track=np.full(keep.size, -1), **a)
    return merge([(0, rows)], ("G1",)), t, pos, acc


def smoothed_errors(settings: EstimatorSettings, seed: int) -> tuple[float, float, object]:
    batch, t, pos, acc = thrust_case(seed)
    res = fuse_target(batch, 2.0, settings)
    g = res.grid
    k = np.searchsorted(t, res.epoch_t[g] - 1e-9)
    ea = float(np.sqrt(np.mean(np.sum((res.xs[g][:, 6:9] - acc[k]) ** 2, 1))))
    ep = float(np.sqrt(np.mean(np.sum((res.xs[g][:, 0:3] - pos[k]) ** 2, 1))))
    return ea, ep, res


@pytest.mark.parametrize("seed", [3, 4])
def test_constrained_askf_beats_the_unconstrained_on_a_constant_thrust(seed: int) -> None:
    """Seed 004's claim, offline: the norm-constrained smoother tracks a constant-magnitude,
    slowly turning thrust better than the unconstrained one, with the norm given or
    estimated, and stays consistent."""
    ea_ekf, ep_ekf, _ = smoothed_errors(EstimatorSettings(), seed)
    for p in (ProcessingSettings(filter="askf", maneuver_norm=8.0),
              ProcessingSettings(filter="askf")):
        st = EstimatorSettings(processing=p)
        ea, ep, res = smoothed_errors(st, seed)
        assert res.maneuver_norm == pytest.approx(8.0, rel=0.01)
        assert ea < 0.85 * ea_ekf, (ea, ea_ekf)
        assert ep < 0.95 * ep_ekf, (ep, ep_ekf)
        norms = np.linalg.norm(res.xs[res.grid][:, 6:9], axis=1)
        assert np.median(np.abs(norms - res.maneuver_norm)) < 0.005   # the constraint holds


def test_askf_without_a_usable_norm_is_the_unconstrained_filter() -> None:
    """A maneuver whose magnitude grows from 8 to 20 m/s^2: no usable norm, the EKF exactly."""
    batch = thrust_case(5, growth=6.0)[0]
    plain = fuse_target(batch, 2.0,
                        EstimatorSettings(processing=ProcessingSettings(noise_passes=1)))
    askf = fuse_target(batch, 2.0, EstimatorSettings(
        processing=ProcessingSettings(noise_passes=1, filter="askf")))
    assert askf.maneuver_norm is None
    np.testing.assert_array_equal(plain.xs, askf.xs)


def test_a_norm_the_data_reject_is_dropped(caplog) -> None:
    """A given norm 5 % high cannot be met by turning the maneuver: the data reject it (misfit
    beyond the noise level), the constraint is dropped with a warning and the result is the
    unconstrained filter exactly; the right norm on the same data is kept."""
    batch = thrust_case(3)[0]
    plain = fuse_target(batch, 2.0, EstimatorSettings())
    with caplog.at_level("WARNING"):
        wrong = fuse_target(batch, 2.0, EstimatorSettings(
            processing=ProcessingSettings(filter="askf", maneuver_norm=8.4)))
    assert wrong.maneuver_norm is None
    assert "reject the maneuver norm 8.4" in caplog.text
    np.testing.assert_array_equal(plain.xs, wrong.xs)
    right = fuse_target(batch, 2.0, EstimatorSettings(
        processing=ProcessingSettings(filter="askf", maneuver_norm=8.0)))
    assert right.maneuver_norm == 8.0
