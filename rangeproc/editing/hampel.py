"""Hampel pre-edit: wild values are removed from each sensor's series before estimation.

The Hampel identifier (Hampel 1974; Pearson 2002) declares ``x_i`` wild when it lies more than
``threshold`` robust sigmas from the median of its window of ``2 window + 1`` samples, the robust
sigma being ``1.4826 x MAD`` (the median absolute deviation, scaled to a Gaussian sigma). A
tracked object moves, so two things are added to the textbook form:

* **Detrending.** Within each window the series' robust slope is removed before the median
  and the MAD are taken, so a fast ramp (a range closing at 300 m/s) does not inflate the MAD.
  The slope is the median of the chords ``(x[j+s] - x[j]) / (t[j+s] - t[j])`` over the window,
  ``s = max(1, half_width // 2)`` samples apart: an isolated wild value spoils two chords and a
  run of wild values ``s`` of them, while the chord's noise is ``s`` times smaller than that
  of consecutive differences (at 20 Hz, consecutive differences alone would leave a slope
  error that inflates the MAD several fold). Curvature left in the window inflates the MAD, never
  the deviation of a good value
  alone, so a hard turn sampled slowly is not edited.
* **A floor on the robust sigma**: the series' noise seen by its third differences
  (``1.4826 MAD(d3 x) / sqrt(20)``, free of any quadratic trend and of wild values as long as
  they are fewer than about one in eight); the MAD of a 15-sample window is itself noisy and
  is zero on quantised readings. When the third differences are mostly zero (quantised or
  constant readings), the smallest non-zero step is the floor.

Inside a **noise burst** nothing is pre-edited: when the window's lower-quartile deviation
(in sigmas) exceeds ``BURST_RATIO`` times the floor, most of the window is noisy, and the
smoother's burst scale (``fusion.noise.residual_sigma``), which is a running median of the
residuals, needs those values to see the burst at its full size; its gate judges them.

The window keeps its full length at the series' ends (it is shifted, not cut), so a run of up
to ``window`` wild values at the start of a track is caught as surely as an isolated spike;
longer runs are the business of the physical limits (``editing.limits``: impossible speed)
and, after estimation, of the gate.

Defaults (``[processing] hampel_window``, ``hampel_threshold``): half-width 7 samples (a
15-sample window) and 6 robust sigmas. The threshold is high on purpose: a pre-edit removes a
value for good, while the smoother's gate and Huber re-weighting judge the moderate outliers
against the fused track with every sensor's help; at 6 sigma a Gaussian value is edited about
twice in a billion. ``hampel_window = 0`` switches the pre-edit off.

Series: per sensor, component and track (radar/theodolite ``track_id``; MISTRAM per station);
plots (rows without ``track_id``, several objects interleaved) are not pre-edited. Azimuth and
yaw are unwrapped first. Each edited component is set to NaN (not measured) and recorded with
reason ``pre-edit``, the other components of the row are kept (the gate still judges them
against the track); a row left with nothing measured is removed (``editing.limits``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from rangeproc.editing.limits import drop_empty_rows
from rangeproc.editing.robust import MAD_TO_SIGMA
from rangeproc.editing.record import EditRecord
from rangeproc.io.logs import SensorLog, replace_columns

#: Default half-width (samples) of the Hampel window: 2 x 7 + 1 = 15 samples.
DEFAULT_WINDOW = 7
#: Default threshold (robust sigmas).
DEFAULT_THRESHOLD = 6.0
#: A window whose lower-quartile sigma exceeds this many times the series' noise floor is a
#: noise burst (or a hard turn sampled slowly): nothing in it is pre-edited.
BURST_RATIO = 2.0
#: sigma / (lower quartile of |x - median|) for Gaussian noise: 1 / 0.31864. The quartile,
#: unlike the MAD, is not raised by a run of wild values filling up to half the window.
QUARTILE_TO_SIGMA = 3.1383
#: Columns pre-edited per sensor kind; the wrapped angles are unwrapped first.
COLUMNS = {
    "radar": ("range", "azimuth", "elevation", "range_rate"),
    "theodolite": ("azimuth", "elevation", "range"),
    "gps": ("lat", "lon", "height", "ve", "vn", "vu"),
    "mistram": ("range_rate",),
    "ins": ("roll", "pitch", "yaw", "lat", "lon", "height", "ve", "vn", "vu"),
}
WRAPPED = frozenset({"azimuth", "yaw", "roll"})
REASON = "pre-edit"


@njit(cache=True)
def _median_of_sorted(buf: np.ndarray, n: int) -> float:
    """Median of the ascending ``buf[:n]``."""
    h = n // 2
    return buf[h] if n % 2 == 1 else 0.5 * (buf[h - 1] + buf[h])


@njit(cache=True)
def _sorted_insert(buf: np.ndarray, n: int, v: float) -> int:
    """Insert ``v`` into the ascending ``buf[:n]``; returns the new length."""
    j = n - 1
    while j >= 0 and buf[j] > v:
        buf[j + 1] = buf[j]
        j -= 1
    buf[j + 1] = v
    return n + 1


@njit(cache=True)
def _median(buf: np.ndarray, n: int) -> float:
    """Median of ``buf[:n]`` (sorted in place; ``n`` small: insertion sort)."""
    for i in range(1, n):
        _sorted_insert(buf, i, buf[i])
    return _median_of_sorted(buf, n)


@njit(cache=True)
def _sorted_remove(buf: np.ndarray, n: int, v: float) -> int:
    """Remove one element equal to ``v`` from the ascending ``buf[:n]``; the new length."""
    j = 0
    while j < n - 1 and buf[j] != v:
        j += 1
    for q in range(j, n - 1):
        buf[q] = buf[q + 1]
    return n - 1


@njit(cache=True, nogil=True)
def hampel_flags(t: np.ndarray, x: np.ndarray, half_width: int, threshold: float,
                 floor: float) -> np.ndarray:
    """(N,) bool: the wild values of one series (module docstring).

    Args:
        t: (N,) ascending times (s); x: (N,) finite values (any unit).
        half_width: window half-width ``k`` (samples; the window holds ``2k + 1``).
        threshold: robust sigmas beyond which a value is wild.
        floor: lowest robust sigma (units of ``x``).
    A series shorter than one window is left alone (all False).
    """
    n = x.shape[0]
    w = 2 * half_width + 1
    out = np.zeros(n, dtype=np.bool_)
    if n < w:
        return out
    step = max(1, half_width // 2)
    # the window's slopes over ``step`` samples, (x[j+step] - x[j]) / dt for j in
    # [lo, lo + w - step) where dt > 0, kept sorted as the window slides (one out, one in)
    n_slopes = n - step
    slope = np.empty(n_slopes)
    usable = np.empty(n_slopes, dtype=np.bool_)
    for j in range(n_slopes):
        dt = t[j + step] - t[j]
        usable[j] = dt > 0.0
        slope[j] = (x[j + step] - x[j]) / dt if usable[j] else 0.0
    slopes = np.empty(w)
    vals = np.empty(w)
    m = np.int64(0)        # not the literal 0: one compiled _sorted_insert/_remove each
    window_lo = -1
    for i in range(n):
        lo = min(max(i - half_width, 0), n - w)
        if window_lo < 0:
            for j in range(lo, lo + w - step):
                if usable[j]:
                    m = _sorted_insert(slopes, m, slope[j])
        elif lo != window_lo:                          # lo moves by one: j = window_lo out
            if usable[window_lo]:
                m = _sorted_remove(slopes, m, slope[window_lo])
            if usable[lo + w - step - 1]:
                m = _sorted_insert(slopes, m, slope[lo + w - step - 1])
        window_lo = lo
        v = _median_of_sorted(slopes, m) if m > 0 else 0.0
        for j in range(w):
            vals[j] = x[lo + j] - v * (t[lo + j] - t[i])
        centre = _median(vals, w)
        if abs(x[i] - centre) <= threshold * floor:    # within the floor: cannot be wild
            continue
        for j in range(w):
            vals[j] = abs(vals[j] - centre)
        spread = MAD_TO_SIGMA * _median(vals, w)        # vals is sorted now
        quiet = QUARTILE_TO_SIGMA * vals[(w - 1) // 4] <= BURST_RATIO * floor
        out[i] = quiet and abs(x[i] - centre) > threshold * max(spread, floor)
    return out


def noise_floor(x: np.ndarray) -> float:
    """Robust noise sigma of a series from its third differences (module docstring); the
    smallest non-zero step when they are mostly zero; 0 for a constant series."""
    d3 = np.diff(x, 3)
    est = MAD_TO_SIGMA * float(np.median(np.abs(d3 - np.median(d3)))) / math.sqrt(20.0) \
        if d3.size else 0.0
    if est > 0.0:
        return est
    steps = np.abs(np.diff(x))
    steps = steps[steps > 0.0]
    return float(steps.min()) if steps.size else 0.0


def _series(log: SensorLog) -> list[np.ndarray]:
    """Row indices (time ordered) of each series of one sensor: per track or station;
    plots (track_id < 0) are left out."""
    key = log.track_id if log.track_id is not None else log.station
    if key is None:
        return [np.arange(len(log))]
    return [np.flatnonzero(key == k) for k in np.unique(key) if k >= 0]


def wild_values(log: SensorLog, column: str, half_width: int, threshold: float) -> np.ndarray:
    """(N,) bool: the values of ``log.columns[column]`` the Hampel identifier finds wild."""
    values = log.columns[column]
    bad = np.zeros(len(log), dtype=bool)
    for rows in _series(log):
        rows = rows[np.isfinite(values[rows])]
        if rows.size < 2 * half_width + 1:
            continue
        x = values[rows]
        if column in WRAPPED:
            x = np.unwrap(x)
        floor = noise_floor(x)
        if floor <= 0.0:
            continue
        bad[rows] = hampel_flags(log.time[rows], np.ascontiguousarray(x), half_width,
                                 threshold, floor)
    return bad


def pre_edit(log: SensorLog, record: EditRecord, *, half_width: int = DEFAULT_WINDOW,
             threshold: float = DEFAULT_THRESHOLD) -> SensorLog:
    """The log with its wild values set to NaN and recorded (reason ``pre-edit``); rows left
    with nothing measured are removed. ``half_width = 0`` returns the log unchanged."""
    if half_width <= 0 or len(log) == 0:
        return log
    new: dict[str, np.ndarray] = {}
    for column in COLUMNS[log.kind]:
        bad = wild_values(log, column, half_width, threshold)
        if not bad.any():
            continue
        values = log.columns[column]
        record.add(log.sensor_id, REASON, column, log.row[bad], log.time[bad], values[bad])
        edited = np.array(values, dtype=float)
        edited[bad] = np.nan
        new[column] = edited
    if not new:
        return log
    return drop_empty_rows(replace_columns(log, new), record, REASON)
