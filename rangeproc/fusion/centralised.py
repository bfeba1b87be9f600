"""Centralised multi-sensor estimation of one target: all rows through one EKF + RTS smoother.

Stages (each a function of arrays; numerics in the compiled kernels):

1. epochs: the union of row times and output-grid times, so the smoother estimates the state
   exactly at the grid epochs (no interpolation between measurement epochs);
2. noise pre-edit: a-priori sigmas raised to difference-based estimates (``editing.noise``);
3. initialisation from the first position fixes (``fusion.initialise``);
4. process noise: when not configured, the white-jerk PSD is chosen by maximising the
   innovation likelihood over a logarithmic grid (``estimation.tuning``);
5. filter + smoother, residuals; then ``noise_passes`` refinement passes, each one
   re-linearising every measurement at the previous smoothed trajectory (iterated extended
   Kalman smoother, i.e. a Gauss-Newton step on the whole flight: Bell, "The iterated Kalman
   smoother as a Gauss-Newton method", SIAM J. Optim. 1994), and, with ``adapt_noise``,
   re-estimating the noise from the residuals (global and burst-local) and re-selecting the
   process noise.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2

from rangeproc.editing.noise import difference_sigma, residual_sigma
from rangeproc.errors import NumericalError
from rangeproc.estimation.ekf import ekf_forward
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.estimation.rts import rts_smooth
from rangeproc.estimation.tuning import select_process_noise
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.initialise import initial_state

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True, slots=True)
class EstimatorSettings:
    """Settings of the centralised estimator.

    gate_probability: chi-square gate probability per row (dof = measured components).
    noise_passes: refinement passes after the first (re-linearise at the smoothed track and,
        with adapt_noise, re-estimate noise and process noise).
    adapt_noise: estimate noise from the data (difference pre-edit + residual passes).
    process_noise: white-jerk PSD q (m^2/s^5); None = maximum likelihood over ``q_grid``.
    q_grid: candidate q values for the likelihood search.
    reset_after / reset_inflation: divergence guard of the EKF (see ``ekf_forward``).
    """

    gate_probability: float = 0.9999
    noise_passes: int = 2
    adapt_noise: bool = True
    process_noise: float | None = None
    q_grid: tuple[float, ...] = tuple(float(v) for v in np.logspace(-2, 4, 13))
    reset_after: int = 50
    reset_inflation: float = 100.0


@dataclass(frozen=True, slots=True)
class FusionResult:
    """Smoothed estimate of one target and the per-row bookkeeping.

    epoch_t: (E,) s; xs: (E, n); Ps: (E, n(n+1)/2) packed covariance; grid: (E,) bool, True at
    output-grid epochs; batch: the rows with the sigmas finally used; meas_epoch: (N,);
    accepted, nis, dof: (N,) gate results of the final pass; res, hph: (N, 6) smoothed
    residuals and explained variance; q: process noise used; noise: global sigma estimate per
    (sensor index, component); n_resets: divergence-guard resets in the final pass.
    """

    epoch_t: np.ndarray
    xs: np.ndarray
    Ps: np.ndarray
    grid: np.ndarray
    batch: MeasurementBatch
    meas_epoch: np.ndarray
    accepted: np.ndarray
    nis: np.ndarray
    dof: np.ndarray
    res: np.ndarray
    hph: np.ndarray
    q: float
    noise: dict[tuple[int, int], float]
    n_resets: int


def gate_thresholds(probability: float) -> np.ndarray:
    """(7,) chi-square thresholds indexed by degrees of freedom (index 0 unused)."""
    g = np.full(7, np.inf)
    g[1:] = chi2.ppf(probability, np.arange(1, 7))
    return g


def output_grid(t_first: float, t_last: float, rate_hz: float) -> np.ndarray:
    """Uniform grid (s) at ``rate_hz`` on whole multiples of the period within [first, last]."""
    k0 = int(np.ceil(t_first * rate_hz - 1e-9))
    k1 = int(np.floor(t_last * rate_hz + 1e-9))
    return np.arange(k0, k1 + 1, dtype=np.float64) / rate_hz


def _epochs(t_rows: np.ndarray, grid_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    epoch_t = np.union1d(t_rows, grid_t)
    meas_epoch = np.searchsorted(epoch_t, t_rows)
    grid = np.zeros(len(epoch_t), dtype=bool)
    grid[np.searchsorted(epoch_t, grid_t)] = True
    return epoch_t, meas_epoch.astype(np.int64), grid


def _run(batch: MeasurementBatch, epoch_t, meas_epoch, x0, P0, q, gate, st, x_lin):
    try:
        xf, Pf, nis, dof, acc, _, resets = ekf_forward(
            epoch_t, meas_epoch, batch.model, batch.z, batch.sigma, batch.s, batch.sv,
            batch.Qr, batch.sensor, x0, P0, q, gate, st.reset_after, st.reset_inflation, x_lin)
        xs, Ps = rts_smooth(epoch_t, xf, Pf, q)
    except FloatingPointError as exc:
        raise NumericalError(f"estimator failed: {exc}") from exc
    res, hph = smoothed_residuals(meas_epoch, batch.model, batch.z, batch.s, batch.sv,
                                  batch.Qr, xs, Ps)
    return xs, Ps, nis, dof, acc, res, hph, resets


def fuse_target(batch: MeasurementBatch, rate_hz: float,
                settings: EstimatorSettings = EstimatorSettings()) -> FusionResult:
    """Estimate one target's trajectory from its measurement batch (see module docstring)."""
    grid_t = output_grid(float(batch.t[0]), float(batch.t[-1]), rate_hz)
    epoch_t, meas_epoch, grid = _epochs(batch.t, grid_t)
    gate = gate_thresholds(settings.gate_probability)
    if settings.adapt_noise:
        batch = batch.with_sigma(difference_sigma(batch))
    x0, P0 = initial_state(batch, float(epoch_t[0]))

    def choose_q(b: MeasurementBatch, x_lin: np.ndarray) -> float:
        if settings.process_noise is not None:
            return settings.process_noise
        return select_process_noise(b, epoch_t, meas_epoch, x0, P0, gate, settings.q_grid,
                                    settings.reset_after, settings.reset_inflation, x_lin)

    x_lin = np.empty((0, x0.shape[0]))
    q = choose_q(batch, x_lin)
    out = _run(batch, epoch_t, meas_epoch, x0, P0, q, gate, settings, x_lin)
    noise: dict[tuple[int, int], float] = {}
    for p in range(settings.noise_passes):
        xs, Ps, nis, dof, acc, res, hph, _ = out
        x_lin = xs
        if settings.adapt_noise:
            sigma, noise = residual_sigma(batch, res, hph, acc)
            batch = batch.with_sigma(sigma)
            q = choose_q(batch, x_lin)
        log.info("pass %d: q = %.3g m^2/s^5", p + 2, q)
        out = _run(batch, epoch_t, meas_epoch, x0, P0, q, gate, settings, x_lin)
    xs, Ps, nis, dof, acc, res, hph, resets = out
    return FusionResult(epoch_t=epoch_t, xs=xs, Ps=Ps, grid=grid, batch=batch,
                        meas_epoch=meas_epoch, accepted=acc, nis=nis, dof=dof, res=res,
                        hph=hph, q=q, noise=noise, n_resets=resets)
