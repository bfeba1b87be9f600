"""Track synthesis: from every sensor's rows to the rows of each object (He 2015).

1. **Segments** (``tracking.segments``, ``tracking.plots``, ``tracking.plot_tracker``): every
   radar/theodolite track is cut where it jumped to another object or paused. Plots (rows
   without ``track_id``, in any order) go through the plot tracker (clutter is left out; plots
   without range cannot be tracked alone, step 6 takes them; a plot track is cut where it
   jumped across missed scans, ``tracking.plot_jumps``; a plot track most of whose plots lie
   behind another track's on its line of sight is a multipath ghost and clutter,
   ``tracking.ghosts``); rows without ``track_id`` of an
   instrument that follows one object at a time are segmented as one track.
2. **Anchored objects**: each declared target carrying GPS (or MISTRAM) starts as the
   trajectory of those rows alone: they name the object (DATA_CONTRACT: GPS and MISTRAM
   measure one cooperative target).
3. **Growth** (association): every pending segment is scored against every object whose span
   it overlaps by ``OVERLAP_SECONDS`` or half its length (``tracking.score``: row
   log-likelihood ratios, the object's state carried to each row with its process noise, a
   constant bias tolerated). A link is a candidate when it scores positive and most of the
   segment's rows fit (``MIN_FIT_SHARE``; the links and splits are ``tracking.links``).
   The best global assignment of pending segments
   to objects, two segments of one sensor overlapping in time never sharing an object
   (plot tracks of at most one common scan excepted: ``objects.same_sensor_conflict``), is the
   hypothesis search of ``tracking.hypotheses`` (its best and runner-up scores are reported).
   Objects that gained segments are re-estimated from all their rows, and the scoring is
   repeated (scores cached per object version), so an object grows across sensors until no
   segment joins.
4. **Discovery**: the longest pending segment that can start a track alone (one with range,
   ``MIN_SEED_ROWS`` rows over ``MIN_SEED_SECONDS``) starts a new object, which grows as in
   3; repeated until none is left. Only then are relays scored (segments within
   ``BRIDGE_SECONDS`` of an object, across gaps), so that a relay is decided among all the
   objects that could continue there, and objects are stitched across gaps
   (``tracking.relay.stitch``, best score first, never joining overlapping segments of one sensor).
   Declared targets without GPS or MISTRAM take the discovered objects with the most rows, in
   declaration order; the other discovered objects are named ``O1``, ``O2``, ... in order of
   first appearance. With a single declared target, a discovered object that overlaps no
   other object in time is that target seen at another time (a GPS on another time scale, a
   long outage) and joins it.
5. **Plots, round after round** (``tracking.reassociation``): every plot of a plot-tracked
   sensor goes to the object it fits best within the gates, one per object and scan, scored
   against the objects' smoothed trajectories (its own object's as if it had been left
   out); the objects whose plots changed are re-estimated and the plots associated again
   until no plot changes object. Ambiguous stretches keep their runner-up object and its
   score.
6. **Angle-only plots** (``tracking.angle_plots``): camera and theodolite detections without
   range and without ``track_id`` go, frame by frame, to the object whose line of sight they
   fit, where that object is already known across it and no other object fits nearly as
   well (their own clutter floor: the sensor's detections per frame over the sector they
   span); the share used is in the summary; beyond an object's span, those that continue
   it while it stays known across the line of sight. Where an object's ranged rows reach
   beyond its trajectory (a segment that joined in step 3's last round, which ends without
   re-estimating), the object is re-estimated and step 5 runs again (a plot after missed
   scans that the object's other rows carry it to is scored against it).
7. What is left is unassigned, with the reason.

Objects used for scoring are estimated by the centralised smoother without refinement
passes, registration or refraction (a quick, robust trajectory); the final estimate of every
object is the full smoother on all its rows (``pipeline``).
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from rangeproc.fusion.assemble import PLANE_ELEVATION_SIGMA
from rangeproc.fusion.batch import SensorRows
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.initialise import Prior
from rangeproc.models.measurement import AZIMUTH
from rangeproc.parallel import thread_map
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.angle_plots import angle_owners
from rangeproc.tracking.biased_duplicates import join_biased_duplicates
from rangeproc.tracking.ghosts import ghost_tracks
from rangeproc.tracking.hypotheses import SearchResult, best_hypotheses
from rangeproc.tracking.links import Rival, conflicts, score_links
from rangeproc.tracking.objects import (
    QUICK_ROWS_PER_SENSOR,
    Objects,
    Segment,
    as_batch,
    member_conflict,
)
from rangeproc.tracking.plot_association import SPAN_MARGIN_SECONDS, reassign_members
from rangeproc.tracking.plot_swaps import repair_heads
from rangeproc.tracking.plot_jumps import cut_jumps
from rangeproc.tracking.plot_tails import stray_tails
from rangeproc.tracking.clutter_map import stationary_returns
from rangeproc.tracking.plot_tracker import (GATE_PROBABILITY, PlotTiming, plot_timing,
                                             several_returns, track_plots)
from rangeproc.tracking.reassociation import reassociate_plots
from rangeproc.tracking.return_spread import largest, object_spreads
from rangeproc.tracking.plots import plot_positions, several_objects
from rangeproc.tracking.relay import (
    relay_lone_objects,
    stitch,
)
from rangeproc.tracking.score import ObjectTrack
from rangeproc.tracking.segments import segment_track

log = logging.getLogger(__name__)

#: A segment that starts an object alone: rows and duration (s).
MIN_SEED_ROWS = 10
MIN_SEED_SECONDS = 5.0
#: Growth rounds per object set (each re-estimates the objects that changed).
MAX_ROUNDS = 8
#: Relative cost of a plot (a row without track id: the plot tracker, Python per scan)
#: against a tracked row (a compiled filter step), to start the slowest sensors first.
PLOT_COST = 30
#: Seeds whose quick trajectories discovery computes together: the longest pending one and
#: the runner-ups, on the cores one estimate leaves idle. A runner-up's trajectory is used
#: when it is still the longest seed in its turn (it depends on its own rows only, so the
#: result is the same as computing it then); one absorbed by an earlier object is dropped.
LOOK_AHEAD = 2
#: Relative cost of an anchored object's quick trajectory per row (the process-noise search's
#: filters and the smoother) against a segmented row, to start the slowest jobs first.
ANCHOR_COST = 4
#: ``reason`` values of the association table.
ASSOCIATED = "associated"
CLUTTER = "clutter"
NO_OBJECT = "no object fits"
ANGLE_PLOT = "angle-only plot"
SHORT = "segment too short to start an object"


@dataclass(slots=True)
class Synthesis:
    """The outcome: ``members`` object id -> [(sensor index, row indices)], in object order
    (declared first, then discovered); ``segment_object`` segment id -> object id or None;
    per sensor index ``row_object``/``row_segment``/``row_reason`` (N,) arrays over its
    SensorRows; the hypothesis searches run (``searches``); ids of discovered objects;
    per sensor index with angle-only plots, (their rows, those associated) (step 6); per plot
    sensor index, its stationary returns (``tracking.clutter_map.stationary_returns``); the
    rounds of step 5 (``tracking.reassociation``: rounds, converged, plots moved per round)
    and its ambiguous stretches (object ids); per object, the spread of its returns within a
    scan of a sensor that gives several returns per object (``tracking.return_spread``,
    (2, 2) m^2 east and north)."""

    members: dict[str, list[tuple[int, np.ndarray]]]
    segments: list[Segment]
    segment_object: dict[int, str | None]
    row_object: dict[int, np.ndarray]
    row_segment: dict[int, np.ndarray]
    row_reason: dict[int, np.ndarray]
    searches: list[SearchResult] = field(default_factory=list)
    discovered: tuple[str, ...] = ()
    angle_plots: dict[int, tuple[int, int]] = field(default_factory=dict)
    stationary: dict[int, list[dict[str, float]]] = field(default_factory=dict)
    plot_rounds: dict = field(default_factory=dict)
    ambiguous: list[dict] = field(default_factory=list)
    return_spread: dict[str, np.ndarray] = field(default_factory=dict)


def _spherical_components(rows: SensorRows, sel: np.ndarray) -> np.ndarray:
    """(M, C) the measured spherical components of rows ``sel`` (range, az, el, rate)."""
    return rows.z[sel][:, :4]


def sensor_segments(sensor: int, rows: SensorRows
                    ) -> tuple[list[Segment], np.ndarray, np.ndarray,
                               tuple[np.ndarray, PlotTiming, list[dict[str, float]]] | None]:
    """Segments of one radar/theodolite, plus its clutter rows, its angle-only plot rows
    (index arrays into ``rows``) and, for a plot sensor, its ranged plot rows with their
    timing (``tracking.plot_tracker.plot_timing``) and stationary returns (None otherwise).
    Segment ids count from 0 (the caller offsets them)."""
    out: list[Segment] = []
    clutter = np.zeros(0, dtype=np.int64)
    angle_plots = np.zeros(0, dtype=np.int64)
    timing = None
    has_range_row = np.isfinite(rows.z[:, 0])

    def add(sel: np.ndarray, track: int, scans: np.ndarray | None = None) -> None:
        t = rows.t[sel]
        out.append(Segment(len(out), sensor, sel, track, float(t[0]), float(t[-1]),
                           bool(has_range_row[sel].mean() > 0.5), scans is not None, scans))

    plots = rows.track < 0
    if plots.any():
        sel = np.flatnonzero(plots)
        if not several_objects(rows.t[sel], rows.z[sel], rows.sigma[sel], rows.s[sel],
                               rows.Qr[sel]):
            plots[:] = False                  # a tracking instrument without track numbers
    for tid in np.unique(rows.track[~plots]):
        sel = np.flatnonzero((rows.track == tid) & ~plots)
        seg = segment_track(rows.t[sel], _spherical_components(rows, sel),
                            angle_columns=(AZIMUTH,))
        for k in range(int(seg.label.max()) + 1 if sel.size else 0):
            add(sel[seg.label == k], int(tid))
    if plots.any():
        sel = np.flatnonzero(plots)
        ranged = sel[has_range_row[sel]]
        angle_plots = sel[~has_range_row[sel]]
        if ranged.size:
            z = rows.z[ranged]
            p, R = plot_positions(z[:, 0], z[:, 1], z[:, 2], rows.sigma[ranged][:, :3],
                                  rows.s[ranged], rows.Qr[ranged])
            planar = bool(np.median(rows.sigma[ranged, 2]) >= PLANE_ELEVATION_SIGMA)
            timing = plot_timing(rows.t[ranged], z[:, 1], p, R, planar)
            several = several_returns(p, R, timing.frame, planar)
            timing = replace(timing, several=several)
            label = repair_heads(rows.t[ranged], p, R, timing.scan,
                                 track_plots(rows.t[ranged], p, R, timing.frame, timing.clock,
                                             planar, timing.stamp_sigma, several=several,
                                             tails=timing.silent))
            label = cut_jumps(rows.t[ranged], p, R, timing.clock,
                              stray_tails(timing.silent, label), timing.stamp_sigma)
            if not several:                                   # one return per object a scan
                label, ghosts = ghost_tracks(timing.frame, z[:, 0], z[:, 1], z[:, 2],
                                             rows.sigma[ranged][:, :3], label, planar)
                if ghosts:
                    log.debug("%s: %d plot tracks are multipath ghosts (clutter)",
                              sensor, ghosts)
            clutter = ranged[label < 0]
            for k in range(int(label.max()) + 1 if label.size else 0):
                add(ranged[label == k], -1, timing.scan[label == k])
            timing = (ranged, timing, stationary_returns(p, R, timing.scan, planar))
    return out, clutter, angle_plots, timing


def _grow(objects: Objects, names: list[str], pending: list[Segment],
          segs_of: dict[str, list[Segment]], searches: list[SearchResult],
          new_id: Callable[[], int], replaced: dict[int, tuple[int, int]],
          tick: Callable[[], None], relay: bool,
          rivals: Mapping[int, Rival] | None = None) -> list[Segment]:
    """Attach pending segments to the objects ``names`` until none joins (step 3); only
    segments overlapping an object in time unless ``relay``."""
    for _ in range(MAX_ROUNDS):
        if not pending:
            break
        pending, links = score_links(objects, pending, names, new_id, replaced, relay, rivals)
        links = {(i, j): w for (i, j), w in links.items()
                 if not member_conflict(objects, names[j], pending[i], segs_of)}
        if not links:
            break
        order = sorted(range(len(pending)), key=lambda i: pending[i].t0)
        rank = {i: k for k, i in enumerate(order)}
        ordered = [pending[i] for i in order]
        result = best_hypotheses(len(ordered), {(rank[i], j): w for (i, j), w in links.items()},
                                 conflicts(ordered))
        searches.append(result)
        changed: set[str] = set()
        left = []
        for k, seg in enumerate(ordered):
            j = result.best.choice[k]
            if j < 0:
                left.append(seg)
                continue
            name = names[j]
            objects.members[name].append((seg.sensor, seg.rows))
            segs_of.setdefault(name, []).append(seg)
            changed.add(name)
        pending = left
        if not pending:
            break
        objects.estimate_many(sorted(changed))
        tick()
        if not changed:
            break
    return pending


def synthesise(rows: Mapping[int, SensorRows], kinds: Sequence[str],
               sensor_ids: tuple[str, ...], anchors: Mapping[str, list[int]],
               declared: Sequence[str], settings: EstimatorSettings,
               priors: Mapping[str, Prior] | None = None,
               tick: Callable[[], None] = lambda: None) -> Synthesis:
    """Associate every radar/theodolite row with an object (module docstring).

    Args:
        rows: sensor index -> its assembled rows (every non-INS sensor).
        kinds: sensor kind per sensor index.
        sensor_ids: the sensor ids (index order).
        anchors: declared target id -> sensor indices of its GPS/MISTRAM.
        declared: the declared target ids, in config order.
        settings: the estimator settings (the quick trajectories drop the refinements).
        priors: declared target id -> its ``initial`` state (starts MISTRAM-only anchors).
    """
    objects = Objects(rows, sensor_ids, settings, priors or {})
    segments: list[Segment] = []
    clutter: dict[int, np.ndarray] = {}
    angle_plots: dict[int, np.ndarray] = {}
    timings: dict[int, tuple[np.ndarray, PlotTiming, list[dict[str, float]]]] = {}
    tracked = [i for i, r in rows.items()
               if kinds[i] in ("radar", "theodolite") and r.t.size]
    for name in declared:
        sensors = [i for i in anchors.get(name, []) if i in rows and rows[i].t.size]
        objects.members[name] = [(i, np.arange(rows[i].t.size)) for i in sensors]
    starting = [n for n in declared if objects.members[n]]

    def first_job(job: int | str):   # a sensor's segments, or an anchored object's trajectory
        return sensor_segments(job, rows[job]) if isinstance(job, int) else \
            objects.quick_track(objects.members[job], objects.priors.get(job))

    def first_cost(job: int | str) -> float:
        if isinstance(job, int):
            return rows[job].t.size + PLOT_COST * int((rows[job].track < 0).sum())
        return ANCHOR_COST * sum(min(sel.size, QUICK_ROWS_PER_SENSOR)
                                 for _, sel in objects.members[job])

    done = thread_map(first_job, [*tracked, *starting], cost=first_cost)   # side by side
    for i, (segs, clutter_rows, angle_rows, timing) in zip(tracked, done):
        clutter[i], angle_plots[i] = clutter_rows, angle_rows
        if timing is not None:
            timings[i] = timing
        first = len(segments)                                  # ids in sensor order
        segments.extend(replace(s, id=first + s.id) for s in segs)
    tick()
    searches: list[SearchResult] = []
    segs_of: dict[str, list[Segment]] = {}
    started = {n: objects.adopt(n, track) for n, track in zip(starting, done[len(tracked):])}
    anchored = [name for name in declared if started.get(name, False)]
    replaced: dict[int, tuple[int, int]] = {}

    def new_id() -> int:
        new_id.n += 1                                    # type: ignore[attr-defined]
        return new_id.n - 1                              # type: ignore[attr-defined]

    new_id.n = len(segments)                             # type: ignore[attr-defined]
    pending = _grow(objects, anchored, list(segments), segs_of, searches, new_id, replaced,
                    tick, relay=False)
    discovered: list[str] = []
    unstartable: list[Segment] = []
    ahead: dict[int, ObjectTrack | None] = {}      # seed segment id -> its quick trajectory
    while True:
        seeds = sorted((s for s in pending if s.has_range and s.rows.size >= MIN_SEED_ROWS
                        and s.t1 - s.t0 >= MIN_SEED_SECONDS),
                       key=lambda s: (-s.rows.size, s.t0))      # the longest, then earliest
        if not seeds:
            break
        seed = seeds[0]
        name = f"_new{len(discovered)}"
        objects.members[name] = [(seed.sensor, seed.rows)]
        pending = [s for s in pending if s.id != seed.id]
        seed_ids = {s.id for s in seeds}
        ahead = {k: v for k, v in ahead.items() if k in seed_ids}
        if seed.id not in ahead:
            todo = [s for s in seeds[:LOOK_AHEAD] if s.id not in ahead]
            ahead.update(zip((s.id for s in todo), thread_map(
                lambda s: objects.quick_track([(s.sensor, s.rows)]), todo)))
        if not objects.adopt(name, ahead.pop(seed.id)):
            del objects.members[name]
            unstartable.append(seed)
            continue
        segs_of[name] = [seed]
        discovered.append(name)
        by_id = {s.id: s for s in pending}
        rivals = {k: Rival(objects.rows[by_id[k].sensor].t[by_id[k].rows], track)
                  for k, track in ahead.items() if track is not None and k in by_id}
        pending = _grow(objects, [*anchored, *discovered], pending, segs_of, searches, new_id,
                        replaced, tick, relay=False, rivals=rivals)
    pending = _grow(objects, [*anchored, *discovered], pending, segs_of, searches, new_id,
                    replaced, tick, relay=True)
    discovered = stitch(objects, anchored, discovered, segs_of)
    discovered = relay_lone_objects(objects, declared, anchored, discovered, segs_of)
    discovered = join_biased_duplicates(objects, [*anchored, *discovered], discovered, segs_of)
    final = sorted([*pending, *unstartable, *(s for segs in segs_of.values() for s in segs)],
                   key=lambda s: s.id)
    step5 = reassociate_plots(objects, [*anchored, *discovered], final, clutter, timings)
    # an object whose every plot went elsewhere (or nowhere) in step 5 is no object
    discovered = [k for k in discovered if objects.members.get(k)]
    angle_owner = _associate_angle_plots(objects, [*anchored, *discovered], angle_plots)
    if _widen_spans(objects, [*anchored, *discovered], angle_plots):   # step 5 again
        step5 = reassociate_plots(objects, [*anchored, *discovered], final, clutter, timings)
        discovered = [k for k in discovered if objects.members.get(k)]
    names = _name_objects(objects, declared, anchored, discovered)
    members = {names[k]: objects.members[k] for k in [*declared, *discovered]
               if k in names and objects.members.get(k)}
    segment_object: dict[int, str | None] = {s.id: None for s in final}
    for key, segs in segs_of.items():
        for s in segs:
            segment_object[s.id] = names.get(key)
    row_object, row_segment, row_reason = _row_tables(rows, kinds, final, segment_object,
                                                      clutter, angle_plots)
    for i, (plots, keys) in angle_owner.items():             # step 6: by line of sight
        owner = np.array([names.get(k, "") if k else "" for k in keys], dtype=object)
        row_object[i][plots] = owner
        row_reason[i][plots] = np.where(owner != "", ASSOCIATED, ANGLE_PLOT)
    for i, (plots, keys) in step5.owners.items():            # step 5: plot by plot
        owner = np.array([names.get(k, "") if k else "" for k in keys], dtype=object)
        row_object[i][plots] = owner
        row_reason[i][plots] = np.where(owner != "", ASSOCIATED,
                                        np.where(np.isin(plots, clutter.get(i, [])), CLUTTER,
                                                 NO_OBJECT))
    spreads = _return_spreads(rows, timings, row_object)
    angle_used = {i: (int(rows.size), int(sum(bool(k) for k in keys)))
                  for i, (rows, keys) in angle_owner.items()}
    stationary = {i: cells for i, (_, _, cells) in timings.items()}
    ambiguous = [{**a, "object": names[a["object"]], "runner_up": names[a["runner_up"]]}
                 for a in step5.ambiguous if a["object"] in names and a["runner_up"] in names]
    return Synthesis(members, final, segment_object, row_object, row_segment, row_reason,
                     searches=searches,
                     discovered=tuple(names[k] for k in discovered if k in names),
                     angle_plots=angle_used, stationary=stationary,
                     plot_rounds={"rounds": step5.rounds, "converged": step5.converged,
                                  "moved_plots": step5.moved},
                     ambiguous=ambiguous, return_spread=spreads)


def _associate_angle_plots(objects: Objects, keys: list[str],
                           angle_plots: Mapping[int, np.ndarray]
                           ) -> dict[int, tuple[np.ndarray, list[str]]]:
    """Step 6: every angle-only plot (a camera's or theodolite's detection without range)
    goes to the object whose line of sight it fits (``tracking.angle_plots``); the
    memberships change accordingly. Returns sensor -> (rows, the key of each one's object
    or "")."""
    keys = [k for k in keys if k in objects.tracks]
    out: dict[int, tuple[np.ndarray, list[str]]] = {}
    for i, rows in angle_plots.items():
        if rows.size == 0 or not keys:
            continue
        batch = as_batch(objects.rows[i], objects.sensor_ids, i)
        owner = angle_owners(batch, rows, [objects.tracks[k] for k in keys])
        objects.members = reassign_members(objects.members, i, rows, owner, keys)
        out[i] = (rows, [keys[j] if j >= 0 else "" for j in owner])
    return out


def _widen_spans(objects: Objects, keys: list[str],
                 angle_plots: Mapping[int, np.ndarray]) -> list[str]:
    """The objects of ``keys`` whose member rows after step 6, its angle-only plots
    (``angle_plots``: sensor -> rows) left out, reach more than ``SPAN_MARGIN_SECONDS``
    beyond either end of their trajectory, re-estimated on all their rows: step 5 then
    scores the plots of that widened span against them (a radar plot after missed scans that
    only a theodolite track carries the object to). Rows lie beyond the trajectory when a
    segment joined it in the last round of :func:`_grow`, which ends without re-estimating
    (module docstring, step 6). The camera detections by which step 6 continues an object
    beyond its span widen nothing: carried by bearings alone, the span's ends are known
    across the line of sight but hardly along it, and scored against them a radar's clutter
    plot far along the same bearing passes the gate (measured cases in the methods page,
    several objects, section 6)."""
    grown = []
    for k in keys:
        track, members = objects.tracks.get(k), objects.members.get(k)
        if track is None or track.t.size == 0 or not members:
            continue
        t = np.concatenate([objects.rows[i].t[sel[~np.isin(sel, angle_plots.get(i, []))]]
                            for i, sel in members])
        if t.size and (t.min() < track.t[0] - SPAN_MARGIN_SECONDS
                or t.max() > track.t[-1] + SPAN_MARGIN_SECONDS):
            grown.append(k)
    tracks = thread_map(lambda k: objects.quick_track(objects.members[k], objects.priors.get(k)),
                        grown, cost=lambda k: sum(s.size for _, s in objects.members[k]))
    return [k for k, track in zip(grown, tracks) if objects.adopt(k, track)]


def _name_objects(objects: Objects, declared: Sequence[str], anchored: list[str],
                  discovered: list[str]) -> dict[str, str]:
    """Internal key -> output id: declared targets without anchors take the biggest
    discovered objects in declaration order; the rest are O1, O2, ... by first appearance."""
    size = {k: sum(sel.size for _, sel in objects.members[k]) for k in discovered}
    first = {k: min(float(objects.rows[i].t[sel].min()) for i, sel in objects.members[k])
             for k in discovered}
    names = {k: k for k in anchored}
    free = sorted(discovered, key=lambda k: -size[k])
    for name in declared:
        if name in anchored or not free:
            continue
        names[free.pop(0)] = name
    for n, k in enumerate(sorted(free, key=lambda k: first[k]), start=1):
        names[k] = f"O{n}"
    return names


def _return_spreads(rows: Mapping[int, SensorRows],
                    timings: Mapping[int, tuple[np.ndarray, PlotTiming, list]],
                    row_object: Mapping[int, np.ndarray]) -> dict[str, np.ndarray]:
    """Object id -> the spread of its returns within a scan (``tracking.return_spread``,
    (2, 2) m^2), the largest over the plot sensors that give several returns per object a
    scan (``tracking.plot_tracker.several_returns``, as the tracker decides it); ``timings``
    as for ``tracking.reassociation.reassociate_plots``, ``row_object`` the final owners."""
    gate = float(chi2_ppf(GATE_PROBABILITY, 3))
    out: dict[str, np.ndarray] = {}
    for i, (ranged, timing, _) in timings.items():
        r = rows[i]
        z = r.z[ranged]
        p, R = plot_positions(z[:, 0], z[:, 1], z[:, 2], r.sigma[ranged][:, :3], r.s[ranged],
                              r.Qr[ranged])
        usable = np.isfinite(p).all(axis=1) & np.isfinite(R).all(axis=(1, 2))
        planar = bool(np.median(r.sigma[ranged, 2]) >= PLANE_ELEVATION_SIGMA)
        p, R, frame = p[usable], R[usable], timing.frame[usable]
        owner = row_object[i][ranged][usable]
        if not (owner != "").any() or not several_returns(p, R, frame, planar):
            continue
        for name, S in object_spreads(p, R, frame, owner, gate).items():
            out[name] = largest(out.get(name), S)
    return out


def _row_tables(rows: Mapping[int, SensorRows], kinds: Sequence[str], segments: list[Segment],
                segment_object: Mapping[int, str | None], clutter: Mapping[int, np.ndarray],
                angle_plots: Mapping[int, np.ndarray]
                ) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray], dict[int, np.ndarray]]:
    """Per radar/theodolite sensor: (N,) object id (""), segment id (-1) and reason."""
    obj: dict[int, np.ndarray] = {}
    seg: dict[int, np.ndarray] = {}
    why: dict[int, np.ndarray] = {}
    for i, r in rows.items():
        if kinds[i] not in ("radar", "theodolite"):
            continue
        n = r.t.size
        obj[i] = np.full(n, "", dtype=object)
        seg[i] = np.full(n, -1, dtype=np.int64)
        why[i] = np.full(n, NO_OBJECT, dtype=object)
        if i in clutter:
            why[i][clutter[i]] = CLUTTER
        if i in angle_plots:
            why[i][angle_plots[i]] = ANGLE_PLOT
    for s in segments:
        name = segment_object[s.id]
        seg[s.sensor][s.rows] = s.id
        if name is not None:
            obj[s.sensor][s.rows] = name
            why[s.sensor][s.rows] = ASSOCIATED
        elif not s.has_range or s.rows.size < MIN_SEED_ROWS:
            why[s.sensor][s.rows] = SHORT if s.has_range else NO_OBJECT
    return obj, seg, why
