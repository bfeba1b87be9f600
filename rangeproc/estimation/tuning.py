"""Process-noise selection by maximum innovation likelihood."""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.ekf import ekf_forward


def select_process_noise(batch, epoch_t: np.ndarray, meas_epoch: np.ndarray, x0: np.ndarray,
                         P0: np.ndarray, gate: np.ndarray, q_grid: tuple[float, ...],
                         reset_after: int, reset_inflation: float,
                         x_lin: np.ndarray) -> float:
    """The white-jerk PSD q (m^2/s^5) from ``q_grid`` with the largest innovation likelihood.

    The likelihood is the EKF's prediction-error (Gaussian) log-likelihood of all rows, with
    rejected rows counted at the gate so that a q which rejects more data is not rewarded.
    ``x_lin`` is passed through to the filter (linearisation states, see ``ekf_forward``).
    The maximum is refined by a parabola through the best grid point and its neighbours in
    log q.
    """
    grid = np.asarray(q_grid, dtype=float)
    ll = np.empty(len(grid))
    for i, q in enumerate(grid):
        ll[i] = ekf_forward(epoch_t, meas_epoch, batch.model, batch.z, batch.sigma, batch.s,
                            batch.sv, batch.Qr, batch.sensor, x0, P0, float(q), gate, reset_after,
                            reset_inflation, x_lin)[5]
    best = int(np.argmax(ll))
    if 0 < best < len(grid) - 1:
        lq = np.log(grid[best - 1:best + 2])
        a, b, _ = np.polyfit(lq, ll[best - 1:best + 2], 2)
        if a < 0:
            return float(np.exp(np.clip(-b / (2 * a), lq[0], lq[2])))
    return float(grid[best])
