"""Process-noise estimation: a global start by maximum likelihood, then local EM updates.

1. :func:`select_process_noise`: the white-jerk PSD q (m^2/s^5) with the largest innovation
   likelihood over a logarithmic grid, evaluated on an evenly decimated subset of the rows
   (q is a property of the target's motion, so its ML estimate does not need every row; the
   subset keeps the search cheap on hour-long sorties).
2. :func:`local_process_noise`: a time-varying q from the smoother's EM statistic (see
   ``rts_smooth``): within a sliding window, ``q = sum E[(da)^2] / sum dt``. A manoeuvring
   stretch gets a large q and a quiet cruise a small one, which is what keeps the smoothed
   uncertainty honest through turns, pull-ups and speed changes.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

from rangeproc.estimation.forward import EKF, kalman_forward

#: UKF parameters argument (unused by the EKF the likelihood search runs).
EKF_UNUSED_UKF = np.array([1.0, 2.0, -6.0])

#: Largest number of rows the likelihood search runs over.
MAX_SEARCH_ROWS = 100_000


def select_process_noise(batch, x0: np.ndarray, P0: np.ndarray, gate: np.ndarray,
                         q_grid: tuple[float, ...], reset_after: int,
                         reset_inflation: float) -> float:
    """The white-jerk PSD q (m^2/s^5) from ``q_grid`` with the largest innovation likelihood.

    The likelihood is the EKF's prediction-error (Gaussian) log-likelihood, with rejected rows
    counted at the gate so that a q which rejects more data is not rewarded. The maximum is
    refined by a parabola through the best grid point and its neighbours in log q.
    """
    step = max(1, int(np.ceil(len(batch.t) / MAX_SEARCH_ROWS)))
    rows = np.arange(0, len(batch.t), step)
    t = batch.t[rows]
    epoch_t = np.unique(t)
    meas_epoch = np.searchsorted(epoch_t, t).astype(np.int64)
    no_lin = np.empty((0, x0.shape[0]))
    grid = np.asarray(q_grid, dtype=float)
    ll = np.empty(len(grid))
    for i, q in enumerate(grid):
        ll[i] = kalman_forward(epoch_t, meas_epoch, batch.model[rows], batch.z[rows],
                            batch.sigma[rows], batch.s[rows], batch.sv[rows], batch.Qr[rows],
                            batch.sensor[rows], x0, P0, np.full(len(epoch_t), float(q)), gate,
                            reset_after, reset_inflation, no_lin, EKF, EKF_UNUSED_UKF)[5]
    best = int(np.argmax(ll))
    if 0 < best < len(grid) - 1:
        lq = np.log(grid[best - 1:best + 2])
        a, b, _ = np.polyfit(lq, ll[best - 1:best + 2], 2)
        if a < 0:
            return float(np.exp(np.clip(-b / (2 * a), lq[0], lq[2])))
    return float(grid[best])


def local_process_noise(epoch_t: np.ndarray, em: np.ndarray, *, window: float = 2.0,
                        floor: float = 1e-3) -> np.ndarray:
    """(E,) q per step from the EM statistic ``em`` (E,), over a ``window`` (s) in time.

    ``q_k = sum(em) / sum(dt)`` over the steps within +-window/2 of step k, then dilated by a
    running maximum over the same span so a manoeuvre's onset is covered from its start, and
    floored at ``floor`` m^2/s^5.
    """
    E = len(epoch_t)
    if E < 2:
        return np.full(E, floor)
    dt = np.diff(epoch_t, prepend=epoch_t[0])
    cs_em = np.concatenate([[0.0], np.cumsum(em)])
    cs_dt = np.concatenate([[0.0], np.cumsum(dt)])
    lo = np.searchsorted(epoch_t, epoch_t - 0.5 * window, side="left")
    hi = np.searchsorted(epoch_t, epoch_t + 0.5 * window, side="right")
    span = cs_dt[hi] - cs_dt[lo]
    q = np.where(span > 0, (cs_em[hi] - cs_em[lo]) / np.maximum(span, 1e-12), floor)
    # dilate in time: width in epochs from the median epoch spacing
    med = float(np.median(dt[1:])) if E > 2 else window
    width = max(1, int(round(window / max(med, 1e-9))))
    q = maximum_filter1d(q, size=width, mode="nearest")
    return np.maximum(q, floor)
