"""The speed bound of new plot tracks fitted to a sensor's own tracks (issue 41; used by
``tracking.two_passes``): a tentative track's velocity is unknown up to a bound (3 sigma),
and its second plot is sought within the distance an object at that bound travels. The
general bound ``tracking.plots.INITIATION_SPEED`` (an aircraft's) gives a boat seen by a
2.5 s scanning radar a gate of kilometres for its second plot, where the likeliest plot is
often clutter; the new track then follows the clutter and the boat is never confirmed.

Offline, the sensor's plots have already been tracked once with the general bound: the
speeds of its confirmed tracks say how fast the objects it sees move. The bound of the second
pass is ``SPEED_MARGIN`` times the fastest of them (:func:`track_speeds`), at least
``SPEED_FLOOR``, at most the general bound. The margin leaves room for an object faster than
every track the first pass confirmed and for a track's speed measured below its true one (a
narrower margin confines the gate further, and a new track on an object faster than it is
never confirmed: the margin errs on the side of the general bound); the floor keeps a
scene of moored objects only (every speed near 0) from a bound that no departing object
meets. A new track's initial score is lower by the velocity volume the
bound leaves out (``tracking.initiation``), so a narrower gate does not by itself confirm
clutter. Plots of stationary returns keep the general bound (``tracking.plot_tracker``).
"""
from __future__ import annotations

import numpy as np

from rangeproc.tracking.plots import INITIATION_SPEED

#: The fitted bound is this many times the fastest confirmed track's speed.
SPEED_MARGIN = 5.0
#: The fitted bound is never below this (m/s): a ship leaving a quay in a scene where the
#: first pass confirmed nothing that moves.
SPEED_FLOOR = 15.0
#: A track's speed is its least-squares velocity over windows of at least this many
#: seconds (a harbour lidar's hull spread of 10-30 m over 10 s gives about 1 m/s of noise,
#: a scanning radar's plots over 4 scans a few m/s).
SPEED_WINDOW = 10.0
#: A window needs at least this many plots to give a speed.
SPEED_MIN_PLOTS = 4
#: A window's speed is taken this many sigmas of its error below its estimate.
SPEED_SIGMAS = 2.0


def track_speeds(label: np.ndarray, t: np.ndarray, p: np.ndarray, axes: int) -> np.ndarray:
    """(L,) the fastest speed (m/s) of each track of ``label`` (N,) (0..L-1, -1 clutter):
    the largest least-squares velocity over consecutive windows of its plots, each the
    shortest run from its first plot that spans ``SPEED_WINDOW`` s and holds
    ``SPEED_MIN_PLOTS`` plots (the last run joined to the one before when short); NaN for
    a track of fewer than ``SPEED_MIN_PLOTS`` plots. t (N,) s, p (N, 3) m ENU, of which the
    first ``axes`` axes are used (2 for a planar sensor)."""
    n = int(label.max()) + 1 if label.size else 0
    out = np.full(max(n, 0), np.nan)
    for k in range(n):
        rows = np.flatnonzero(label == k)
        tk, pk = t[rows], p[rows, :axes]
        if tk.size < SPEED_MIN_PLOTS or tk[-1] <= tk[0]:
            continue
        out[k] = max(_speed(tk[w], pk[w]) for w in _windows(tk))
    return out


def _windows(t: np.ndarray) -> list[slice]:
    """Consecutive runs of times ``t`` (N,) s ascending, N >= ``SPEED_MIN_PLOTS``, each
    spanning ``SPEED_WINDOW`` s with ``SPEED_MIN_PLOTS`` plots (a short last run joined to
    the one before)."""
    out: list[slice] = []
    i = 0
    while i < t.size:
        j = max(i + SPEED_MIN_PLOTS, int(np.searchsorted(t, t[i] + SPEED_WINDOW)) + 1)
        if j > t.size:
            if out:
                out[-1] = slice(out[-1].start, t.size)
            else:
                out.append(slice(i, t.size))
            break
        out.append(slice(i, j))
        i = j
    return out


def _speed(t: np.ndarray, p: np.ndarray) -> float:
    """Speed (m/s) of the least-squares line through positions p (K, D) at times t (K,),
    K >= 3, less ``SPEED_SIGMAS`` sigmas of its error (from the line's residuals, the
    spread of a hull's returns and the plot noise in them), at least 0: a short run of
    plots spread over a hull does not make its object fast. 0 when the times do not
    differ."""
    dt = t - t.mean()
    ss = float(dt @ dt)
    if not ss > 0.0:
        return 0.0
    v = (dt[:, None] * (p - p.mean(axis=0))).sum(axis=0) / ss
    res = p - p.mean(axis=0) - dt[:, None] * v
    sigma_p = np.sqrt(float((res ** 2).sum()) / (max(t.size - 2, 1) * p.shape[1]))
    return max(0.0, float(np.linalg.norm(v)) - SPEED_SIGMAS * sigma_p / np.sqrt(ss))


def fitted_speed(label: np.ndarray, t: np.ndarray, p: np.ndarray, axes: int) -> float:
    """The speed bound (m/s, 3 sigma) of new tracks fitted to the confirmed tracks
    ``label`` (N,) of a first pass with the general bound (module docstring):
    ``SPEED_MARGIN`` times their fastest speed (:func:`track_speeds`), within
    [``SPEED_FLOOR``, ``INITIATION_SPEED``]; ``INITIATION_SPEED`` when no track has a
    speed."""
    speeds = track_speeds(label, t, p, axes)
    if not np.isfinite(speeds).any():
        return INITIATION_SPEED
    return float(np.clip(SPEED_MARGIN * np.nanmax(speeds), SPEED_FLOOR, INITIATION_SPEED))
