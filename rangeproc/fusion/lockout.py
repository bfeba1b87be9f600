"""Gate lock-out of sparse plots: where a span's track lost its object, it starts again.

An object seen only by a scanning radar has one plot per scan (2-5 s apart). After a turn
between two plots, or a clutter plot that pulled it, the filter's prediction may be far from
the next plot. The gate then rejects the plot's range (per component: the angles still
pass) and the track runs on along the line of sight, so the next plots miss the gate too:
every later plot of the span is lost and the smoother has nothing to bring the track back
(the divergence guard, ``estimation.divergence``, counts ``reset_after`` rejected rows of
one sensor, tens of seconds of plots; and a plot whose angles pass is no rejected row for it
unless far beyond the gate). Offline the remedy is to start the track again where it was
locked out: the span is cut before the first of ``LOCKOUT_PLOTS`` consecutive plots of a
sparse sensor that the smoothed track misses beyond the gate (their smoothed residuals in
the sensor's noise), and each part is estimated on its own (own start, own process noise);
the gap between the parts is then bridged in the output (``fusion.bridge``) with the
sigma the motion model gives it. The cut stands only when the later part, estimated alone,
follows its plots (:func:`clean_restart`): two consecutive wild plots, a sensor's
heavy-tailed noise, or clutter the association assembled into an object are missed by
either track and leave the span whole.

A sensor is *sparse* in a span when the median step between its rows there is at least
``SPARSE_STEP_S`` (a scanning radar's revisit, not a tracking radar, GPS or camera). Dense
sensors are left alone: a run of rejected rows of one of them is the divergence guard's. A
span is cut only where the object is seen by plots alone from the cut on: while a lidar,
camera, tracking radar or GPS still measures it, plots the track misses are the plots' own
trouble (clutter, the other side of an extended hull), and the dense rows keep the track.
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.estimator_types import FusionResult

#: A sensor whose rows in a span are at least this far apart (median step, s) gives plots
#: (a scanning radar's revisit is 2-5 s); GPS at 1 Hz and faster sensors are not sparse.
SPARSE_STEP_S = 1.5
#: Consecutive locked-out plots of one sparse sensor that cut the span (one is a stray
#: plot the smoother may carry, two in a row a track that lost its object).
LOCKOUT_PLOTS = 2
#: Plots the restarted part may miss before its own next lock-out (a stray plot now and
#: then is clutter the association let through; more is no track).
STRAY_PLOTS = 1
#: Each part of a cut span keeps at least this many rows (a part too short to start from
#: its own fixes is no improvement; the span is then left whole).
MIN_PART_ROWS = 3


def sparse_sensors(sensor: np.ndarray, t: np.ndarray) -> list[int]:
    """Sensor indices whose rows (``sensor`` (N,), times ``t`` (N,) s ascending) have a
    median step of at least ``SPARSE_STEP_S``; a sensor with fewer than two rows is not
    sparse."""
    out = []
    for s in np.unique(sensor):
        ts = t[sensor == s]
        if ts.size >= 2 and float(np.median(np.diff(ts))) >= SPARSE_STEP_S:
            out.append(int(s))
    return out


def locked_out(result: FusionResult, gate: np.ndarray) -> np.ndarray:
    """(N,) bool over ``result.batch``'s rows: a plot of a sparse sensor that the smoothed
    track misses beyond the gate: the chi-square of its smoothed residuals (``res``) in its
    sensor's global noise (``result.noise``; the row's own sigma where there is none)
    exceeds ``gate[m]`` for its ``m`` measured components (``gate`` (7,) by degrees of
    freedom). The global noise, not the row's final sigma: the noise adaptation widens the
    sigma of plots far from a lost track (``fusion.noise``, Huber's rule), which would hide
    the loss."""
    b = result.batch
    sparse = sparse_sensors(b.sensor, b.t)
    if not sparse:          # no plots (instrumented objects): nothing can be locked out
        return np.zeros(len(b), dtype=bool)
    sig = b.sigma.copy()
    for (sensor, c), value in result.noise.items():
        if value > 0.0:
            sig[b.sensor == sensor, c] = value
    have = np.isfinite(b.z) & np.isfinite(result.res) & (sig > 0.0)
    u = np.where(have, result.res / np.where(have, sig, 1.0), 0.0)
    chi2 = np.sum(u * u, axis=1)
    m = np.clip(have.sum(axis=1), 0, gate.size - 1)
    return np.isin(b.sensor, sparse) & (m > 0) & (chi2 > gate[m])


def missed_from(result: FusionResult, gate: np.ndarray, t: float) -> int:
    """How many plots from time ``t`` (s) on the track misses beyond the gate
    (:func:`locked_out`)."""
    return int(np.count_nonzero(locked_out(result, gate) & (result.batch.t >= t)))


def plots_only_from(batch_sensor: np.ndarray, batch_t: np.ndarray, sparse: list[int],
                    t: float) -> bool:
    """True when every row from time ``t`` (s) on is a plot of a ``sparse`` sensor: from
    there the object is seen by plots alone (no lidar, camera, tracking radar or GPS row
    holds or steers its track)."""
    return bool(np.isin(batch_sensor[batch_t >= t], sparse).all())


def clean_restart(tail: FusionResult, whole: FusionResult, gate: np.ndarray,
                  t_cut: float) -> bool:
    """Whether a span cut at ``t_cut`` (s) is better for it: the later part estimated alone
    (``tail``) misses fewer of the plots from ``t_cut`` on than the uncut span's track
    (``whole``), and no more than ``STRAY_PLOTS`` of them before its own next lock-out
    (:func:`lockout_time`; the end of the part when none): the plots after a hard turn make
    one track again. Plots that no track can follow (clutter assembled into an object, two
    wild plots in a row, heavy-tailed noise) leave the span whole, so its output still ends
    where its plots stop fitting it."""
    missed = locked_out(tail, gate)
    t_next = lockout_time(tail, gate)
    before_next = tail.batch.t < (np.inf if t_next is None else t_next)
    return (missed_from(tail, gate, t_cut) < missed_from(whole, gate, t_cut)
            and int(np.count_nonzero(missed & before_next)) <= STRAY_PLOTS)


def lockout_time(result: FusionResult, gate: np.ndarray) -> float | None:
    """The time (s) of the first plot of the first run of ``LOCKOUT_PLOTS`` consecutive
    locked-out plots of one sparse sensor (:func:`locked_out`) from which the object is
    seen by plots alone (:func:`plots_only_from`), when the span can be cut there with
    ``MIN_PART_ROWS`` rows on either side; None when there is none."""
    b = result.batch
    bad = locked_out(result, gate)
    if not bad.any():
        return None
    sparse = sparse_sensors(b.sensor, b.t)
    first: float | None = None
    for s in np.unique(b.sensor[bad]):
        rows = np.flatnonzero(b.sensor == s)
        flags = bad[rows].astype(np.int64)
        # runs of consecutive locked-out plots of this sensor: the first of length >= N
        run = np.convolve(flags, np.ones(LOCKOUT_PLOTS, dtype=np.int64), mode="valid")
        for k in np.flatnonzero(run == LOCKOUT_PLOTS):
            t_cut = float(b.t[rows[k]])
            if not plots_only_from(b.sensor, b.t, sparse, t_cut):
                continue
            before = int(np.count_nonzero(b.t < t_cut))
            if before >= MIN_PART_ROWS and len(b) - before >= MIN_PART_ROWS:
                first = t_cut if first is None else min(first, t_cut)
                break
    return first
