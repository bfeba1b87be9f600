"""Where an object's own rows support its trajectory: no output where its rows reject it.

A smoothed trajectory is only as good as the rows that shaped it. When an object's position
rows stop fitting it (a track that held rows of two things, a sparse plot object whose
motion model extrapolated a wrong acceleration across a pause), the filter rejects them one
after the other and carries its prediction on: the estimate then leaves the region the rows
are in, kilometres away between plots 100 m apart, and its covariance says little about why.
Such a stretch is not an estimate of the object and is not written.

A *position row* is a row that fixes a position: a GPS row (Cartesian position) or a radar
row with range and azimuth. It *fits* when every position component it measured was
accepted by the final pass's gate (``FusionResult.used``) and its smoothed residual lies
within ``FIT_SIGMAS`` of the row's sigma: a trajectory that fits its rows passes within
their noise (the smoothed residual's variance is the row's less what the trajectory
explains), while a trajectory whose process noise grew until rows of several things pass the
gate accepts rows hundreds of their sigmas away. The sigma is the one the final pass used,
but at most ``NOISE_CEILING`` times the sensor's stated sigma: the noise estimated from the
residuals of rows of several things grows with them (kilometres for a 5 m radar), while a
real noise burst stays within the ceiling.

The ceiling still admits a trajectory that drifts off its rows slowly (a track that followed
a return of something else and is carried on past it, its noise estimate inflated by those
returns): its rows then lie tens of their stated sigmas away, all on one side. Where the
stated sigmas are known, a *drift* is a run of at least ``DRIFT_ROWS`` consecutive position
rows of one sensor whose smoothed residual in one component lies beyond ``FIT_SIGMAS`` of the
stated sigma with the same sign; its rows do not fit. White noise, even a 10x burst, changes
sign (a run of ``DRIFT_ROWS`` one-signed residuals beyond 0.5 sigma of a 10x burst: 2 x
0.31^4 = 2 %; beyond 5 sigma of the stated noise: 1e-25); an offset of a sensor's returns
that persists (a hull side) lies within ``FIT_SIGMAS`` stated sigmas of the track that the
other sensors carry, or is taken up by it.

Between two consecutive fitting position rows the trajectory is *unsupported* when that
stretch holds at least ``MIN_UNFIT_ROWS`` position rows that do not fit and lasts longer than
``MIN_UNFIT_SECONDS``: a lone wild point, or a biased sensor's rows interleaved with another
sensor's fitting ones, leave the trajectory supported; a run of rejections with no fitting row
among them does not. Before the first fitting row and after the last, the *end* stretches,
``MIN_UNFIT_ROWS`` rows that do not fit make it unsupported whatever their span: no fitting
row follows (precedes) them to bring the trajectory back, so what is written there is an
extrapolation its own rows reject, however short (a track's last seconds written hundreds of
metres off, at 100+ m/s^2, because the rows rejecting them spanned 4 s). A stretch with no
rows at all is a data gap, bridged as before (``fusion.bridge``), its sigma growing honestly.
An object without position rows (angles or range rates from a given initial state) is
supported throughout.
"""
from __future__ import annotations

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import CARTESIAN, SPHERICAL

#: A stretch between fitting position rows with at least this many position rows that do not
#: fit, lasting longer than this many seconds, is unsupported (module docstring).
MIN_UNFIT_ROWS = 3
MIN_UNFIT_SECONDS = 5.0
#: Consecutive position rows of one sensor, each beyond ``FIT_SIGMAS`` stated sigmas with
#: the same sign in one component, that make a drift (module docstring).
DRIFT_ROWS = 4
#: A fitting row's smoothed residual lies within this many of its sigmas in each position
#: component (a 1e-6 event for a Gaussian residual).
FIT_SIGMAS = 5.0
#: The sigma a row is held to is at most this many times its sensor's stated sigma (the
#: simulator's and the source documents' noise bursts are 10x).
NOISE_CEILING = 10.0


def position_rows(batch: MeasurementBatch, used: np.ndarray, res: np.ndarray,
                  stated: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(is_position (N,) bool, fits (N,) bool) of the rows of ``batch``: rows that fix a
    position, and whether every position component they measured was accepted (``used``
    (N, 6) bool) with its smoothed residual (``res`` (N, 6), the row's units) within
    ``FIT_SIGMAS`` of its sigma, at most ``NOISE_CEILING`` times ``stated`` (S, 3), the
    stated sigmas of the first three components per sensor index (NaN: no ceiling).

    Rows are judged :data:`BLOCK_ROWS` at a time (each on its own: the same verdicts), so
    that the (N, 3) intermediates of a long sortie are not all held at once."""
    n = len(batch.t)
    is_position = np.empty(n, dtype=bool)
    fits = np.empty(n, dtype=bool)
    for lo in range(0, n, BLOCK_ROWS):
        at = slice(lo, min(lo + BLOCK_ROWS, n))
        is_position[at], fits[at] = _judged(batch.rows(at), used[at], res[at], stated)
    if stated is not None:
        fits &= ~drifting(batch, res, stated, is_position)
    return is_position, fits


#: Rows judged at a time by :func:`position_rows` (its intermediates: about 2 MiB).
BLOCK_ROWS = 32_768


def _judged(batch: MeasurementBatch, used: np.ndarray, res: np.ndarray,
            stated: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`position_rows` of a block of rows (views), before the drift test."""
    z = batch.z
    cart = (batch.model == CARTESIAN) & np.isfinite(z[:, :3]).all(axis=1)
    sph = (batch.model == SPHERICAL) & np.isfinite(z[:, 0]) & np.isfinite(z[:, 1])
    measured = np.isfinite(z[:, :3])
    sigma = batch.sigma[:, :3]
    if stated is not None:
        ceiling = NOISE_CEILING * stated[batch.sensor]
        sigma = np.where(np.isfinite(ceiling), np.fmin(sigma, ceiling), sigma)
    with np.errstate(invalid="ignore"):
        close = np.abs(res[:, :3]) <= FIT_SIGMAS * sigma
    accepted = np.where(measured, used[:, :3] & close, True).all(axis=1)
    is_position = cart | sph
    return is_position, is_position & accepted


def drifting(batch: MeasurementBatch, res: np.ndarray, stated: np.ndarray,
             is_position: np.ndarray) -> np.ndarray:
    """(N,) bool: the position rows (``is_position`` (N,) bool) in a drift (module docstring):
    runs of at least ``DRIFT_ROWS`` consecutive position rows of one sensor whose smoothed
    residual ``res`` (N, 6) in one of the first three components lies beyond ``FIT_SIGMAS``
    of ``stated`` (S, 3), that sensor's stated sigma (NaN: no test), with the same sign."""
    out = np.zeros(len(batch.t), dtype=bool)
    for sensor in np.unique(batch.sensor[is_position]):
        rows = np.flatnonzero(is_position & (batch.sensor == sensor))
        rows = rows[np.argsort(batch.t[rows], kind="stable")]
        limit = FIT_SIGMAS * stated[sensor]
        with np.errstate(invalid="ignore"):
            side = np.where(res[rows, :3] > limit, 1, np.where(res[rows, :3] < -limit, -1, 0))
        for c in range(3):
            out[rows[_runs(side[:, c], DRIFT_ROWS)]] = True
    return out


def _runs(side: np.ndarray, least: int) -> np.ndarray:
    """(M,) bool: members of runs of at least ``least`` equal non-zero entries of ``side``."""
    change = np.flatnonzero(np.diff(side) != 0) + 1
    starts = np.r_[0, change]
    ends = np.r_[change, side.size]
    member = np.zeros(side.size, dtype=bool)
    for a, b in zip(starts, ends):
        if side.size and side[a] != 0 and b - a >= least:
            member[a:b] = True
    return member


def unsupported_stretches(t_rows: np.ndarray, is_position: np.ndarray, fits: np.ndarray
                          ) -> list[tuple[float, float]]:
    """The open time intervals (s) where the trajectory is unsupported (module docstring):
    between consecutive fitting position rows, each holding at least ``MIN_UNFIT_ROWS``
    position rows that do not fit and lasting longer than ``MIN_UNFIT_SECONDS``, or before
    the first / after the last one (-inf / +inf), holding at least ``MIN_UNFIT_ROWS`` of them
    whatever their span. t_rows: (N,) s ascending."""
    pos_t = t_rows[is_position]
    pos_fit = fits[is_position]
    if pos_t.size == 0 or pos_fit.all():
        return []
    edges = np.concatenate([[-np.inf], pos_t[pos_fit], [np.inf]])
    unfit_t = pos_t[~pos_fit]
    # stretch k: (edges[k], edges[k + 1]); the unfit rows in each (none lie on an edge time
    # except at a shared time stamp, counted in the stretch after it)
    k = np.searchsorted(edges, unfit_t, side="right") - 1
    out = []
    for j, n in zip(*np.unique(k, return_counts=True)):
        lo, hi = float(edges[j]), float(edges[j + 1])
        end = np.isinf(lo) or np.isinf(hi)
        if n >= MIN_UNFIT_ROWS and (end or hi - lo > MIN_UNFIT_SECONDS):
            out.append((lo, hi))
    return out


def unsupported_time(batch: MeasurementBatch, used: np.ndarray, res: np.ndarray) -> float:
    """Seconds of ``batch``'s span left unsupported (:func:`unsupported_stretches`) by a pass
    with accepted components ``used`` (N, 6) and smoothed residuals ``res`` (N, 6), its rows
    judged at their own sigmas."""
    is_position, fits = position_rows(batch, used, res)
    t0, t1 = float(batch.t[0]), float(batch.t[-1])
    return sum(min(hi, t1) - max(lo, t0)
               for lo, hi in unsupported_stretches(batch.t, is_position, fits))


def supported(t: np.ndarray, batch: MeasurementBatch, used: np.ndarray, res: np.ndarray,
              stated: np.ndarray | None = None) -> np.ndarray:
    """(E,) bool: output epochs ``t`` (E,) s outside every unsupported stretch of the rows
    ``batch`` with the final pass's ``used`` (N, 6) and smoothed residuals ``res`` (N, 6);
    ``stated`` as for :func:`position_rows` (module docstring)."""
    is_position, fits = position_rows(batch, used, res, stated)
    keep = np.ones(t.size, dtype=bool)
    for lo, hi in unsupported_stretches(batch.t, is_position, fits):
        keep &= ~((t > lo) & (t < hi))
    return keep


def left_out(t: np.ndarray, keep: np.ndarray) -> tuple[tuple[float, float], ...]:
    """The runs of epochs ``t`` (E,) s that ``keep`` (E,) bool leaves out, as
    ((first, last), ...) s: what :func:`supported` did not let be written."""
    out = np.flatnonzero(~keep)
    if out.size == 0:
        return ()
    breaks = np.flatnonzero(np.diff(out) > 1)
    starts = np.r_[out[0], out[breaks + 1]]
    ends = np.r_[out[breaks], out[-1]]
    return tuple((float(t[a]), float(t[b])) for a, b in zip(starts, ends))
