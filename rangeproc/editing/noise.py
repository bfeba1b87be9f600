"""Measurement-noise estimation from the data itself (a-priori sigmas may be wrong).

Two estimators, both robust to wild points (median based):

* :func:`difference_sigma` before any filtering: the third difference of a smooth signal
  sampled fast is tiny, so ``sigma ~= 1.4826 MAD(diff3) / sqrt(20)`` (``Var(d3 eps) = 20 s^2``
  for white noise). It only ever *raises* the a-priori sigma for the first pass (at low sample
  rates the signal's own jerk would inflate it), which protects the first pass from stated
  sigmas that are far too small.
* :func:`residual_sigma` after smoothing: per sensor and component, a global robust scale of
  the post-fit residuals corrected for the fitted part (``E[res^2] = sigma^2 - H P_s H^T``), and
  a local (running-median) scale that follows noise bursts, jamming or multipath: where the
  local scale exceeds the global one by ``burst_ratio`` the row gets the local sigma. This is the
  residual-RMS adaptation of seed 000 sec. 2.3.1, done as a smoother-based, windowed estimate.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import median_filter

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH, N_COMPONENTS, SPHERICAL

MAD_TO_SIGMA = 1.482602218505602
MIN_ROWS = 20


def _groups(batch: MeasurementBatch) -> list[np.ndarray]:
    """Row indices (time ordered) of each independent series: sensor x station x track."""
    key = (batch.sensor * 1_000_003 + (batch.station + 1)) * 1_000_003 + (batch.track + 1)
    order = np.argsort(key, kind="stable")          # stable keeps time order within a key
    ks = key[order]
    cuts = np.flatnonzero(np.diff(ks)) + 1
    return [g for g in np.split(order, cuts) if len(g) > 0]


def difference_sigma(batch: MeasurementBatch) -> np.ndarray:
    """Per-row sigma (N, 6): the a-priori sigma raised to the third-difference noise estimate.

    Differences are taken only over runs of near-uniform sampling (no step longer than 1.5x the
    series' median step), so gaps do not count as noise.
    """
    sigma = batch.sigma.copy()
    for rows in _groups(batch):
        if len(rows) < MIN_ROWS:
            continue
        t = batch.t[rows]
        dt = np.diff(t)
        pos = dt[dt > 0]
        if len(pos) == 0:
            continue
        step = np.median(pos)
        regular = (dt > 0) & (dt < 1.5 * step)
        ok3 = regular[:-2] & regular[1:-1] & regular[2:]
        for c in range(N_COMPONENTS):
            v = batch.z[rows, c]
            if np.isnan(v).all():
                continue
            if batch.model[rows[0]] == SPHERICAL and c == AZIMUTH:
                v = np.where(np.isnan(v), np.nan, np.unwrap(np.nan_to_num(v)))
            d3 = np.diff(v, 3)[ok3]
            d3 = d3[np.isfinite(d3)]
            if len(d3) < MIN_ROWS:
                continue
            est = MAD_TO_SIGMA * np.median(np.abs(d3 - np.median(d3))) / np.sqrt(20.0)
            sigma[rows, c] = np.maximum(sigma[rows, c], est)
    return sigma


def residual_sigma(batch: MeasurementBatch, res: np.ndarray, hph: np.ndarray,
                   accepted: np.ndarray, *, window: int = 101,
                   burst_ratio: float = 1.5) -> tuple[np.ndarray, dict[tuple[int, int], float]]:
    """Re-estimate per-row sigmas from smoothed residuals.

    Args:
        batch: the batch (its ``sigma`` is the fallback where data are too few).
        res, hph: (N, 6) from :func:`rangeproc.estimation.residuals.smoothed_residuals`.
        accepted: (N,) rows the gate accepted (the global scale uses these only).
        window: rows in the running-median window of the local scale.
        burst_ratio: local/global scale ratio above which a row takes the local scale.

    Returns:
        sigma (N, 6) and the global estimate per (sensor index, component).
    """
    sigma = batch.sigma.copy()
    found: dict[tuple[int, int], float] = {}
    for sensor in np.unique(batch.sensor):
        rows = np.flatnonzero(batch.sensor == sensor)
        for c in range(N_COMPONENTS):
            r = res[rows, c]
            have = np.isfinite(r)
            used = have & accepted[rows]
            if used.sum() < MIN_ROWS:
                continue
            ru = r[used]
            scale = MAD_TO_SIGMA * np.median(np.abs(ru - np.median(ru)))
            var = scale ** 2 + np.median(hph[rows[used], c])
            glob = float(np.sqrt(var))
            found[(int(sensor), c)] = glob
            sig = np.full(len(rows), glob)
            idx = np.flatnonzero(have)
            if len(idx) >= window:
                local = MAD_TO_SIGMA * median_filter(np.abs(r[idx]), size=window, mode="nearest")
                local = np.sqrt(local ** 2 + hph[rows[idx], c])
                burst = local > burst_ratio * glob
                sig[idx[burst]] = local[burst]
            sigma[rows, c] = sig
    return sigma, found
