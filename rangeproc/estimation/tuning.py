"""Process-noise estimation: a global start by maximum likelihood, then local EM updates.

1. :func:`start_process_noise`: the white-jerk PSD q (m^2/s^5) with the largest innovation
   likelihood over a logarithmic grid, globally and in sliding windows (a local profile: boost
   and turns get a large q, cruise and coast a small one), evaluated on an evenly decimated
   subset of the rows (q is a property of the target's motion, so its estimate does not need
   every row; the subset keeps the search cheap on hour-long sorties).
2. :func:`local_process_noise`: the refinement from the smoother's EM statistic (see
   ``rts_smooth``): within a sliding window, ``q = sum E[(da)^2] / sum dt``. This is what keeps
   the smoothed uncertainty honest through turns, pull-ups and speed changes; EM alone moves
   slowly from a poor start when the data constrain the acceleration weakly, hence step 1.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter1d

from rangeproc.estimation.forward import FilterPrior, FilterSettings, run_filter
from rangeproc.parallel import thread_map

#: Largest number of rows the likelihood search runs over, unless the span needs more for
#: :data:`MIN_SEARCH_RATE_HZ`.
MAX_SEARCH_ROWS = 20_000
#: Fewest rows per second of span the search keeps (:func:`search_rows`). Decimated more
#: thinly the filter no longer follows the target between the rows it sees and the
#: likelihood over q turns erratic: on the one-hour 2M-row sortie, 20,000 rows (5.6 per
#: second) gave total log-likelihoods jumping by 10^5 between neighbouring q and a choice
#: (3.7e3 or 1.4e4 m^2/s^5) that tipped on 1e-15 changes of the input; 180,000 rows give a
#: smooth curve with one maximum (q = 27), the same for both inputs.
MIN_SEARCH_RATE_HZ = 50.0
#: Each series (sensor x station x track) of the search keeps at least this many rows per
#: second of its span, and at least :data:`SEARCH_LEAST_ROWS` rows: a slow sensor is thinned
#: less than a fast one, never into absence (``MeasurementBatch.thinned``).
SEARCH_LEAST_RATE_HZ = 2.0
SEARCH_LEAST_ROWS = 100


def search_rows(span_s: float, max_rows: int = MAX_SEARCH_ROWS) -> int:
    """Rows of the likelihood search over a span of ``span_s`` seconds: ``max_rows``, or
    :data:`MIN_SEARCH_RATE_HZ` per second of the span when that is more."""
    return max(int(max_rows), int(MIN_SEARCH_RATE_HZ * max(span_s, 0.0)))


def start_process_noise(batch, epoch_t: np.ndarray, x0: np.ndarray, P0: np.ndarray,
                        gate: np.ndarray, q_grid: tuple[float, ...], reset_after: int,
                        reset_inflation: float, *, window: float = 4.0,
                        max_rows: int = MAX_SEARCH_ROWS) -> tuple[float, np.ndarray]:
    """Starting white-jerk PSD: a global value and a local profile, by innovation likelihood.

    The filter runs once per candidate q over an evenly decimated subset of the rows (about
    ``max_rows``: each series thinned by the same stride, ``MeasurementBatch.thinned``); each
    row's log-likelihood contribution is kept (rejected rows count
    at the gate, so a q that rejects more data is not rewarded).

    Returns:
        q_global: the q maximising the total likelihood (refined by a parabola in log q);
        q_epochs: (E,) per-epoch profile on ``epoch_t``: in a sliding ``window`` (s) the
        likelihood-weighted mean of log q over the candidates (a local Bayesian model average
        with a flat prior on the grid: a clear winner dominates, indistinguishable candidates
        average), shrunk half-way toward ``q_global`` in log q, and dilated over half a window
        so a manoeuvre's onset is covered.
    """
    step = max(1, int(np.ceil(len(batch.t) / max_rows)))
    rows = batch.thinned(step, SEARCH_LEAST_RATE_HZ, SEARCH_LEAST_ROWS) if step > 1 \
        else np.arange(len(batch.t))
    t = batch.t[rows]
    sub_epochs = np.unique(t)
    meas_epoch = np.searchsorted(sub_epochs, t).astype(np.int64)
    rows_sub = batch.rows(rows).filter_rows(sub_epochs, meas_epoch)   # contiguous copies
    grid = np.asarray(q_grid, dtype=float)
    settings = FilterSettings(gate, reset_after=reset_after, reset_inflation=reset_inflation)

    def row_loglik(q: float) -> np.ndarray:
        prior = FilterPrior(x0, P0, np.full(len(sub_epochs), q))
        return run_filter(rows_sub, prior, settings).ll_rows

    # the candidates side by side (rangeproc.parallel): the filter releases the GIL
    ll_rows = np.stack(thread_map(row_loglik, [float(q) for q in grid]))
    total = ll_rows.sum(axis=1)
    best = int(np.argmax(total))
    q_global = float(grid[best])
    if 0 < best < len(grid) - 1:
        lq = np.log(grid[best - 1:best + 2])
        a, b, _ = np.polyfit(lq, total[best - 1:best + 2], 2)
        if a < 0:
            q_global = float(np.exp(np.clip(-b / (2 * a), lq[0], lq[2])))
    # windowed likelihoods per candidate, by cumulative sums over the time-ordered rows
    cs = np.concatenate([np.zeros((len(grid), 1)), np.cumsum(ll_rows, axis=1)], axis=1)
    lo = np.searchsorted(t, t - 0.5 * window, side="left")
    hi = np.searchsorted(t, t + 0.5 * window, side="right")
    win = cs[:, hi] - cs[:, lo]                                   # (G, M)
    w = np.exp(win - win.max(axis=0))                             # windowed posterior weights
    log_q_rows = (w * np.log(grid)[:, None]).sum(axis=0) / w.sum(axis=0)
    # shrink half-way (in log q) toward the global value: the forward filter's windowed
    # likelihood over-reacts where a manoeuvre is not white jerk (a coordinated turn rotates
    # the acceleration steadily); the EM passes refine from there with the smoothed data
    log_q = 0.5 * (np.interp(epoch_t, t, log_q_rows) + np.log(q_global))
    q_epochs = dilate_in_time(epoch_t, np.exp(log_q), 0.5 * window)
    return q_global, q_epochs


def dilate_in_time(epoch_t: np.ndarray, values: np.ndarray, span: float) -> np.ndarray:
    """Running maximum of ``values`` (E,) over ``span`` seconds (width from the median step)."""
    if len(epoch_t) < 3:
        return values
    med = float(np.median(np.diff(epoch_t)))
    width = max(1, int(round(span / max(med, 1e-9))))
    return maximum_filter1d(values, size=width, mode="nearest")


def local_process_noise(epoch_t: np.ndarray, em: np.ndarray, *, window: float = 2.0,
                        floor: float = 1e-3, ceiling: float = np.inf) -> np.ndarray:
    """(E,) q per step from the EM statistic ``em`` (E,), over a ``window`` (s) in time.

    ``q_k = sum(em) / sum(dt)`` over the steps within +-window/2 of step k, then dilated by a
    running maximum over the same span so a manoeuvre's onset is covered from its start, and
    kept within [``floor``, ``ceiling``] m^2/s^5. The ceiling (the largest q the likelihood
    search considers) stops a feedback: a pass that lost its object smooths a wild track
    whose EM statistic, unbounded, let the next pass's covariance grow to 1e37 m between
    plots it then could no longer gate.
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
    return np.clip(dilate_in_time(epoch_t, q, window), floor, ceiling)
