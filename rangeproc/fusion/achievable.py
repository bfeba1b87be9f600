"""The achievable accuracy of a run: what its instruments allow along its own trajectory.

The report draws it beside the achieved 1-sigma (``report/trajectory.py``): where the achieved
sigma is larger, the processing of this data (rejected wild points, noise bursts, rows
down-weighted, a divergence) and not the instruments limited the result. It is the planning
computation (``rangeproc plan``) on the run's own rows: the same constant-acceleration
filter and Rauch-Tung-Striebel smoother (``estimation.forward``, ``estimation.rts``), with

* every row of the final pass, at its sensor component's global noise estimate (the
  instrument's noise as this flight measured it, without bursts; the stated sigma where
  there is none), no gate, no divergence guard;
* the run's process noise ``q`` per step and its smoothed track as the linearisation point
  (a covariance analysis: the measured values do not enter the covariance);
* the calibration's uncertainty at the output epochs, as in the run.

On a long span (more than :data:`MAX_ROWS` rows) each series (sensor x station x track) is
thinned evenly by ``k`` and its kept rows' sigma divided by ``sqrt(k)``: each kept row stands
for the mean of ``k`` rows, the same information per second when the state moves little over
``k`` rows (white noise averages as ``1 / sqrt(k)``).
"""
from __future__ import annotations

import numpy as np

from rangeproc.estimation.forward import FilterPrior, FilterRows, FilterSettings, run_filter
from rangeproc.estimation.linalg import diagonal_entries
from rangeproc.estimation.rts import rts_smooth
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.fusion.registration import spans_calibration_covariance
from rangeproc.io.memory import release_freed_between
from rangeproc.models.motion import N_KINEMATIC

#: Most rows the achievable-accuracy pass runs on (the rest: thinned, module docstring).
MAX_ROWS = 200_000
#: Fewest rows per second a thinned series keeps (the approximation holds while the state
#: moves little between kept rows: stride 2 on a 40 s flight moves the sigma by 1 %).
LEAST_RATE_HZ = 5.0
#: The pass's starting covariance (diagonal: m^2, (m/s)^2, (m/s^2)^2): wide, as a run's
#: own start from its first fixes.
P0_DIAG = np.repeat([1e4, 1e2, 1e1], 3)
#: The packed entries of the position variances P[i, i], i < 3.
POSITION_VARIANCES = diagonal_entries(0, 3)


def _row_sigma(result: FusionResult) -> np.ndarray:
    """(N, 6) each row's sigma: its sensor component's global noise estimate, else the
    sigma the final pass used."""
    b = result.batch
    sigma = b.sigma.copy()
    for sensor in dict.fromkeys(s for s, _ in result.noise):   # one row mask per sensor
        at = b.sensor == sensor
        for (s, comp), value in result.noise.items():
            if s == sensor and np.isfinite(value) and value > 0.0:
                sigma[at, comp] = value
    return sigma


def _thinned(result: FusionResult, sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Row indices and their sigmas for the pass: every row, or on a long span each series
    thinned evenly (``MeasurementBatch.thinned``: never under :data:`LEAST_RATE_HZ` rows
    per second of its span) with its sigma divided by the square root of its stride."""
    b = result.batch
    n = len(b)
    if n <= MAX_ROWS:
        return np.arange(n), sigma
    idx = b.thinned(int(np.ceil(n / MAX_ROWS)), LEAST_RATE_HZ, 400)
    keep = np.zeros(n, dtype=bool)
    keep[idx] = True
    scale = np.ones(n)
    for rows in b.series():
        scale[rows] = np.sqrt(len(rows) / max(int(keep[rows].sum()), 1))
    return idx, sigma[idx] / scale[idx, None]


def achievable_sigma(result: FusionResult) -> np.ndarray:
    """(G, 3) the achievable 1-sigma position (m, range ENU axes) at the output epochs
    (``result.grid``) of one object's fusion result (module docstring)."""
    b = result.batch
    if len(b) == 0:
        return np.full((int(result.grid.sum()), 3), np.nan)
    idx, sigma = _thinned(result, _row_sigma(result))
    every = len(idx) == len(b)          # every row: the batch's own columns, no row copies

    def col(a: np.ndarray) -> np.ndarray:         # only the columns the filter reads
        return a if every else a[idx]

    rows = FilterRows(result.epoch_t, col(result.meas_epoch), col(b.model), col(b.z),
                      np.ascontiguousarray(sigma), col(b.s), col(b.sv), col(b.Qr),
                      col(b.sensor))
    del sigma
    release_freed_between(len(b))       # what the thinning let go, before the filter's arrays
    x_lin = np.ascontiguousarray(result.xs[:, :N_KINEMATIC])
    prior = FilterPrior(x_lin[0].copy(), np.diag(P0_DIAG), result.q, x_lin)
    fwd = run_filter(rows, prior, FilterSettings(np.full(7, np.inf)))
    xf, Pf = fwd.xf, fwd.Pf             # the rows, their gate results and the linearisation
    del rows, prior, x_lin, fwd         # track are not needed by the smoother: let go first
    # fade and jerk given (None) as the passes give them: one compiled smoother for both
    _, Ps, _ = rts_smooth(result.epoch_t, xf, Pf, result.q, False, True, None, None)
    var = Ps[np.flatnonzero(result.grid)[:, None], POSITION_VARIANCES]   # (G, 3), no copies
    del xf, Pf, Ps
    t = result.epoch_t[result.grid]
    var += spans_calibration_covariance(result.calibration, t, POSITION_VARIANCES)
    return np.sqrt(np.maximum(var, 0.0))
