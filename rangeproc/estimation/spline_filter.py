"""Zhou et al.'s self-adaptive spline filter: the pieces that live inside
the shared forward loop's ``anomaly`` and ``jerk-input`` steps (``estimation.forward_loop``).

Zhou et al. 2001 (sec. 1.2) represent the trajectory by a cubic spline: on each knot interval
``[T_{i-1}, T_i]`` the third derivative (jerk) ``S_i`` is constant, and the state equation
(eqs. 5/6) propagates it as a *known model input*:

    a += S dt,   v += a dt + S dt^2 / 2,   p += v dt + a dt^2 / 2 + S dt^3 / 6

(here on rangeproc's 9-state constant-acceleration state, whose white-jerk process noise ``q``
stays the model error around the spline). ``S`` is held in the filter and changed only when
the anomaly test fires:

* **anomaly test** (sec. 2.2): the stacked innovation chi-square of all rows of one epoch at
  the prediction, ``chi2(k) = y^T (H P H^T + R)^-1 y`` with ``M`` degrees of freedom (``M`` =
  the components of the epoch's rows), against the ``1 - alpha`` quantile ``chi2_M``.
  :func:`epoch_chi2` evaluates it in O(M) through the 6x6 information form (the rows see only
  position and velocity): with whitened rows (R = I), ``y^T (I + H P H^T)^-1 y =
  y^T y - c^T (I + L^T G L)^-1 c``, ``G = H^T H``, ``c = L^T H^T y``, ``P_66 = L L^T``, so an
  epoch of thousands of rows costs no M x M factorisation. Rows failing the per-row gate are
  left out (a wild point is the gate's business, not a model anomaly); the quantiles come from
  a table by degrees of freedom (:func:`spline_params`, scipy) up to :data:`SPL_TABLE` and the
  Wilson-Hilferty approximation beyond it (relative error < 1e-3 there);
* **adaptive R** (2.3.1): per sensor component the running post-update residual RMS
  ``sigma = sqrt(RSS / (k - 1))`` over its accepted rows; at an anomalous epoch the rows use
  ``max(stated sigma, RMS)`` (floor at the stated sigma, at most :data:`SPL_MAX_RATIO` times it,
  and only once :data:`SPL_RMS_MIN` residuals exist) instead of their stated sigma;
* **adaptive state equation** (2.3.2): the anomalous epoch is a knot (returned, so the batch
  fit places a knot there) and starts a new segment. First the predicted kinematic covariance
  is opened by the epoch's excess, ``(chi2 - M) / tr(H P H^T)`` (:func:`anomaly_inflation`,
  stored per epoch like a strong-tracking fading factor so the RTS smoother runs the very same
  model), so the update re-estimates acceleration (and velocity) from the anomalous rows; then
  the new segment's jerk is re-estimated from the acceleration corrections since the knot,
  ``S = (a_now - a_knot) / (t_now - t_knot)`` (:func:`segment_jerk`; the document's
  ``h^-1 (X_a(k) - X_a(k-1))`` over a window rather than one step), once
  :data:`SPL_MIN_SEGMENT` measurement epochs and :data:`SPL_JERK_SPAN` seconds have passed,
  and is then held as the segment's known input. The document's one-step form
  ``S + (a_k - a_{k|k-1}) / h`` was tried first and fails: with a well-converged covariance
  one update corrects the acceleration by a small fraction of the change, the estimate falls
  short and the test fires again every few epochs on noise-free data.
  Safeguards: no test during the first :data:`SPL_WARMUP` measurement epochs (the start-up
  transient of a track converging from its prior is not a segment change) nor before the new
  segment's jerk is estimated; the first segment keeps ``S = 0`` (the prior says nothing about
  jerk); each jerk component is held within :data:`SPL_MAX_JERK` (m/s^3), the inflation
  within :data:`SPL_MAX_INFLATION`.

Layout of the ``spl`` parameter array of the spline filter's loop (``FilterSettings.spline``):
``spl[0]`` the standard normal quantile of ``1 - alpha`` (Wilson-Hilferty), ``spl[m]`` for
``m = 1 .. SPL_TABLE`` the chi-square quantile with ``m`` degrees of freedom.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit
from rangeproc.quantiles import chi2_ppf, norm_ppf

from rangeproc.estimation.fading import epoch_innovations
from rangeproc.estimation.kernels import N_OBSERVED
from rangeproc.estimation.linalg import chol_solve_inplace, cholesky_inplace

#: Degrees of freedom tabulated exactly in ``spl``; Wilson-Hilferty beyond.
SPL_TABLE = 64
#: Measurement epochs before the anomaly test is active (start-up transient).
SPL_WARMUP = 20
#: Measurement epochs after a knot before the next test (re-convergence on the new segment).
SPL_MIN_SEGMENT = 20
#: Residuals a sensor component needs before its running RMS may replace its sigma.
SPL_RMS_MIN = 10
#: Largest adapted sigma, relative to the stated one.
SPL_MAX_RATIO = 1e3
#: Shortest time (s) after a knot over which the new segment's jerk is estimated (with at
#: least ``SPL_MIN_SEGMENT`` measurement epochs): dense multi-sensor stamps put 20 epochs
#: within 0.1 s, far too short to tell a jerk from noise.
SPL_JERK_SPAN = 1.0
#: Largest covariance inflation at an anomaly.
SPL_MAX_INFLATION = 1e4
#: Largest re-estimated jerk per axis (m/s^3): about 100 g per second, beyond any airframe.
SPL_MAX_JERK = 1e3


def spline_params(probability: float) -> np.ndarray:
    """The ``spl`` array of the spline filter's loop (``FilterSettings.spline``) for the anomaly
    test at ``probability`` = ``1 - alpha`` (module docstring)."""
    if not 0.5 <= probability < 1.0:
        raise ValueError(f"anomaly probability must be in [0.5, 1), got {probability}")
    out = np.empty(SPL_TABLE + 1)
    out[0] = norm_ppf(probability)
    out[1:] = chi2_ppf(probability, np.arange(1, SPL_TABLE + 1))
    return out


@njit(cache=True, error_model="numpy")
def anomaly_threshold(spl: np.ndarray, m: int) -> float:
    """``chi2_m`` at the tabulated probability: exact up to ``SPL_TABLE`` dof, then
    Wilson-Hilferty ``m (1 - 2/(9m) + z sqrt(2/(9m)))^3``."""
    if m < spl.shape[0]:
        return spl[m]
    c = 2.0 / (9.0 * m)
    v = 1.0 - c + spl[0] * math.sqrt(c)
    return m * v * v * v


@njit(cache=True, error_model="numpy")
def anomaly_inflation(chi: float, m: int, G: np.ndarray, P: np.ndarray) -> float:
    """Factor on the predicted kinematic covariance at an anomalous epoch: the excess of the
    whitened innovation over its noise share, ``(chi2 - M) / tr(H P H^T)`` (``G = H^T H``
    whitened, as :func:`epoch_chi2` leaves it), so the prediction explains what the epoch saw
    (the strong-tracking factor of ``estimation.fading`` with one epoch's statistic); in
    ``[1, SPL_MAX_INFLATION]``."""
    tr = 0.0
    for a in range(N_OBSERVED):
        for c in range(N_OBSERVED):
            tr += G[a, c] * P[c, a]
    if not tr > 0.0:
        return 1.0
    return min(max((chi - m) / tr, 1.0), SPL_MAX_INFLATION)


@njit(cache=True, error_model="numpy")
def add_jerk(x: np.ndarray, jerk: np.ndarray, dt: float) -> None:
    """Zhou et al. 2001 eqs. 5/6: the known jerk input's share of one step, added to ``F x``."""
    h2 = 0.5 * dt * dt
    h3 = h2 * dt / 3.0
    for a in range(3):
        x[a] += h3 * jerk[a]
        x[3 + a] += h2 * jerk[a]
        x[6 + a] += dt * jerk[a]


@njit(cache=True, error_model="numpy")
def segment_jerk(x: np.ndarray, a_knot: np.ndarray, span: float, jerk: np.ndarray) -> None:
    """Re-estimate the jerk of the segment whose knot was ``span`` seconds ago (Zhou et al. 2001
    2.3.2) from the filter's acceleration corrections since then: ``(a_now - a_knot) / span``
    per axis, clamped to ``SPL_MAX_JERK`` (into ``jerk``)."""
    for a in range(3):
        jerk[a] = min(max((x[6 + a] - a_knot[a]) / span, -SPL_MAX_JERK), SPL_MAX_JERK)


@njit(cache=True, nogil=True, error_model="numpy")
def epoch_chi2(i0: int, meas_epoch: np.ndarray, model: np.ndarray, z: np.ndarray,
               sigma: np.ndarray, s: np.ndarray, sv: np.ndarray, Qr: np.ndarray,
               x: np.ndarray, P: np.ndarray, gate: np.ndarray, G: np.ndarray, L: np.ndarray,
               h: np.ndarray, H: np.ndarray, y6: np.ndarray, Hw: np.ndarray, S: np.ndarray,
               t: np.ndarray, b: np.ndarray) -> tuple[float, int]:
    """Stacked innovation chi-square of one epoch's rows at the prediction ``x, P`` (Zhou et
    al. 2001 sec. 2.2) and its degrees of freedom ``M``; rows failing their own gate are left
    out.

    ``G, L`` (6, 6), ``h, y6, b`` (6,), ``H`` (6, n), ``Hw, S`` (6, 6), ``t`` (6, 1) work.
    Returns ``(0, 0)`` when no row is kept or the 6x6 algebra fails."""
    e2_sum, m_sum, _ = epoch_innovations(i0, meas_epoch, model, z, sigma, s, sv, Qr, x, P,
                                         gate, G, h, H, y6, Hw, S, t, b)
    if m_sum == 0:
        return 0.0, 0
    for a in range(N_OBSERVED):                          # P_66 = L L^T
        for c in range(N_OBSERVED):
            L[a, c] = P[a, c]
    if not cholesky_inplace(L, np.int64(N_OBSERVED)):
        return 0.0, 0
    for a in range(N_OBSERVED):                          # c = L^T b  (into t[:, 0])
        acc = 0.0
        for j in range(a, N_OBSERVED):
            acc += L[j, a] * b[j]
        t[a, 0] = acc
    for a in range(N_OBSERVED):                          # Hw <- G L
        for c in range(N_OBSERVED):
            acc = 0.0
            for j in range(c, N_OBSERVED):
                acc += G[a, j] * L[j, c]
            Hw[a, c] = acc
    for a in range(N_OBSERVED):                          # S = I + L^T G L
        for c in range(a + 1):
            acc = 0.0
            for j in range(a, N_OBSERVED):
                acc += L[j, a] * Hw[j, c]
            S[a, c] = acc
            S[c, a] = acc
        S[a, a] += 1.0
    for a in range(N_OBSERVED):
        b[a] = t[a, 0]
    if not cholesky_inplace(S, np.int64(N_OBSERVED)):
        return 0.0, 0
    chol_solve_inplace(S, np.int64(N_OBSERVED), t, np.int64(1))
    red = 0.0
    for a in range(N_OBSERVED):
        red += b[a] * t[a, 0]
    return max(e2_sum - red, 0.0), m_sum
