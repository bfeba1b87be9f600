"""Long spans: the hyperparameter passes on a thinned subset of the rows, the final pass on all.

A long sortie's passes before the last one exist to find hyperparameters: the process-noise
profile, the measurement noise, the sensors' calibration and the track to linearise at. Each
of them is a statistic over many rows, so an evenly thinned subset that keeps every sensor
finds them nearly as well at a fraction of the cost; the final filter + smoother pass, whose
track and covariance are the product, always runs on every row. The rule, with its
parameters:

* a span thins only when it has more than :data:`THIN_ABOVE_ROWS` rows and at least one
  refinement pass (``noise_passes >= 1``); shorter spans use every row in every pass;
* each series (sensor x MISTRAM station x sensor track) keeps every ``k``-th row, its first
  and its last, with ``k = floor(N / THIN_TARGET_ROWS)`` for all of them alike, but never so
  few that the series drops below :data:`MIN_THIN_RATE_HZ` rows per second of its own span
  (or keeps under :data:`MIN_SERIES_ROWS` rows): a slow sensor is thinned less or not at all;
* the thinned passes run on the same output grid, so the registration's nodes and the
  process-noise profile are estimated at the same epochs.

Before the final pass :func:`expand` carries the last thinned pass to every row: the smoothed
track at every epoch (:func:`track_at`: the constant-acceleration prediction from the thinned
epochs on either side, blended linearly in time: the two agree to the jerk's
``j dt^3 / 6``, micrometres at the thinned steps of a tenth of a second), each row's residual
against it, the covariance of the nearest thinned epoch for the explained variance, and the
gate's verdict per component. Rows the thinned smoother did not use are independent of its
track, so their residual variance is ``sigma^2 + H P H^T`` rather than ``sigma^2 - H P H^T``:
their explained variance enters the noise estimate with a negative sign
(``fusion.noise.residual_sigma``). The last registration solve, the noise estimate and the
final pass then run on every row, so the calibration's covariance is the full data's.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from rangeproc.estimation.registration import LATENCY_SLOT
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.estimation.tuning import local_process_noise
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.fusion.passes import PassResult
from rangeproc.fusion.refraction_rows import refraction_corrections
from rangeproc.fusion.registration import (
    Calibration,
    apply_increments,
    nearest_index,
    row_rates,
)

#: Spans with at most this many rows use every row in every pass.
THIN_ABOVE_ROWS = 400_000
#: Rows the thinned passes aim at (every series thinned by the same stride).
THIN_TARGET_ROWS = 200_000
#: Least rows per second a thinned series keeps over its own span.
MIN_THIN_RATE_HZ = 5.0
#: Least rows a thinned series keeps (the noise estimate's running windows need them).
MIN_SERIES_ROWS = 400
#: Rows per block when residuals are computed at the expanded track (bounds the memory).
BLOCK_ROWS = 262_144


class PassRows(NamedTuple):
    """The rows a pass runs on and their epochs.

    batch: the rows; epoch_t (E,) s, meas_epoch (N,), grid (E,) bool as
    :meth:`of` builds them; kept: (N,) indices of these rows in the
    span's full batch, None when they are every row.
    """

    batch: MeasurementBatch
    epoch_t: np.ndarray
    meas_epoch: np.ndarray
    grid: np.ndarray
    kept: np.ndarray | None = None

    @classmethod
    def of(cls, batch: MeasurementBatch, grid_t: np.ndarray,
           kept: np.ndarray | None = None) -> PassRows:
        """The rows of ``batch`` with their epochs: the union of row times and output-grid
        times ``grid_t`` (s), so the smoother estimates the state exactly at the grid."""
        epoch_t = np.union1d(batch.t, grid_t)
        grid = np.zeros(len(epoch_t), dtype=bool)
        grid[np.searchsorted(epoch_t, grid_t)] = True
        return cls(batch, epoch_t, np.searchsorted(epoch_t, batch.t).astype(np.int64), grid,
                   kept)


def thinning_stride(n_rows: int, noise_passes: int) -> int:
    """The common stride of a span of ``n_rows`` rows (1: every row)."""
    if noise_passes < 1 or n_rows <= THIN_ABOVE_ROWS:
        return 1
    return max(1, n_rows // THIN_TARGET_ROWS)


def thinned_rows(batch: MeasurementBatch, stride: int) -> np.ndarray:
    """Sorted indices of the rows the thinned passes keep (see the module docstring)."""
    return batch.thinned(stride, MIN_THIN_RATE_HZ, MIN_SERIES_ROWS)


def track_at(epoch_t: np.ndarray, xs: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(M, n) the smoothed track ``xs`` (E, n) at epochs ``epoch_t`` (E,) s, carried to times
    ``t`` (M,) s inside them: the constant-acceleration prediction from the epoch before and
    from the epoch after, weighted linearly in time (exact at the epochs; states beyond the
    ninth, constants, are interpolated linearly)."""
    b = np.clip(np.searchsorted(epoch_t, t, side="left"), 1, len(epoch_t) - 1)
    a = b - 1
    span = epoch_t[b] - epoch_t[a]
    w = np.where(span > 0, (t - epoch_t[a]) / np.where(span > 0, span, 1.0), 0.0)[:, None]
    return (1.0 - w) * _carried(xs[a], t - epoch_t[a]) + w * _carried(xs[b], t - epoch_t[b])


def _carried(x: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """States ``x`` (M, n) predicted by the CA model over ``dt`` (M,) s."""
    out = x.copy()
    d = dt[:, None]
    out[:, 0:3] += d * x[:, 3:6] + 0.5 * d * d * x[:, 6:9]
    out[:, 3:6] += d * x[:, 6:9]
    return out


def steps_at(epoch_t: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(M,) the per-step white-jerk PSD ``q`` (E,) of epochs ``epoch_t`` for the steps ending
    at times ``t`` (M,): each finer step takes the coarse step that contains it."""
    return q[np.clip(np.searchsorted(epoch_t, t, side="left"), 0, len(epoch_t) - 1)]


class Expanded(NamedTuple):
    """The last thinned pass carried to every row (:func:`expand`).

    xs: (E, n) the track at every epoch of the full rows; Ps: the thinned pass's packed
    covariances, ``ps_epoch`` (E,) the index of each epoch's nearest thinned epoch in them.
    """

    xs: np.ndarray
    Ps: np.ndarray
    ps_epoch: np.ndarray

    def residuals(self, batch: MeasurementBatch, meas_epoch: np.ndarray,
                  rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Residuals and explained variance (R, 6) of ``rows`` (indices; None: all) of the full
        ``batch`` at this track, computed in blocks of :data:`BLOCK_ROWS` rows."""
        n = len(batch) if rows is None else len(rows)
        res = np.empty((n, 6))
        hph = np.empty((n, 6))
        for lo in range(0, n, BLOCK_ROWS):     # every row: slices (views), not row copies
            r = slice(lo, min(lo + BLOCK_ROWS, n)) if rows is None \
                else np.asarray(rows)[lo:lo + BLOCK_ROWS]
            e = meas_epoch[r]
            res[lo:lo + len(e)], hph[lo:lo + len(e)] = smoothed_residuals(
                np.arange(len(e), dtype=np.int64), batch.model[r], batch.z[r], batch.s[r],
                batch.sv[r], batch.Qr[r], np.ascontiguousarray(self.xs[e]),
                np.ascontiguousarray(self.Ps[self.ps_epoch[e]]))
        return res, hph


def expand(thin: PassRows, xs: np.ndarray, Ps: np.ndarray, full_epoch_t: np.ndarray
           ) -> Expanded:
    """The thinned pass's smoothed track ``xs`` and covariances ``Ps`` (on ``thin``'s epochs)
    carried to the full rows' epochs ``full_epoch_t`` (E,) s."""
    x = track_at(thin.epoch_t, xs, full_epoch_t)
    return Expanded(x, Ps, nearest_index(thin.epoch_t, full_epoch_t))


def gate_use(res: np.ndarray, hph: np.ndarray, sigma: np.ndarray, threshold: float
             ) -> np.ndarray:
    """(N, 6) bool: measured components whose residual ``res`` passes the one-component gate
    ``res^2 <= threshold (sigma^2 + hph)`` (the verdict for rows the thinned filter never
    gated; ``hph`` >= 0 their prediction's variance)."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(res) & (res * res <= threshold * (sigma * sigma + hph))


def independent_rows(n_rows: int, kept: np.ndarray) -> np.ndarray:
    """(N,) bool: rows of the full batch the thinned passes did not use."""
    out = np.ones(n_rows, dtype=bool)
    out[kept] = False
    return out


def thinned_pass_rows(full: PassRows, grid_t: np.ndarray, noise_passes: int) -> PassRows:
    """The rows of the passes before the last: every row, or on a long span an evenly
    thinned subset (``fusion.thinning``) on the same output grid."""
    stride = thinning_stride(len(full.batch), noise_passes)
    if stride == 1:
        return full
    kept = thinned_rows(full.batch, stride)
    return PassRows.of(full.batch.rows(kept), grid_t, kept)


def carry_to_every_row(full: PassRows, thin: PassRows, out: PassResult, q_used: np.ndarray,
                  noise: dict[tuple[int, int], float], cal: Calibration | None,
                  settings, gate: np.ndarray):
    """Carry the last thinned pass ``out`` (on ``thin``'s rows, with process noise
    ``q_used``) to every row of ``full`` before the final pass (``fusion.thinning``).

    The full rows get the refraction and the calibration found so far, their residuals at
    the carried track, and the gate's verdict (the thinned filter's for its own rows; for
    the others the one-component gate with the noise estimated so far, ``noise``).
    ``settings``: the estimator's (``fusion.estimator_types.EstimatorSettings``: its
    ``processing``, ``refraction``, ``calibration``, ``q_window`` and ``q_grid``); ``gate``
    (7,) the chi-square thresholds.

    Returns: the carried track (:class:`Expanded`), the corrected full batch, the pass
    result on every row, the full batch with the sigmas of the pass before (to redo that
    pass on every row), its process noise and the final pass's (from the thinned pass's EM
    statistic; None without one), both (E,).
    """
    p = settings.processing
    expanded = expand(thin, out.xs, out.Ps, full.epoch_t)
    b = full.batch
    if settings.refraction is not None:
        b = refraction_corrections(b, expanded.xs, full.meas_epoch, settings.refraction)
    if cal is not None and cal.applied.any():
        latency = any(t.slot == LATENCY_SLOT and a != 0.0
                      for t, a in zip(cal.terms, cal.applied))
        rate = row_rates(b, expanded.xs, full.epoch_t, full.meas_epoch, full.grid,
                         settings.calibration, cal.terms) if latency else None
        b = apply_increments(b, cal.terms, cal.applied,
                             rate if rate is not None else np.zeros((len(b), 4)))
    res, hph = expanded.residuals(b, full.meas_epoch)
    sigma = b.sigma.copy()
    for sensor in dict.fromkeys(s for s, _ in noise):     # one row mask per sensor
        at = b.sensor == sensor
        for (s, c), value in noise.items():
            if s == sensor:
                sigma[at, c] = value
    used = gate_use(res, hph, sigma, float(gate[1]))
    used[thin.kept] = out.used
    hph[independent_rows(len(b), thin.kept)] *= -1.0   # not in the thinned smoother's data
    q_full = steps_at(thin.epoch_t, q_used, full.epoch_t)
    q_next = None
    if p.process_noise is None and out.em is not None:
        q_next = steps_at(thin.epoch_t, local_process_noise(
            thin.epoch_t, out.em, window=settings.q_window, ceiling=max(settings.q_grid)),
            full.epoch_t)
    n = len(b)
    result = PassResult(expanded.xs, expanded.Ps, None, np.full(n, np.nan),
                        np.zeros(n, dtype=np.int64), used, res, hph, out.resets, b)
    return expanded, b, result, b.with_sigma(sigma), q_full, q_next
