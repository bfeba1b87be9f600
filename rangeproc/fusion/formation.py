"""An object first (or last) seen beside another, within the resolution of the radar that sees
it and moving with it: its span before (after) that, written as the other's trajectory plus
the offset between the two, bridged.

Two boats side by side closer than a radar resolves give one plot a scan for both (Koch and
van Keuk 1997: an unresolved measurement of the pair). The plot tracker follows that plot as one
track; the second boat's own track begins where the two part, beside the first, at the first's
speed and course. Before that the second boat was there all along, hidden in the first's plots:
an object does not appear in open water. The formation hypothesis writes it where the pair's
plots put it: at the first object's smoothed trajectory plus the offset measured where the second
was first resolved, the offset's uncertainty growing with the relative velocity's, and marks
those epochs bridged (no measurement of its own, ``io.output.BRIDGED_SECONDS``).

An object j starts (ends) in formation with an object i when, at j's first (last) output
epoch t0:

* the horizontal offset d = x_j - x_i lies within the resolution of j's radar: inside the
  ``FORMATION_GATE_PROBABILITY`` chi-square gate (2 dof) of twice the stated plot covariance
  of j's radar row nearest t0 (range sigma along the line of sight, range times azimuth sigma
  across it: two plots that close are one plot's noise apart), and
* the velocities agree: v_j - v_i inside the same gate of the sum of their smoothed velocity
  covariances.

The nearest such i (in that gate's distance) gives j the epochs of i from t0 back (forward) over
at most ``max_extension`` s (the output's bridging limit) and at most the time their estimated
relative velocity takes to carry them the resolution apart (the gate's radius along the cell's
major axis over |v_j - v_i|: moving so, they would have been resolved before), with states
x_i + (d, 0) and covariances P_i + P_j(t0) + tau^2 Pv (tau the time from t0, Pv the relative
velocity's covariance, on the position block; Pv on the velocity block): the offset held, as
the pair moved together, its error growing along the relative velocity's. Objects without a
ranged radar row near t0 (a theodolite's, a declared target's GPS) are left as they are.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.quantiles import chi2_ppf
from rangeproc.results import TrackEstimate

#: Chi-square gate probability (2 dof) of the offset within the radar's resolution and of the
#: relative velocity (module docstring).
FORMATION_GATE_PROBABILITY = 0.99
#: A radar row at most this far (s) from the object's first (last) epoch gives its resolution.
RESOLUTION_ROW_SECONDS = 5.0


def plot_cell(result: FusionResult, t0: float, stated: np.ndarray) -> np.ndarray | None:
    """(2, 2) m^2 the stated horizontal covariance of the ranged row of ``result``'s batch
    nearest t0 (s): the sensor's stated range sigma along the row's line of sight (turned from the
    sensor's axes into range ENU by the row's rotation ``Qr``), the row's range times the
    stated azimuth sigma across it (``stated`` (S, 3): each sensor's stated sigmas
    of range, azimuth, elevation, SI, ``stages.products.stated_position_sigma``); None
    without a ranged row of a sensor with both stated within ``RESOLUTION_ROW_SECONDS``."""
    b = result.batch
    sig = stated[b.sensor, :2]                                         # (N, 2)
    ranged = np.isfinite(b.z[:, 0]) & np.isfinite(b.z[:, 1]) & np.isfinite(sig).all(axis=1)
    near = ranged & (np.abs(b.t - t0) <= RESOLUTION_ROW_SECONDS)
    if not near.any():
        return None
    k = np.flatnonzero(near)[np.argmin(np.abs(b.t[near] - t0))]
    r, az = float(b.z[k, 0]), float(b.z[k, 1])
    # the line of sight in the sensor's axes (azimuth east of the axes' north), turned into
    # range ENU by the row's rotation (p = s + Qr^T d, as the measurement model has it)
    sight = b.Qr[k].T @ np.array([np.sin(az), np.cos(az), 0.0])
    along = sight[:2] / max(float(np.hypot(sight[0], sight[1])), 1e-12)
    across = np.array([along[1], -along[0]])
    s_r, s_a = float(sig[k, 0]), float(r * sig[k, 1])
    return s_r ** 2 * np.outer(along, along) + s_a ** 2 * np.outer(across, across)


def _at(track: TrackEstimate, t0: float, rate_hz: float) -> int | None:
    """Index of ``track``'s epoch at t0 (s; within half an output period), None without."""
    k = int(np.argmin(np.abs(track.time - t0))) if track.time.size else -1
    return k if k >= 0 and abs(track.time[k] - t0) <= 0.5 / rate_hz else None


def _partner(j: int, tracks: list[TrackEstimate], cell: np.ndarray, end: int,
             rate_hz: float) -> tuple[int, int, float] | None:
    """(object index, its epoch index at t0, the time (s) their relative velocity takes to
    carry them a resolution apart) of the nearest object in formation with ``tracks[j]`` at
    its first (``end`` 0) or last (``end`` -1) epoch (module docstring)."""
    me = tracks[j]
    gate = float(chi2_ppf(FORMATION_GATE_PROBABILITY, 2))
    best: tuple[float, int, int, float] | None = None
    reach = float(np.sqrt(gate * np.linalg.eigvalsh(2.0 * cell).max()))    # m
    for i, other in enumerate(tracks):
        k = _at(other, float(me.time[end]), rate_hz) if i != j else None
        if k is None:
            continue
        d = me.x[end, :2] - other.x[k, :2]
        m2 = float(d @ np.linalg.solve(2.0 * cell, d))
        dv = me.x[end, 3:5] - other.x[k, 3:5]
        Pv = me.P[end, 3:5, 3:5] + other.P[k, 3:5, 3:5]
        if m2 > gate or float(dv @ np.linalg.solve(Pv, dv)) > gate:
            continue
        if best is None or m2 < best[0]:
            best = (m2, i, k, reach / max(float(np.linalg.norm(dv)), 1e-9))
    return None if best is None else best[1:]


def _extension(me: TrackEstimate, other: TrackEstimate, k: int, end: int,
               max_extension: float, frame: RangeFrame) -> TrackEstimate:
    """``me`` with ``other``'s epochs beyond its first (``end`` 0) or last (``end`` -1) epoch,
    up to ``max_extension`` s, offset by the pair's offset at ``other``'s epoch k (module
    docstring)."""
    t0 = float(me.time[end])
    tau = np.abs(other.time - t0)
    beyond = (other.time < t0) if end == 0 else (other.time > t0)
    sel = np.flatnonzero(beyond & (tau <= max_extension))
    if sel.size == 0:
        return me
    x = other.x[sel].copy()
    x[:, :3] += me.x[end, :3] - other.x[k, :3]
    Pv = me.P[end, 3:6, 3:6] + other.P[k, 3:6, 3:6]
    P = other.P[sel] + me.P[end][None]
    P[:, :3, :3] += tau[sel, None, None] ** 2 * Pv[None]
    P[:, 3:6, 3:6] += Pv[None]
    lat, lon, h = frame.to_geodetic(x[:, :3])
    gap0 = float(me.data_gap[end]) if me.data_gap is not None else 0.0
    parts = {
        "time": other.time[sel], "x": x, "P": P, "n_sensors": np.zeros(sel.size, np.int64),
        "lat": lat, "lon": lon, "height": h,
        "sensors": np.full(sel.size, "", dtype=object),
        "data_gap": tau[sel] + gap0,
        "achievable": np.full((sel.size, 3), np.nan),
    }
    joined = {}
    for name, new in parts.items():
        old = getattr(me, name)
        if old is None:
            old = (np.full(me.time.size, "", dtype=object) if name == "sensors"
                   else np.zeros(me.time.size) if name == "data_gap"
                   else np.full((me.time.size, 3), np.nan))
        joined[name] = np.concatenate([new, old] if end == 0 else [old, new])
    prob = {name: np.concatenate([np.full(sel.size, np.nan), p] if end == 0
                                 else [p, np.full(sel.size, np.nan)])
            for name, p in me.model_prob.items()}
    return replace(me, model_prob=prob, **joined)


def formation_spans(tracks: list[TrackEstimate], results: dict[str, FusionResult],
                    frame: RangeFrame, rate_hz: float, max_extension: float,
                    stated: np.ndarray) -> list[TrackEstimate]:
    """``tracks`` with each object that starts or ends in formation with another (module
    docstring) extended along it, over at most ``max_extension`` s; ``results``: each
    object's fusion result by id (its radar rows give the resolution); ``rate_hz`` the
    output rate (Hz); ``stated`` as for :func:`plot_cell`. Extensions are taken from the
    tracks as given (not from one another)."""
    out = list(tracks)
    for j, me in enumerate(tracks):
        result = results.get(me.target_id)
        if result is None or me.time.size == 0:
            continue
        for end in (0, -1):
            cell = plot_cell(result, float(me.time[end]), stated)
            if cell is None:
                continue
            found = _partner(j, tracks, cell, end, rate_hz)
            if found is not None:
                out[j] = _extension(out[j], tracks[found[0]], found[1], end,
                                    min(max_extension, found[2]), frame)
    return out
