"""Measurement-noise estimation from the data itself (a-priori sigmas may be wrong).

Two estimators, both robust to wild points (median based):

* :func:`difference_sigma` before any filtering: the third difference of a smooth signal
  sampled fast is tiny, so ``sigma ~= 1.4826 MAD(diff3) / sqrt(20)`` (``Var(d3 eps) = 20 s^2``
  for white noise). It only ever *raises* the a-priori sigma for the first pass (at low sample
  rates the signal's own jerk would inflate it), which protects the first pass from stated
  sigmas that are far too small.
* :func:`residual_sigma` after smoothing: per sensor and component, a global scale of the
  post-fit residuals (RMS clipped at 4 robust sigmas, bursts excluded) corrected for the fitted
  part (``E[res^2] = sigma^2 - H P_s H^T``), and
  a local (running-median) scale that follows noise bursts, jamming or multipath: where the
  local scale exceeds the global one by ``burst_ratio`` the row gets the local sigma (the local
  scale is dilated over a quarter window so the edges of a short burst are covered too). This is
  the residual-RMS adaptation of Zhou et al. 2001 sec. 2.3.1, done as a smoother-based, windowed
  estimate.
  Errors correlated in time (the returns of an extended object coming from the side the
  sensor sees for a while, a camera's slowly varying bearing error) carry less information
  than as many white ones: where the lag-1 correlation ``rho`` of a sensor's normalised
  residuals (consecutive rows of one object, :func:`lag_correlation`) exceeds ``RHO_MIN``,
  its sigma is multiplied by ``sqrt((1 + rho) / (1 - rho))`` (:func:`correlation_discount`,
  ``rho`` at most ``RHO_MAX``): the variance of the mean of an AR(1) sequence of lag-1
  correlation ``rho`` over many samples is ``(1 + rho) / (1 - rho)`` times that of as many
  independent ones (Bryson and Henrikson 1968 treat such errors as a Gauss-Markov state; this
  is the information discount that leaves the state alone, cf. Petovello et al. 2009), so the
  smoother credits the rows with what they are worth. White residuals (point targets, a
  tracking radar's noise) have ``rho`` near 0 and are left alone.
  Finally each row is down-weighted by Huber's rule (weight ``min(1, k / |u|)`` for the
  normalised residual ``u``, i.e. sigma times ``sqrt(|u| / k)``), the M-estimation answer to
  residuals that are large but not wild; gross outliers are still rejected by the gate.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d, median_filter

from rangeproc.editing.robust import MAD_TO_SIGMA
from rangeproc.fusion.assemble import assumed_elevation
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH, ELEVATION, N_COMPONENTS, SPHERICAL

#: Codes of :func:`residual_sigma`'s down-weighting reasons.
BURST, HUBER = 1, 2
#: Huber's threshold on the normalised residual (global sigmas): weight ``min(1, k / |u|)``.
HUBER_K = 2.0
MIN_ROWS = 20


def difference_sigma(batch: MeasurementBatch) -> np.ndarray:
    """Per-row sigma (N, 6): the a-priori sigma raised to the third-difference noise estimate.

    Differences are taken only over runs of near-uniform sampling (no step longer than 1.5x the
    series' median step), so gaps do not count as noise.
    """
    sigma = batch.sigma.copy()
    for rows in batch.series():
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
                   used: np.ndarray, *, window: int = 51, burst_ratio: float = 2.0,
                   huber_k: float = HUBER_K
                   ) -> tuple[np.ndarray, dict[tuple[int, int], float], np.ndarray]:
    """Re-estimate per-row sigmas from smoothed residuals.

    Args:
        batch: the batch (its ``sigma`` is the fallback where data are too few).
        res, hph: (N, 6) from :func:`rangeproc.estimation.residuals.smoothed_residuals`;
            for a row the smoother did not use (``fusion.thinning``) its residual variance is
            ``sigma^2 + H P H^T``, and ``hph`` is then given negated.
        used: (N, 6) components the gate accepted (the global scale uses these only).
        window: rows in the running-median window of the local scale.
        burst_ratio: local/global scale ratio above which a row takes the local scale.
        huber_k: Huber threshold on the normalised residual.

    Returns:
        sigma (N, 6), the global estimate per (sensor index, component), and why (N, 6) int8
        each component's sigma exceeds that global estimate: :data:`BURST` (the local scale
        of a burst), :data:`HUBER` (down-weighted for a large two-sided smoother residual),
        0 (neither; also where data were too few to estimate).
    """
    sigma = batch.sigma.copy()
    why = np.zeros(sigma.shape, dtype=np.int8)
    found: dict[tuple[int, int], float] = {}
    for sensor in np.unique(batch.sensor):
        rows = np.flatnonzero(batch.sensor == sensor)
        # the sensor's rows gathered once (its components are then column views)
        res_s, hph_s, used_s, t_s = res[rows], hph[rows], used[rows], batch.t[rows]
        for c in range(N_COMPONENTS):
            r, h = res_s[:, c], hph_s[:, c]
            have = np.isfinite(r)
            used_c = have & used_s[:, c]
            if used_c.sum() < MIN_ROWS:
                continue
            ru = r[used_c]
            robust = float(np.sqrt(max(
                (MAD_TO_SIGMA * np.median(np.abs(ru - np.median(ru)))) ** 2
                + np.median(h[used_c]), 0.0)))
            sig = np.full(len(rows), robust)
            idx = np.flatnonzero(have)
            burst = np.zeros(len(rows), dtype=bool)
            if len(idx) >= window:
                local = MAD_TO_SIGMA * median_filter(np.abs(r[idx]), size=window, mode="nearest")
                local = np.sqrt(np.maximum(local ** 2 + h[idx], 0.0))
                local = np.where(local > burst_ratio * robust, local, 0.0)
                # dilate by a quarter window: enough to cover the edge rows a centred running
                # median misses, without spreading burst sigmas far onto normal rows
                local = maximum_filter1d(local, size=max(1, window // 4), mode="nearest")
                burst[idx] = local > 0.0
                sig[idx[local > 0.0]] = local[local > 0.0]
            glob = _clipped_rms(r, h, used_c & ~burst, robust)
            found[(int(sensor), c)] = glob
            sig[~burst] = glob
            u = np.abs(np.nan_to_num(r)) / sig
            sig = sig * np.sqrt(np.maximum(1.0, u / huber_k))
            rho = lag_correlation(t_s, r / sig, used_c & ~burst & (u < _CLIP))
            sigma[rows, c] = sig * correlation_discount(rho)
            why[rows[burst], c] = BURST
            why[rows[~burst & (u > huber_k)], c] = HUBER
    return sigma, found, why


#: E[x^2 | |x| < 4] for a standard normal: the clipped RMS is divided by its square root.
_CLIP = 4.0
_CLIP_VAR = 0.998932


def _clipped_rms(r: np.ndarray, hph: np.ndarray, use: np.ndarray, robust: float) -> float:
    """Global sigma: RMS of the used, non-burst residuals inside +-4 robust sigma, corrected
    for the clipping and for the fitted part (hph). MAD alone is biased low when the noise has
    heavier-than-Gaussian (but not wild) tails; the RMS is not, and the clip keeps it robust.
    """
    keep = use & (np.abs(np.nan_to_num(r)) < _CLIP * robust)
    if keep.sum() < MIN_ROWS:
        return robust
    return float(np.sqrt(max(np.mean(r[keep] ** 2) / _CLIP_VAR + np.mean(hph[keep]), 0.0)))


#: A sensor's residual lag-1 correlation above this (smoothed residuals of white noise have
#: |rho| of a few hundredths) discounts its rows' information; at most this correlation is
#: credited (a discount of sqrt(39) = 6.2 in sigma).
RHO_MIN = 0.3
RHO_MAX = 0.95


def lag_correlation(t: np.ndarray, u: np.ndarray, use: np.ndarray) -> float:
    """Lag-1 correlation (dimensionless) of the normalised residuals u (N,) of consecutive
    rows (times t (N,) s ascending) no more than 1.5 median steps apart, over the rows
    ``use`` (N,) bool: ``sum v_k v_k+1 / sqrt(sum v_k^2 sum v_k+1^2)`` with ``v`` the residuals
    less their mean (a constant bias, a registration's business, is no correlation in time);
    0 with fewer than ``MIN_ROWS`` such pairs."""
    idx = np.flatnonzero(use & np.isfinite(u))
    if idx.size < MIN_ROWS:
        return 0.0
    dt = np.diff(t[idx])
    pos = dt[dt > 0]
    if pos.size == 0:
        return 0.0
    ok = (dt > 0) & (dt <= 1.5 * np.median(pos))
    v = u[idx] - np.mean(u[idx])           # a constant bias is not a correlation in time
    a, b = v[:-1][ok], v[1:][ok]
    if a.size < MIN_ROWS:
        return 0.0
    den = np.sqrt(np.sum(a * a) * np.sum(b * b))
    return float(np.sum(a * b) / den) if den > 0 else 0.0


def correlation_factors(batch: MeasurementBatch, res: np.ndarray, used: np.ndarray
                        ) -> dict[tuple[int, int], float]:
    """The correlation discount (sigma factor > 1) of each (sensor index, component) whose
    residuals ``res`` (N, 6) over the accepted components ``used`` (N, 6) have a lag-1
    correlation above ``RHO_MIN`` (:func:`lag_correlation` of ``res / sigma``,
    :func:`correlation_discount`); components with white residuals are not listed.

    Used on the first pass (``fusion.centralised``): the process-noise search and the first
    pass take errors as white, so a camera's slowly varying bearing error, or the returns of
    the side of a hull a sensor sees for a while, read as manoeuvre; the likelihood then asks
    for a process noise that lets the track follow them, and between the sparse rows that fix
    position the track leaves the object. A 2-D radar's assumed elevation
    (``fusion.assemble.assumed_elevation``) is left out: its residual is the object's height
    above the sensor's tilted plane, slow by nature, and a discount would free the height the
    assumption is there to hold."""
    out: dict[tuple[int, int], float] = {}
    assumed = assumed_elevation(batch)
    for sensor in np.unique(batch.sensor):
        rows = np.flatnonzero(batch.sensor == sensor)
        for c in range(N_COMPONENTS):
            u = res[rows, c] / batch.sigma[rows, c]
            measured = used[rows, c] & ~assumed[rows] if c == ELEVATION else used[rows, c]
            factor = correlation_discount(lag_correlation(batch.t[rows], u, measured))
            if factor > 1.0:
                out[(int(sensor), c)] = factor
    return out


def discounted_sigma(batch: MeasurementBatch, factors: dict[tuple[int, int], float]
                     ) -> np.ndarray:
    """Per-row sigma (N, 6) of ``batch`` with each (sensor index, component)'s factor of
    :func:`correlation_factors` applied."""
    sigma = batch.sigma.copy()
    for (sensor, c), factor in factors.items():
        sigma[batch.sensor == sensor, c] *= factor
    return sigma


def correlation_discount(rho: float) -> float:
    """The sigma factor of rows whose errors have lag-1 correlation ``rho``: 1 up to
    ``RHO_MIN``, else ``sqrt((1 + rho) / (1 - rho))`` with ``rho`` at most ``RHO_MAX``."""
    if not rho > RHO_MIN:
        return 1.0
    r = min(rho, RHO_MAX)
    return float(np.sqrt((1.0 + r) / (1.0 - r)))
