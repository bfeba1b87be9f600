"""Angle-only plots (camera and theodolite detections without ``track_id``) joined to objects
by line of sight.

An EO/IR camera or a theodolite that reports detections rather than a track (several per
frame, other objects and clutter among them) gives bearings, sometimes elevations, and no
range: such a row can start no track, but once the objects exist it says where an object is
across its line of sight, often many times a second. Each such row is scored against every
object's quick trajectory carried to the row's time (``tracking.score``: the row's predicted
angles and their variance, the object's uncertainty included) and, frame by frame (the rows
sharing one time stamp: a camera frame), the rows and the objects whose chi-square gate
(``plot_association.GATE_PROBABILITY``) they pass are paired by the assignment of the
largest summed log-likelihood ratio, as the ranged plots are (``plot_association``): an
object is detected at most once per frame, a detection goes to at most one object. A line of
sight carries no range, so a detection is taken only where it is unambiguous: its
log-likelihood ratio under the best object exceeds that under any other by
``AMBIGUITY_NATS`` (two boats a few degrees apart seen from one camera give no detection to
either, rather than half of them to the wrong one), and none at all in a stretch where such
contested detections are ``CONTESTED_SHARE`` of the object's frames or more
(:func:`contested_rows`, :func:`outside_stretches`: those left are the ones whose error leans
away from the other object, a one-sided sample that pushes the object off), not where the
object's line of sight is
shared by something no object holds (:func:`outside_shared_sight`: a moored boat behind a
passing one gives, frame after frame, a second detection nearly as likely under the boat,
and in the frames that miss the boat the only one), and only to an object already known
across the line of sight (:func:`localised`: its own bearing sigma, from its position
covariance carried to the detection's time, within ``LOCALISED_SIGMAS`` of the
detection's): a line of sight refines where an object is, it cannot say where an object
nobody ranged has gone.

Beyond the span of the object's other rows (before its first, after its last) a camera
often sees the object for seconds more: a boat lying still at the start, its radar plots
too few after missed scans to confirm a track, is in the camera's frames throughout. There
the object is carried from its end state with the gap noise (``tracking.score``: its
trajectory's white-jerk noise and the manoeuvre its speed allows), and the detections that
pass every test above (gate, clutter floor, one object standing out, no shared sight,
localised) are its own while they *continue* its span: outward from the span's end, no gap
between consecutive ones longer than ``CONTINUE_GAP_S``, and not beyond the point where the
carried object is no longer localised, which bounds the reach by the object's own growing
uncertainty (:func:`continuing`). A stray detection seconds beyond the span, with none
between, is not the object's. Fused, such rows before the first position fix are the span's
lead-in: longer than ``fusion.lead_in.LEAD_IN_S`` it is estimated backwards from the fix, so
that bearings at tens of hertz cannot pull the forward start along the line of sight;
shorter, the forward start is the first fixes' fit carried back over it. (A fixed margin
before every span, which gives every object such rows whether they continue it or not, lets
the process-noise search follow the bearings instead; measured cases in the methods page,
several objects, section 6.) These rows widen no span for step 5 (``tracking.synthesis``):
bearings alone know the ends across the line of sight, not along it.

A detection must also be likelier the object's than clutter (:func:`angle_clutter_floor`):
the sensor's own clutter density is its detections per frame over the azimuth sector (and
elevation band) they span, every detection counted as clutter (the objects give at most a
few of them). A wide object uncertainty therefore cannot take the best of a frame's clutter.
The rows then join their object's rows and are fused with them (measurement-level fusion:
the angles of the row, its own sigmas, the sensor's platform geometry).
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import AZIMUTH
from rangeproc.tracking.plot_association import (
    EXTEND_SECONDS,
    assign_per_scan,
    azimuth_sector,
    continuing_run,
    finite_span,
    plot_llr,
)
from rangeproc.tracking.score import (
    AMBIGUITY_NATS,
    EXTENT_SPHERICAL,
    OUTLIER_PROBABILITY,
    ObjectTrack,
    innovation_variance,
    mixture_llr,
)

ELEVATION = 2
#: A detection may go to an object whose bearing sigma is at most this many of its own.
LOCALISED_SIGMAS = 3.0
#: An object's line of sight is shared (:func:`outside_shared_sight`) where at least this
#: share of the frames within this many seconds that its gate holds a detection in hold two
#: nearly equally likely ones: a camera at 5-10 frames a second gives 10-20 frames in such a
#: window, a boat passing a moored one stays on its bearing for seconds, and clutter of a few
#: detections a frame falls in a 1-degree object's gate in a few per cent of them.
SHARED_SIGHT_WINDOW_S = 1.0
SHARED_SIGHT_SHARE = 0.5
#: An object takes none of its detections in a stretch where at least this share of the
#: frames its gate holds a detection in within ``SHARED_SIGHT_WINDOW_S`` hold one another
#: object scores nearly as well (:func:`contested_rows`): the detections left it there are
#: those on the side away from the other object, a censored sample, and censoring a fifth of
#: a Gaussian sample's one side already moves its mean by 0.35 of its sigma.
CONTESTED_SHARE = 0.2
#: Beyond an object's span its detections continue it while none is more than this many
#: seconds after the one before (:func:`continuing`): a camera at 5-10 frames a second that
#: misses its object in a few frames running; a longer silence ends the run.
CONTINUE_GAP_S = 1.0


def localised(batch: MeasurementBatch, rows: np.ndarray, track: ObjectTrack) -> np.ndarray:
    """(P,) bool: the object ``track``, carried to each row of ``rows`` (P,) as it is
    scored (``tracking.score``; beyond its span with the gap noise), is known across the
    row's line of sight to within ``LOCALISED_SIGMAS`` of the row's azimuth sigma: the
    predicted azimuth's innovation variance less the row's stated variance, ``S - R``, at
    most ``LOCALISED_SIGMAS^2 R`` (rad^2). False where S is not defined."""
    S = innovation_variance(batch, rows, track, AZIMUTH)
    R = batch.sigma[rows, AZIMUTH] ** 2
    return S - R <= LOCALISED_SIGMAS ** 2 * R


def angle_clutter_floor(batch: MeasurementBatch, rows: np.ndarray, frame: np.ndarray
                        ) -> np.ndarray:
    """(P,) the log-likelihood ratio (``tracking.score``) each angle-only row of ``rows``
    (P,) must reach against an object to be likelier the object's than clutter: the
    sensor's detections per frame (``frame`` (P,)) spread uniformly over the azimuth sector
    they span (the turn less its widest empty sector) and, for rows with elevation, the
    elevation band; the score's unrelated density is uniform over ``EXTENT_SPHERICAL``, so
    the floor is the mixture llr of ``log density + log extent`` (module docstring)."""
    if rows.size == 0:
        return np.zeros(0)
    z = batch.z[rows]
    per_frame = rows.size / max(np.unique(frame).size, 1)
    sector = max(azimuth_sector(z[:, AZIMUTH]), 1e-6)
    log_ext = np.log(EXTENT_SPHERICAL)
    flat = np.log(per_frame) - np.log(sector) + log_ext[AZIMUTH]
    elevated = np.isfinite(z[:, ELEVATION])
    band = finite_span(z[:, ELEVATION])
    with_el = flat + (log_ext[ELEVATION] - np.log(band) if band > 0.0 else 0.0)
    return np.where(elevated & (band > 0.0), mixture_llr(with_el, OUTLIER_PROBABILITY),
                    mixture_llr(flat, OUTLIER_PROBABILITY))


def angle_owners(batch: MeasurementBatch, rows: np.ndarray,
                 tracks: Sequence[ObjectTrack | None]) -> np.ndarray:
    """(P,) index into ``tracks`` of the object each angle-only row ``rows`` (P,) of one
    sensor's ``batch`` goes to, -1 for none (module docstring)."""
    if rows.size == 0 or not tracks:
        return np.full(rows.size, -1, dtype=np.int64)
    frame_t, frame = np.unique(batch.t[rows], return_inverse=True)
    frame = frame.astype(np.int64).ravel()
    floor = angle_clutter_floor(batch, rows, frame)
    llr = plot_llr(batch, rows, tracks, frame, None, floor, margin=EXTEND_SECONDS)
    for j, track in enumerate(tracks):
        if track is not None and track.t.size:
            scored = np.flatnonzero(np.isfinite(llr[:, j]))
            llr[scored[~localised(batch, rows[scored], track)], j] = -np.inf
    if llr.shape[1] > 1:                      # only where one object stands out
        contested = contested_rows(llr)
        llr[~outside_stretches(contested, llr, frame, frame_t, share=CONTESTED_SHARE)] = -np.inf
        llr[contested.any(axis=1)] = -np.inf
    llr[~outside_shared_sight(llr, frame, frame_t)] = -np.inf     # ... nor a shared sight
    return continuing(assign_per_scan(llr, frame), batch.t[rows], tracks)


def continuing(owner: np.ndarray, t: np.ndarray, tracks: Sequence[ObjectTrack | None]
               ) -> np.ndarray:
    """``owner`` (P,) (index into ``tracks``, -1 none) with each object's detections beyond
    its span (times ``t`` (P,) s) kept only while they continue it: outward from the span's
    end, each within ``CONTINUE_GAP_S`` of the one before (``continuing_run``)."""
    out = owner.copy()
    for j, track in enumerate(tracks):
        mine = np.flatnonzero(owner == j)
        if track is None or track.t.size == 0 or mine.size == 0:
            continue
        out[mine[~continuing_run(t[mine], track.t, CONTINUE_GAP_S)]] = -1
    return out


def contested_rows(llr: np.ndarray) -> np.ndarray:
    """(P, J) bool: the detections each object (column of ``llr`` (P, J), -inf outside its
    gate) holds in its gate while another object scores them within ``AMBIGUITY_NATS``."""
    out = np.zeros(llr.shape, dtype=bool)
    for j in range(llr.shape[1]):
        others = np.delete(llr, j, axis=1).max(axis=1)
        with np.errstate(invalid="ignore"):
            out[:, j] = np.isfinite(llr[:, j]) & (np.abs(llr[:, j] - others) < AMBIGUITY_NATS)
    return out


def outside_stretches(marked: np.ndarray, llr: np.ndarray, frame: np.ndarray,
                      frame_t: np.ndarray, window: float = SHARED_SIGHT_WINDOW_S,
                      share: float = SHARED_SIGHT_SHARE) -> np.ndarray:
    """(P, J) bool: False for each object's detections in the frames of a stretch where at
    least ``share`` of its gated frames within ``window`` s hold a ``marked`` (P, J) one."""
    out = np.ones(llr.shape, dtype=bool)
    for j in range(llr.shape[1]):
        gated = np.isfinite(llr[:, j])
        if gated.sum() < 2:
            continue
        seen = np.unique(frame[gated])
        two = np.zeros(frame_t.size, dtype=bool)
        two[frame[marked[:, j]]] = True
        ts = frame_t[seen]
        n_two = np.r_[0, np.cumsum(two[seen])]
        lo = np.searchsorted(ts, ts - window, "left")
        hi = np.searchsorted(ts, ts + window, "right")
        bad = np.zeros(frame_t.size, dtype=bool)
        bad[seen] = (n_two[hi] - n_two[lo]) >= share * (hi - lo)
        out[bad[frame], j] = False
    return out


def outside_shared_sight(llr: np.ndarray, frame: np.ndarray, frame_t: np.ndarray,
                         window: float = SHARED_SIGHT_WINDOW_S,
                         share: float = SHARED_SIGHT_SHARE) -> np.ndarray:
    """(P, J) bool: for each object (column of ``llr`` (P, J), -inf outside its gate), False
    for the detections of the frames (``frame`` (P,), frame times ``frame_t`` (F,) s) in a
    stretch where its line of sight is shared: at least ``share`` of the frames within
    ``window`` s in which its gate holds a detection hold a second one nearly as likely
    (within ``AMBIGUITY_NATS`` of the frame's best) under it. Such a stretch holds two
    things on one bearing (a moored boat behind a passing one), and the object takes none
    of its detections: where both are seen it cannot tell which is its own, and where the
    camera misses it the one left is the other's. A lone clutter detection near the object
    makes no stretch."""
    marked = np.zeros(llr.shape, dtype=bool)
    for j in range(llr.shape[1]):
        col = llr[:, j]
        gated = np.flatnonzero(np.isfinite(col))
        if gated.size < 2:
            continue
        order = gated[np.lexsort((-col[gated], frame[gated]))]
        f = frame[order]
        head = np.r_[True, f[1:] != f[:-1]]                     # each frame's best
        second = np.flatnonzero(~head & np.r_[False, head[:-1]])  # ... and runner-up
        close = col[order[second - 1]] - col[order[second]] < AMBIGUITY_NATS
        marked[order[second[close]], j] = True
    return outside_stretches(marked, llr, frame, frame_t, window, share)
