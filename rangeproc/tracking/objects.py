"""Objects under construction in track synthesis: segments, member rows, quick trajectories.

A :class:`Segment` is a run of one sensor's rows that follow one object
(``tracking.segments``, ``tracking.plot_tracker``); :class:`Objects` holds each object's member
rows and its quick trajectory, the centralised smoother without refinement passes,
registration or refraction, on at most ``QUICK_ROWS_PER_SENSOR`` rows per sensor, against
which segments are scored (``tracking.score``).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from rangeproc.estimation.linalg import unpack_many
from rangeproc.fusion.batch import MeasurementBatch, SensorRows, merge
from rangeproc.fusion.centralised import fuse_target
from rangeproc.fusion.estimator_types import EstimatorSettings, FusionResult
from rangeproc.fusion.initialise import NoPositionFix, Prior
from rangeproc.parallel import thread_map
from rangeproc.tracking.score import ObjectTrack

#: While objects are being discovered, a segment is scored only against objects it overlaps
#: in time by at least this many seconds (or half its own duration): association first,
#: relay across gaps once every object exists (``tracking.synthesis``, step 4), so a relay
#: decision is made among all the objects that could continue there, not given to the first
#: one discovered.
OVERLAP_SECONDS = 5.0
#: Output rate (Hz) of the quick trajectories used for scoring. A quick trajectory holds
#: every epoch of its smoother (its member rows' times as well as this grid), so it is
#: dense where the object has data; the grid covers its gaps.
SCORING_RATE_HZ = 5.0
#: While associating, a segment's row farther than this (s) from every row of an object is
#: neither evidence for nor against it (``tracking.links._scored_llr``): the object's
#: trajectory there is a bridge across a gap in its data.
OBSERVED_GAP_SECONDS = 5.0
#: Rows per sensor of an object's quick trajectory: at most these many, evenly spread
#: (association needs the shape of a track, not every row).
QUICK_ROWS_PER_SENSOR = 5_000
#: Rows of a quick trajectory's process-noise search (q is a property of the motion; the
#: full estimate searches up to ``estimation.tuning.MAX_SEARCH_ROWS``).
QUICK_Q_SEARCH_ROWS = 2_000
#: Two plot tracks of one sensor that hold plots of more scans in common than this follow
#: two objects (an object gives one plot per scan); up to this many, they may be one object
#: (:func:`same_sensor_conflict`).
MAX_SHARED_SCANS = 1


@dataclass(frozen=True, slots=True)
class Segment:
    """Rows of one sensor that follow one object: ``rows`` index that sensor's
    :class:`SensorRows` (time order); ``track`` the file's track_id hint (-1 for plots);
    ``t0``, ``t1`` (s); ``has_range``: it can start a track alone; ``plot``: a track of the
    plot tracker (its rows are re-associated one by one at the end, ``tracking.synthesis``
    step 5); ``scans``: for a plot track, the scan number of each row (``rows``' shape;
    ``tracking.plot_tracker.PlotTiming.scan``), else None."""

    id: int
    sensor: int
    rows: np.ndarray
    track: int
    t0: float
    t1: float
    has_range: bool
    plot: bool = False
    scans: np.ndarray | None = None


def object_track(result: FusionResult) -> ObjectTrack:
    """Every epoch of a fused result (its rows' times and its output grid) as an
    :class:`ObjectTrack`, with the sigma it weighed each of its rows with (the final
    pass's, inf for a component the gate left out)."""
    return ObjectTrack(np.ascontiguousarray(result.epoch_t),
                       np.ascontiguousarray(result.xs[:, :9]),
                       unpack_many(result.Ps, result.xs.shape[1], 9),
                       np.ascontiguousarray(result.q), weighed_rows(result))


def weighed_rows(result: FusionResult) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Sensor index -> (its rows' ``source_row`` (K,) ascending, the sigma (K, 6) the
    result's final pass weighed them with, inf where a component was not used)."""
    batch = result.batch
    sigma = np.where(result.used, batch.sigma, np.inf)
    out: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for sensor in np.unique(batch.sensor):
        sel = np.flatnonzero(batch.sensor == sensor)
        order = sel[np.argsort(batch.source_row[sel], kind="stable")]
        out[int(sensor)] = (batch.source_row[order], sigma[order])
    return out


def spread(sel: np.ndarray, most: int) -> np.ndarray:
    """At most ``most`` entries of ``sel``, evenly spread, first and last included."""
    if sel.size <= most:
        return sel
    return sel[np.unique(np.linspace(0, sel.size - 1, most).astype(np.int64))]


def subset_rows(rows: SensorRows, sel: np.ndarray) -> SensorRows:
    return SensorRows(**{f: getattr(rows, f)[sel] for f in SensorRows.__slots__})


class Objects:
    """Objects under construction: member rows per object and their quick trajectories."""

    def __init__(self, rows: Mapping[int, SensorRows], sensor_ids: tuple[str, ...],
                 settings: EstimatorSettings, priors: Mapping[str, Prior]) -> None:
        self.rows = rows
        self.priors = priors
        self.sensor_ids = sensor_ids
        self.settings = replace(settings.with_processing(noise_passes=0), calibration=(),
                                refraction=None, q_search_rows=QUICK_Q_SEARCH_ROWS)
        self.noise_passes = settings.processing.noise_passes
        self.members: dict[str, list[tuple[int, np.ndarray]]] = {}
        self.tracks: dict[str, ObjectTrack] = {}
        #: per object, the sorted times (s) of its member rows when its trajectory was adopted
        self.member_t: dict[str, np.ndarray] = {}
        #: per object, how often its trajectory was estimated (the scores' cache key)
        self.version: dict[str, int] = {}
        #: (segment id, object) -> (object version, per-row llr of the segment's scored rows):
        #: a discovery re-scores every pending segment, but only against the objects that
        #: changed since (the scores are identical to recomputing them)
        self.llr_cache: dict[tuple[int, str], tuple[int, np.ndarray]] = {}
        #: (segment id, relay) -> (its candidates as (index, object, version), its links
        #: {object index: score}): a segment none of whose candidates changed keeps its links
        self.link_cache: dict[tuple[int, bool], tuple[tuple, dict[int, float]]] = {}

    def members_batch(self, members: Sequence[tuple[int, np.ndarray]]) -> MeasurementBatch:
        """The batch of member rows ``members`` ((sensor, rows) pairs), at most
        ``QUICK_ROWS_PER_SENSOR`` per sensor."""
        parts: dict[int, list[np.ndarray]] = {}
        for i, sel in members:
            parts.setdefault(i, []).append(sel)
        return merge([(i, subset_rows(self.rows[i], spread(np.sort(np.concatenate(sels)),
                                                       QUICK_ROWS_PER_SENSOR)))
                      for i, sels in parts.items()], self.sensor_ids)

    def estimate_many(self, names: Sequence[str]) -> dict[str, bool]:
        """:meth:`estimate` of each object, side by side in threads (``rangeproc.parallel``);
        object -> whether it could be started."""
        names = list(names)
        return dict(zip(names, thread_map(self.estimate, names,
                                          cost=lambda n: sum(s.size for _, s in self.members[n]))))

    def estimate(self, name: str) -> bool:
        """(Re-)estimate an object's quick trajectory; False when it cannot be started."""
        return self.adopt(name, self.quick_track(self.members[name], self.priors.get(name)))

    def quick_track(self, members: Sequence[tuple[int, np.ndarray]],
                    prior: Prior | None = None) -> ObjectTrack | None:
        """The quick trajectory of the member rows ``members`` ((sensor, rows) pairs); None
        when it cannot be started. A function of its arguments only (the objects are not
        touched), so it may be computed ahead of need."""
        try:
            result = fuse_target(self.members_batch(members), SCORING_RATE_HZ, self.settings,
                                 prior=prior)
        except NoPositionFix:
            return None
        return object_track(result) if result.grid.any() else None

    def refined_track(self, name: str) -> ObjectTrack | None:
        """Object ``name``'s trajectory with one refinement pass of the full estimate
        (re-linearised at the first pass's smoothed track, noise re-estimated), on the quick
        trajectory's rows; None when it cannot be started. (One pass repaired the cases
        seen, ``tracking.synthesis._doubtful``; a second costs a third more.)"""
        try:
            result = fuse_target(self.members_batch(self.members[name]), SCORING_RATE_HZ,
                                 self.settings.with_processing(
                                     noise_passes=min(1, self.noise_passes)),
                                 prior=self.priors.get(name))
        except NoPositionFix:
            return None
        return object_track(result) if result.grid.any() else None

    def adopt(self, name: str, track: ObjectTrack | None) -> bool:
        """Make ``track`` object ``name``'s quick trajectory (a new version) and note the
        times of its member rows (:meth:`witnessed`); False (and nothing changes) when it
        is None."""
        if track is None:
            return False
        self.tracks[name] = track
        self.version[name] = self.version.get(name, 0) + 1
        times = [self.rows[i].t[sel] for i, sel in self.members.get(name, [])]
        self.member_t[name] = np.sort(np.concatenate(times)) if times else track.t
        return True

    def witnessed(self, name: str, t: np.ndarray) -> np.ndarray:
        """(N,) bool: times ``t`` (N,) s within ``OBSERVED_GAP_SECONDS`` of a member row of
        object ``name`` (as of its current trajectory)."""
        mt = self.member_t[name]
        k = np.searchsorted(mt, t)
        before = np.abs(t - mt[np.clip(k - 1, 0, mt.size - 1)])
        after = np.abs(mt[np.clip(k, 0, mt.size - 1)] - t)
        return np.minimum(before, after) <= OBSERVED_GAP_SECONDS


def overlaps(t0: float, t1: float, u0: float, u1: float) -> bool:
    """True when span [t0, t1] overlaps [u0, u1] (s) by ``OVERLAP_SECONDS`` or by half of
    [t0, t1]'s duration, whichever is less."""
    return min(t1, u1) - max(t0, u0) >= min(OVERLAP_SECONDS, 0.5 * (t1 - t0))


def as_batch(rows: SensorRows, sensor_ids: tuple[str, ...], sensor: int) -> MeasurementBatch:
    """A sensor's rows viewed as a batch (same row order; no copy of the big arrays)."""
    n = rows.t.size
    return MeasurementBatch(rows.t, rows.model, rows.z, rows.sigma, rows.s, rows.sv, rows.Qr,
                            np.full(n, sensor, dtype=np.int64), rows.source_row, rows.station,
                            rows.track, sensor_ids)


def same_sensor_conflict(a: Segment, b: Segment) -> bool:
    """True when segments ``a`` and ``b`` cannot follow one object: they are of one sensor
    and overlap in time, unless both are plot tracks holding plots of at most
    ``MAX_SHARED_SCANS`` common scans. A sensor sees an object once at a time, and a scanning
    radar detects it once per scan; but a plot track that lost its object coasts on for a
    few scans and may take a stray plot in its widening gate while the tracker has started a
    new track on the object: the two overlap in time, yet share only the stray plot's scan.
    Which plot of such a scan is the object's is settled plot by plot later
    (``tracking.reassociation``: one plot per object and scan)."""
    if a.sensor != b.sensor or a.t0 > b.t1 or b.t0 > a.t1:
        return False
    if a.scans is None or b.scans is None:
        return True
    return np.intersect1d(a.scans, b.scans).size > MAX_SHARED_SCANS


def member_conflict(objects: Objects, name: str, seg: Segment,
                    segs_of: Mapping[str, list[Segment]]) -> bool:
    """True when the object already holds a segment in conflict with ``seg``
    (:func:`same_sensor_conflict`)."""
    return any(same_sensor_conflict(o, seg) for o in segs_of.get(name, []))
