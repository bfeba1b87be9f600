"""A surveillance radar's plots, associated one by one with the finished objects.

The plot tracker (``tracking.plot_tracker``) links plots scan to scan on their own evidence
only; where two objects fly closer than a few plot sigmas its tracks can swap between them,
and a segment
then holds plots of both (a surveillance track with plots of two aircraft in formation).
Once the objects exist, every plot of such a sensor (clutter included)
is scored against each object whose span it lies in (``tracking.score``: the object's state
carried to the plot time, ``S = H P Hᵀ + R``); within each scan the plots and the objects
whose chi-square gate (probability ``GATE_PROBABILITY``) they pass are paired by the
assignment of the largest summed log-likelihood ratio, an object taking at most one plot per
scan (it is detected once per scan); a plot that loses its scan's assignment is unassigned,
one that no object gates stays where its plot track put it if that object is less certain
than the plot there (a sparse object's own quick trajectory may be too poor to gate all of
its plots; ``tracking.synthesis``), and is unassigned otherwise. A plot is scored against
the object whose plot track holds it as if left out of that object's trajectory, and
every other plot of the scan against that same trajectory without it
(``tracking.score.score_rows_left_out``): a sparse object's track leans towards its own
plots, which would otherwise keep winning plots the plot tracker gave it wrongly, and keep
its true plot of the scan, scored against a track drawn to the wrong one, out. An object
tracked precisely by another sensor thereby takes its own plots back from an object that
only the surveillance radar sees, and two objects whose plots the plot tracker swapped
exchange them where the rest of their trajectories tell (an object seen by the
surveillance radar alone comes out at its true assignment's accuracy).

A gated plot must also be likelier the object's than clutter (:func:`clutter_floor`: the
sensor's own clutter density), and plots of plot tracks that no object took join an object
whose span they lead up to (:func:`extend_objects`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment
from rangeproc.quantiles import chi2_ppf

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH
from rangeproc.tracking.plots import revisit_period
from rangeproc.tracking.score import (
    EXTENT_SPHERICAL,
    OUTLIER_PROBABILITY,
    ObjectTrack,
    mixture_llr,
    score_rows,
    score_rows_left_out,
)

#: Chi-square gate probability of a plot against an object.
GATE_PROBABILITY = 0.9999
#: A plot is scored against an object whose span (s) it lies within this margin of.
SPAN_MARGIN_SECONDS = 2.0
#: Cost of a pair outside the gate in the per-scan assignment (never chosen over a gated one).
BIG = 1e12
#: Orphan plots this far (s) outside an object's span are scored against it carried there
#: (``extend_objects``; the relay's ``BRIDGE_SECONDS``).
EXTEND_SECONDS = 60.0
#: ... and join it while they continue its span with gaps of at most this many revisits
#: (one scan missed, and half a scan of timing).
EXTEND_GAP_SCANS = 2.5


def finite_span(values: np.ndarray) -> float:
    """The extent ``max - min`` of ``values`` (N,) over its finite entries (blanks, an
    edited-out component, left out); 0 for none."""
    values = values[np.isfinite(values)]
    return float(np.ptp(values)) if values.size else 0.0


def azimuth_sector(azimuth: np.ndarray) -> float:
    """The azimuth sector (rad) that angles ``azimuth`` (N,) rad span: the turn less its
    widest empty sector (2 pi for none); blanks (an edited-out component) left out."""
    azimuth = azimuth[np.isfinite(azimuth)]
    if azimuth.size == 0:
        return 2 * np.pi
    az = np.sort(np.mod(azimuth, 2 * np.pi))
    return 2 * np.pi - float(np.diff(np.concatenate([az, az[:1] + 2 * np.pi])).max())


def clutter_floor(batch: MeasurementBatch, plots: np.ndarray, scan: np.ndarray,
                  n_clutter: int) -> np.ndarray:
    """(P,) the log-likelihood ratio (``tracking.score``) each plot of ``plots`` (P,) must
    reach against an object to be more likely the object's than clutter.

    The clutter density is the sensor's own: ``n_clutter`` plots the plot tracker found to
    be clutter, per scan (``scan`` (P,)), over the box the plots span in range, azimuth (the
    turn less its widest empty sector) and elevation. A plot's density under an object,
    ``N(z; h, S)``, must exceed it; the score's unrelated density is uniform over a fixed
    extent (``EXTENT_SPHERICAL``), so the floor is the mixture llr of ``log density +
    log extent``. An object that hardly knows where it is (a bridge of minutes: sigma of tens
    of km) otherwise gates every plot and takes the best clutter plot of each scan.

    Blank components (edited out) span nothing. A sensor that measures no elevation (a 2-D
    radar or lidar: every plot at the assumed elevation 0, ``fusion.assemble``) has no
    floor (-inf: its plots span no elevation). Floors for such sensors, tried in two forms
    on the Autoferry recordings (the assumed elevation scored as clutter's too; range and
    azimuth alone), lowered the boats' coverage (docs/methods/several-objects.md)."""
    z = batch.z[plots]
    n_scans = max(np.unique(scan).size, 1)
    spans = [finite_span(z[:, 0]), azimuth_sector(z[:, AZIMUTH])]
    elevated = np.isfinite(z[:, 2])
    if elevated.any():
        spans.append(finite_span(z[:, 2]))
    if min(spans) <= 0.0 or n_clutter == 0:
        return np.full(plots.size, -np.inf)
    log_ext = np.log(EXTENT_SPHERICAL)
    flat = np.log(n_clutter / n_scans) - np.log(spans[:2]).sum() + log_ext[:2].sum()
    with_el = flat + (log_ext[2] - np.log(spans[-1]) if elevated.any() else 0.0)
    return np.where(elevated, mixture_llr(with_el, OUTLIER_PROBABILITY),
                    mixture_llr(flat, OUTLIER_PROBABILITY))


def plot_owners(batch: MeasurementBatch, plots: np.ndarray,
                tracks: Sequence[ObjectTrack | None], scan: np.ndarray,
                member: np.ndarray | None = None, floor: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """(owner (P,): index into ``tracks`` of the object each plot row goes to, -1 for none;
    gated (P,) bool: some object's gate holds the plot).

    batch: one sensor's rows as a batch; plots: (P,) row indices of its plots; tracks: the
    objects' quick trajectories (None: the object has none); scan: (P,) scan number of each
    plot; member: (P,) index into ``tracks`` of the object whose trajectory each plot
    helped estimate (-1 none), scored as left out of it (None: plain scores). Within a scan
    an object takes at most one plot and a plot goes to at most one object: the assignment
    maximising the summed log-likelihood ratio over the gated pairs
    (``scipy.optimize.linear_sum_assignment``). Module docstring for the gate.
    """
    if plots.size == 0 or not tracks:
        return np.full(plots.size, -1, dtype=np.int64), np.zeros(plots.size, dtype=bool)
    llr = plot_llr(batch, plots, tracks, scan, member, floor)
    return assign_per_scan(llr, scan), np.isfinite(llr).any(axis=1)


def plot_llr(batch: MeasurementBatch, plots: np.ndarray,
             tracks: Sequence[ObjectTrack | None], scan: np.ndarray,
             member: np.ndarray | None = None, floor: np.ndarray | None = None,
             margin: float = SPAN_MARGIN_SECONDS) -> np.ndarray:
    """(P, J) log-likelihood ratio of each plot (arguments as :func:`plot_owners`) under each
    object, -inf outside the object's gate, below ``floor`` (P,) or outside its span widened
    by ``margin`` (s)."""
    llr = np.full((plots.size, len(tracks)), -np.inf)
    if plots.size == 0 or not tracks:
        return llr
    if floor is None:
        floor = np.full(plots.size, -np.inf)
    t = batch.t[plots]
    dof = np.isfinite(batch.z[plots, :4]).sum(axis=1)
    gate = np.asarray(chi2_ppf(GATE_PROBABILITY, np.maximum(dof, 1)), dtype=float)
    for j, track in enumerate(tracks):
        if track is None or track.t.size == 0:
            continue
        inside = np.flatnonzero((t >= track.t[0] - margin) & (t <= track.t[-1] + margin))
        if inside.size == 0:
            continue
        if member is None:
            _, nis, ll = score_rows(batch, plots[inside], track)
        else:       # against its trajectory without its own plot of the scan, if any
            left_out = own_plot_in_scan(plots, scan, member == j)[inside]
            _, nis, ll = score_rows_left_out(batch, plots[inside], track, left_out)
        ok = (nis <= gate[inside]) & (ll >= floor[inside])
        llr[inside[ok], j] = ll[ok]
    return llr


def assign_per_scan(llr: np.ndarray, scan: np.ndarray) -> np.ndarray:
    """(P,) owner (column of ``llr`` (P, J), -1 none) of each plot: within each scan
    (``scan`` (P,)) the assignment of plots to objects maximising the summed llr over the
    finite (gated) pairs, each object taking at most one plot."""
    owner = np.full(llr.shape[0], -1, dtype=np.int64)
    gated = np.isfinite(llr).any(axis=1)
    order = np.argsort(scan, kind="stable")
    bounds = np.flatnonzero(np.diff(scan[order])) + 1
    for rows in np.split(order, bounds):
        rows = rows[gated[rows]]
        if rows.size == 0:
            continue
        block = llr[rows]
        cols = np.flatnonzero(np.isfinite(block).any(axis=0))
        block = block[:, cols]
        a, b = linear_sum_assignment(np.where(np.isfinite(block), -block, BIG))
        ok = np.isfinite(block[a, b])
        owner[rows[a[ok]]] = cols[b[ok]]
    return owner


def extend_objects(batch: MeasurementBatch, plots: np.ndarray,
                   tracks: Sequence[ObjectTrack | None], scan: np.ndarray,
                   owner: np.ndarray, orphan: np.ndarray, floor: np.ndarray | None = None,
                   revisit: float | None = None) -> np.ndarray:
    """``owner`` (P,) with orphan plots (``orphan`` (P,) bool: plots of a plot track that
    no object took) before or after an object's span joined to it.

    An object's trajectory starts with its first rows; where another object held its plot
    track before that (a formation's plot tracks swapping), its earlier plots were taken
    back from the other object in step 5 and then fitted nothing (an aircraft's first
    plots, before another sensor's track of it starts). Orphans up
    to ``EXTEND_SECONDS`` outside a span are scored against the object carried there (its
    covariance growing with its white-jerk noise), assigned per scan as in
    :func:`plot_owners`, and kept while they continue the span without a gap of more than
    ``EXTEND_GAP_SCANS`` revisits: a run that reaches the object, not a stray plot
    that happens to fall in a wide gate. ``scan`` (P,) groups the plots assigned together;
    ``revisit`` is the sensor's revisit period (s; default: from ``scan``).
    """
    out = owner.copy()
    idx = np.flatnonzero(orphan & (owner < 0))
    if idx.size == 0 or not tracks:
        return out
    t = batch.t[plots]
    if revisit is None:
        revisit = revisit_period(t, scan)
    if not revisit > 0.0:
        return out
    llr = np.full((plots.size, len(tracks)), -np.inf)
    dof = np.isfinite(batch.z[plots, :4]).sum(axis=1)
    gate = np.asarray(chi2_ppf(GATE_PROBABILITY, np.maximum(dof, 1)), dtype=float)
    for j, track in enumerate(tracks):
        if track is None or track.t.size == 0:
            continue
        ti = t[idx]
        lo, hi = float(track.t[0]), float(track.t[-1])
        near = idx[((ti < lo - SPAN_MARGIN_SECONDS) & (ti >= lo - EXTEND_SECONDS))
                   | ((ti > hi + SPAN_MARGIN_SECONDS) & (ti <= hi + EXTEND_SECONDS))]
        if near.size == 0:
            continue
        _, nis, ll = score_rows(batch, plots[near], track)
        ok = (nis <= gate[near]) & (floor is None or ll >= floor[near])
        llr[near[ok], j] = ll[ok]
    won = assign_per_scan(llr, scan)
    for j, track in enumerate(tracks):
        mine = np.flatnonzero(won == j)
        if mine.size:
            out[mine[continuing_run(t[mine], track.t, EXTEND_GAP_SCANS * revisit)]] = j
    return out


def continuing_run(t: np.ndarray, span: np.ndarray, max_gap: float) -> np.ndarray:
    """(K,) bool: which of the times ``t`` (K,) s continue ``span`` (its times, ascending):
    those inside it, and outside it outward from the nearer end, on either side, each within
    ``max_gap`` (s) of the one before (the first of the end itself)."""
    keep = (t >= span[0]) & (t <= span[-1])
    for side, edge in ((t < span[0], float(span[0])), (t > span[-1], float(span[-1]))):
        part = np.flatnonzero(side)
        part = part[np.argsort(np.abs(t[part] - edge), kind="stable")]   # outward
        reach = np.abs(np.diff(np.concatenate([[edge], t[part]])))
        keep[part] = np.cumprod(reach <= max_gap).astype(bool)
    return keep


def own_plot_in_scan(plots: np.ndarray, scan: np.ndarray, mine: np.ndarray) -> np.ndarray:
    """(P,) for each plot row of ``plots`` (P,): itself if it is one of the object's
    (``mine`` (P,) bool), else the object's plot in the same scan (``scan`` (P,); the first
    if it has several), else -1."""
    out = np.full(plots.size, -1, dtype=np.int64)
    own = np.flatnonzero(mine)
    if own.size == 0:
        return out
    scans, first = np.unique(scan[own], return_index=True)
    k = np.clip(np.searchsorted(scans, scan), 0, scans.size - 1)
    hit = scans[k] == scan
    out[hit] = plots[own[first[k[hit]]]]
    out[own] = plots[own]
    return out


def reassign_members(members: Mapping[str, list[tuple[int, np.ndarray]]], sensor: int,
                     plots: np.ndarray, owner: np.ndarray, keys: Sequence[str]
                     ) -> dict[str, list[tuple[int, np.ndarray]]]:
    """Object memberships with ``sensor``'s plot rows ``plots`` moved to their ``owner``
    (index into ``keys``; -1: to no object); other rows are left where they are."""
    out: dict[str, list[tuple[int, np.ndarray]]] = {}
    for key, parts in members.items():
        kept = [(i, sel if i != sensor else sel[~np.isin(sel, plots)]) for i, sel in parts]
        out[key] = [(i, sel) for i, sel in kept if sel.size]
    for j, key in enumerate(keys):
        mine = plots[owner == j]
        if mine.size and key in out:
            out[key].append((sensor, np.sort(mine)))
    return out
