"""Improved Sage-Husa adaptive measurement noise (Song et al. 2011) in the compiled filter loop.

Song et al. 2011 (eqs. 20-28) estimate the measurement-noise mean ``r`` and covariance ``R``
recursively from the filter's residuals, and its "improved" form does it over a sliding window
of the latest 100 samples so that old data are forgotten. Here, per sensor and measured
component (independent series, so ``R`` is diagonal in each sensor's own components):

* noise mean: ``r = mean(y)`` of the prior innovations ``y = z - h(x_{k|k-1})`` accepted in the
  window (eq. 24's windowed form); it is subtracted from the next innovations when
  ``estimate_mean`` is set;
* noise variance, from the *post-update* residual ``e = z - h(x_{k|k})``, which keeps the
  estimate positive without the clamping the prior-innovation form needs (the classic failure
  of Sage-Husa: ``E[y y^T] - H P H^T`` goes negative). In the filter's whitened coordinates
  (``R = I`` for the a-priori sigma) ``e_w = S^-1 y_w`` and ``H P_{k|k} H^T = I - S^-1``, so
  ``E[e_w e_w^T + I - S^-1] = R_true / R_used``: each accepted component contributes the ratio
  ``(e_w^2 + 1 - (S^-1)_aa) * (sigma_used / sigma_apriori)^2`` of its true to a-priori variance,
  and the sigma used next is ``sigma_apriori * sqrt(mean ratio)``.

Safeguards a practitioner needs: a warm-up (the a-priori sigma until ``SH_WARMUP`` rows of the
series have been accepted), the ratio held inside ``[SH_MIN_RATIO, SH_MAX_RATIO]`` (positive
definite, bounded), gated rows never enter the window (a wild point cannot inflate ``R``), and
a divergence test that falls back: when the filter's divergence guard fires (a sensor rejected
``reset_after`` times in a row), every window restarts from the a-priori noise. The process
noise is adapted by the smoother's local EM statistic (``estimation.tuning``), the offline
counterpart of Song et al.'s recursive ``Q``.

State layout (arrays allocated by the shared forward loop, ``estimation.forward_loop``, one
row per series ``g = sensor * 6 + component``):
``buf (G, W, 2)`` ring of (ratio, innovation), ``count (G,)``, ``pos (G,)``, ``acc (G, 2)``
running sums.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.models.measurement import N_COMPONENTS

#: Accepted rows of a series before its adapted noise is used.
SH_WARMUP = 20
#: Bounds of the true/a-priori variance ratio.
SH_MIN_RATIO = 1e-4
SH_MAX_RATIO = 1e6


@njit(cache=True)
def sh_adapt(sensor: int, idx: np.ndarray, m: int, sig: np.ndarray, y: np.ndarray,
             count: np.ndarray, acc: np.ndarray, window: int, estimate_mean: bool) -> None:
    """Scale the a-priori sigmas ``sig[:m]`` of components ``idx[:m]`` by the windowed ratio and
    remove the windowed noise mean from the innovations ``y[:m]`` (both in place)."""
    for a in range(m):
        g = sensor * N_COMPONENTS + idx[a]
        n = min(count[g], window)
        if count[g] < SH_WARMUP or n == 0:
            continue
        ratio = min(max(acc[g, 0] / n, SH_MIN_RATIO), SH_MAX_RATIO)
        sig[a] *= math.sqrt(ratio)
        if estimate_mean:
            y[a] -= acc[g, 1] / n


@njit(cache=True)
def sh_record(g: int, ratio: float, innovation: float, buf: np.ndarray, count: np.ndarray,
              pos: np.ndarray, acc: np.ndarray, window: int) -> None:
    """Push one accepted sample of series ``g`` into its window (running sums kept exact by a
    full re-sum each time the ring wraps)."""
    p = pos[g]
    if count[g] >= window:                     # drop the oldest
        acc[g, 0] -= buf[g, p, 0]
        acc[g, 1] -= buf[g, p, 1]
    buf[g, p, 0] = ratio
    buf[g, p, 1] = innovation
    acc[g, 0] += ratio
    acc[g, 1] += innovation
    count[g] += 1
    p += 1
    if p == window:
        p = 0
        s0 = 0.0
        s1 = 0.0
        for j in range(min(count[g], window)):
            s0 += buf[g, j, 0]
            s1 += buf[g, j, 1]
        acc[g, 0] = s0
        acc[g, 1] = s1
    pos[g] = p


@njit(cache=True)
def sh_reset(count: np.ndarray, pos: np.ndarray, acc: np.ndarray) -> None:
    """Restart every window from the a-priori noise (the divergence fallback)."""
    for g in range(count.shape[0]):
        count[g] = 0
        pos[g] = 0
        acc[g, 0] = 0.0
        acc[g, 1] = 0.0
