"""Step 5 of track synthesis: every plot re-associated with the smoothed objects, round after
round, until the assignment is stable; the ambiguous stretches and their runner-up.

Offline, rangeproc sees each object's whole trajectory. The objects' quick trajectories
(``tracking.objects``) are fixed-interval smoothed (Rauch, Tung and Striebel 1965), so a plot
is scored against the object's state estimated from its data before *and* after the plot,
not against a prediction from the past as a real-time tracker does. One **round** associates
every plot of every plot sensor (:func:`associate_sensor`): within each scan the plots and
the objects whose gates they pass are paired by the assignment of the largest summed
log-likelihood ratio (``tracking.plot_association``), with the rules below for the plots no
object gates. The objects whose plots changed are then re-estimated from their new rows and
the next round scores every plot against the new trajectories; this repeats until no plot
changes object (at most ``MAX_ROUNDS`` rounds). It is the hard-decision form of the
expectation-maximisation of the Probabilistic Multi-Hypothesis Tracker (Streit and
Luginbuhl 1995: assignment given the smoothed tracks, then the tracks smoothed given the
assignment), each round raising the joint likelihood of the assignment and the trajectories;
MATLAB's ``smootherJIPDA`` plays the same role for a JIPDA tracker.

Rules of a round, per sensor (the first round starts from the plot tracks' assignment, each
later one from the previous round's):

* A plot is scored against the object that holds it as if left out of that object's
  trajectory (``tracking.score.score_rows_left_out``), so a sparse object does not keep
  plots only because its track leans towards them.
* A plot no object gates stays with the object that held it only where that object is less
  certain than the plot (:func:`uncertain_at`: a precise object does not keep a plot it
  cannot gate) and the plot is no lone outlier of it (:func:`isolated_outliers`: a clutter
  plot taken in a missed scan is not kept), and never beside another plot of the same scan
  (:func:`one_plot_per_frame`); on a sensor that gives several returns of one object a
  frame (a lidar), a plot is no object's that another object holding a plot of the same
  frame explains better: it is that object's further return (:func:`further_returns`).
* An object whose trajectory gates none of some of its own plots while less certain than
  those plots there is re-estimated with a refinement pass (:func:`doubtful`,
  ``Objects.refined_track``; a first pass badly linearised where plots alone range the
  object), and the plots no object gated are associated again.
* Orphan plots of plot tracks join an object whose span they lead up to
  (``tracking.plot_association.extend_objects``).

**Ambiguity.** For each plot of the last round that the assignment gave an object, the
runner-up is the other object with the highest log-likelihood ratio for it, and the margin
the difference. A run of at least ``MIN_AMBIGUOUS_PLOTS`` consecutive plots of one object
and sensor, each with the same runner-up within ``AMBIGUITY_LLR`` of the chosen object, is
an ambiguous stretch (two objects close together); it is reported with the runner-up and
the summed margin, the log-likelihood ratio of the chosen assignment over giving those plots
to the runner-up (the scan's other plots as chosen).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.parallel import thread_map
from rangeproc.quantiles import chi2_ppf
from rangeproc.tracking.objects import Objects, Segment, as_batch
from rangeproc.tracking.plot_association import (
    GATE_PROBABILITY,
    SPAN_MARGIN_SECONDS,
    assign_per_scan,
    clutter_floor,
    extend_objects,
    plot_llr,
    reassign_members,
)
from rangeproc.tracking.plot_tracker import PlotTiming
from rangeproc.tracking.score import ObjectTrack, score_rows, score_rows_left_out

#: Rounds of re-association at most (each re-estimates the objects whose plots changed); the
#: assignment usually settles in two or three.
MAX_ROUNDS = 4
#: A plot no object gates stays with its object (less certain than the plot there) unless it
#: is a lone outlier of that object (:func:`isolated_outliers`): outside this chi-square
#: probability of it, scored as left out, while its neighbours are inside. A clutter plot
#: the plot tracker took in a missed scan (NIS 100 against its own object) is not kept.
KEEP_PROBABILITY = 1.0 - 1e-6
#: A plot is ambiguous when its object is less than e^3 (about 20) times likelier than the
#: runner-up (log-likelihood ratio margin).
AMBIGUITY_LLR = 3.0
#: After the first round a plot leaves the object that holds it (and still gates it) only for
#: an object this much likelier (log-likelihood ratio; e^3, about 20 times): the rounds
#: settle instead of passing close plots to and fro between two objects.
SWITCH_LLR = 3.0
#: Consecutive ambiguous plots of one object, sensor and runner-up that make a reported
#: stretch (a single close plot is noise, not a second hypothesis).
MIN_AMBIGUOUS_PLOTS = 3


@dataclass(frozen=True, slots=True)
class SensorPlots:
    """What one plot sensor's rounds share (computed once): its plot rows ``rows`` (P,),
    their frame numbers (P,), which belong to a plot track (``tracked`` (P,) bool), the
    clutter floor of each (``plot_association.clutter_floor`` over their scans, (P,)), the
    sensor's revisit period (s) and whether it gives several returns of one object a frame
    (``PlotTiming.several``)."""

    rows: np.ndarray
    frame: np.ndarray
    tracked: np.ndarray
    floor: np.ndarray
    revisit: float
    several: bool = False


def sensor_plots(objects: Objects, sensor: int, rows: np.ndarray, frame: np.ndarray,
                 scan: np.ndarray, tracked: np.ndarray, n_clutter: int,
                 revisit: float, several: bool = False) -> SensorPlots:
    """:class:`SensorPlots` of ``sensor``'s plot rows ``rows`` (P,) with their frame and scan
    numbers (P,); its clutter floor from its ``n_clutter`` clutter plots."""
    batch = as_batch(objects.rows[sensor], objects.sensor_ids, sensor)
    return SensorPlots(rows, frame, tracked, clutter_floor(batch, rows, scan, n_clutter),
                       revisit, several)


@dataclass(slots=True)
class Reassociation:
    """The outcome of step 5: per sensor (its plot rows (P,), the key of each one's object or
    ""); the rounds run, whether the last changed nothing, the plots that changed object in
    each round; the ambiguous stretches (module docstring) as dicts with the keys
    ``object``, ``runner_up`` (object keys), ``sensor`` (index), ``t0``, ``t1`` (s),
    ``n_plots`` and ``llr_margin``."""

    owners: dict[int, tuple[np.ndarray, list[str]]] = field(default_factory=dict)
    rounds: int = 0
    converged: bool = True
    moved: list[int] = field(default_factory=list)
    ambiguous: list[dict] = field(default_factory=list)


def reassociate_plots(objects: Objects, keys: list[str], segments: Sequence[Segment],
                      clutter: Mapping[int, np.ndarray],
                      timings: Mapping[int, tuple[np.ndarray, PlotTiming, list]]
                      ) -> Reassociation:
    """Step 5 (module docstring): every plot of a plot-tracked sensor (its plot tracks' rows
    and its clutter) associated with the objects ``keys`` of ``objects``, round after round;
    the memberships and trajectories of ``objects`` change accordingly. ``timings``: sensor
    -> (its ranged plot rows, their timing, ...)."""
    parts: dict[int, list[np.ndarray]] = {}
    for seg in segments:
        if seg.plot:
            parts.setdefault(seg.sensor, []).append(seg.rows)
    out = Reassociation()
    keys = [k for k in keys if k in objects.tracks]
    if not parts or not keys:
        return out
    sensors = sorted(parts)
    plots: dict[int, SensorPlots] = {}
    for i in sensors:
        rows = np.unique(np.concatenate([*parts[i], clutter.get(i, np.zeros(0, np.int64))]))
        ranged, timing, _ = timings[i]
        at = np.searchsorted(ranged, rows)
        plots[i] = sensor_plots(objects, i, rows, timing.frame[at], timing.scan[at],
                                np.isin(rows, np.concatenate(parts[i])),
                                clutter.get(i, np.zeros(0)).size, timing.revisit,
                                timing.several)
    refined: set[str] = set()
    held = {i: _keys_of(held_by(objects, keys, i, plots[i].rows), keys) for i in sensors}
    last_llr: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    owners: dict[int, np.ndarray] = {}
    seen = {_state(held)}
    while True:
        out.rounds += 1
        changed: set[str] = set()
        moved = 0
        for i in sensors:
            owner, llr, assigned = associate_sensor(objects, keys, i, plots[i], refined,
                                                    settled=out.rounds > 1)
            now = _keys_of(owner, keys)
            diff = now != held[i]
            moved += int(diff.sum())
            changed.update(str(k) for k in np.concatenate([now[diff], held[i][diff]]) if k)
            held[i] = now
            last_llr[i] = (llr, assigned)
            owners[i] = owner
            out.owners[i] = (plots[i].rows, [str(k) for k in now])
        out.moved.append(moved)
        out.converged = not changed
        state = _state(held)
        if not changed or state in seen or out.rounds >= MAX_ROUNDS:
            break                            # stable, a cycle (it is not), or enough rounds
        seen.add(state)
        emptied = [k for k in changed if not objects.members.get(k)]
        for k in emptied:                       # an object left without rows is no object
            objects.tracks.pop(k, None)
        keys = [k for k in keys if k not in emptied]
        redo = [k for k in keys if k in changed]
        tracks = thread_map(lambda k: objects.refined_track(k) if k in refined
                            else objects.quick_track(objects.members[k], objects.priors.get(k)),
                            redo, cost=lambda k: sum(s.size for _, s in objects.members[k]))
        for k, track in zip(redo, tracks):
            objects.adopt(k, track)
        if not keys:
            break
    for i in sensors:
        llr, assigned = last_llr[i]
        out.ambiguous.extend(ambiguous_stretches(
            objects.rows[i].t[plots[i].rows], llr, np.where(assigned, owners[i], -1), keys, i))
    return out


def _state(held: Mapping[int, np.ndarray]) -> int:
    """A hash of an assignment (sensor -> (P,) object key per plot)."""
    return hash(tuple(tuple(held[i]) for i in sorted(held)))


def held_by(objects: Objects, keys: Sequence[str], sensor: int, rows: np.ndarray
            ) -> np.ndarray:
    """(P,) index into ``keys`` of the object holding each of ``sensor``'s rows ``rows``, -1
    for none."""
    out = np.full(rows.size, -1, dtype=np.int64)
    for j, k in enumerate(keys):
        for i, sel in objects.members.get(k, []):
            if i == sensor:
                out[np.isin(rows, sel)] = j
    return out


def _keys_of(owner: np.ndarray, keys: Sequence[str]) -> np.ndarray:
    """(P,) object array: the key of each owner index (``keys``), "" for -1."""
    return np.array([keys[j] if j >= 0 else "" for j in owner], dtype=object)


def associate_sensor(objects: Objects, keys: list[str], sensor: int, plots: SensorPlots,
                     refined: set[str], settled: bool = False
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One round for one sensor's plots ``plots`` (module docstring). Objects refined here
    join ``refined``; the memberships of ``objects`` are updated. Returns (owner (P,) index
    into ``keys`` or -1, the llr matrix (P, K) of the assignment, whether the assignment gave
    each plot its owner (P,) bool)."""
    batch = as_batch(objects.rows[sensor], objects.sensor_ids, sensor)
    rows, frame, floor = plots.rows, plots.frame, plots.floor
    before = held_by(objects, keys, sensor, rows)

    def assign() -> tuple[np.ndarray, np.ndarray]:
        llr = plot_llr(batch, rows, [objects.tracks[k] for k in keys], frame, before, floor,
                       margin=0.0 if settled else SPAN_MARGIN_SECONDS)
        return llr, assign_per_scan(llr, frame)

    llr, owner = assign()
    if settled:                      # a later round: a plot leaves the object that holds it
        at = np.flatnonzero((before >= 0) & (owner != before))      # (and still gates it)
        at = at[np.isfinite(llr[at, before[at]])]                    # only for a clearly
        gain = np.where(owner[at] >= 0, llr[at, np.maximum(owner[at], 0)],    # better one
                        -np.inf) - llr[at, before[at]]
        stay = at[gain < SWITCH_LLR]
        owner[stay] = before[stay]
    gated = np.isfinite(llr).any(axis=1)
    again = [k for k in doubtful(objects, keys, batch, rows, before, gated)
             if k not in refined]
    if again:             # trajectories that miss their own plots: refined, and the plots
        #                   no object gated are associated again
        for k, track in zip(again, thread_map(objects.refined_track, again)):
            objects.adopt(k, track)
        refined.update(again)
        llr2, owner2 = assign()
        gated2 = np.isfinite(llr2).any(axis=1)
        rescue = ~gated & gated2
        owner = np.where(rescue, owner2, owner)
        llr = np.where(rescue[:, None], llr2, llr)
        gated = gated | gated2
    assigned = owner >= 0
    keep = before >= 0                 # an ungated plot stays with the object that held it
    for j in np.unique(before[keep & ~gated]):       # only where that object is less
        own = np.flatnonzero((before == j) & ~gated)     # certain than the plot and it is no
        track = objects.tracks[keys[j]]                   # lone outlier
        keep[own] = (uncertain_at(track, batch, rows[own])
                     & ~isolated_outliers(track, batch, rows, before == j, own))
    owner = np.where(gated, owner, np.where(keep, before, -1))
    if settled:                  # a later round moves plots between objects, never drops one
        owner = np.where((owner < 0) & (before >= 0), before, owner)  # the first kept
    owner = extend_objects(batch, rows, [objects.tracks[k] for k in keys], frame, owner,
                           plots.tracked, floor, plots.revisit)
    owner = one_plot_per_frame(objects, keys, batch, rows, owner, gated, frame)
    if plots.several:
        owner = further_returns(owner, llr, frame)
    objects.members = reassign_members(objects.members, sensor, rows, owner, keys)
    return owner, llr, assigned & (owner >= 0)


def ambiguous_stretches(t: np.ndarray, llr: np.ndarray, owner: np.ndarray,
                        keys: Sequence[str], sensor: int) -> list[dict]:
    """The ambiguous stretches (module docstring) of one sensor's plots at times ``t`` (P,)
    s, scored ``llr`` (P, K) (-inf outside a gate) against the objects ``keys`` (K,), that
    the per-scan assignment gave to ``owner`` (P,) (index into ``keys``, -1: not given by
    the assignment). ``sensor`` is recorded in each stretch."""
    out: list[dict] = []
    if llr.shape[1] < 2 or not (owner >= 0).any():
        return out
    given = np.flatnonzero(owner >= 0)
    others = llr[given].copy()
    others[np.arange(given.size), owner[given]] = -np.inf
    rival = np.full(owner.size, -1, dtype=np.int64)
    margin = np.full(owner.size, np.inf)
    rival[given] = np.argmax(others, axis=1)
    margin[given] = llr[given, owner[given]] - others[np.arange(given.size), rival[given]]
    close = margin < AMBIGUITY_LLR                                 # inf (no rival): not close
    for j in range(llr.shape[1]):
        mine = np.flatnonzero(owner == j)
        mine = mine[np.argsort(t[mine], kind="stable")]
        if mine.size < MIN_AMBIGUOUS_PLOTS:
            continue
        runner = np.where(close[mine], rival[mine], -1)
        edges = np.flatnonzero(np.diff(np.concatenate([[-2], runner, [-2]])) != 0)
        for a, b in zip(edges[:-1], edges[1:]):
            if runner[a] < 0 or b - a < MIN_AMBIGUOUS_PLOTS:
                continue
            run = mine[a:b]
            out.append({"object": keys[j], "runner_up": keys[int(runner[a])],
                        "sensor": sensor, "t0": float(t[run[0]]), "t1": float(t[run[-1]]),
                        "n_plots": int(run.size), "llr_margin": float(margin[run].sum())})
    return out


def doubtful(objects: Objects, keys: list[str], batch: MeasurementBatch, rows: np.ndarray,
             before: np.ndarray, gated: np.ndarray) -> list[str]:
    """The objects (keys) whose quick trajectory gates none of some of their own plots (rows
    ``rows`` of ``batch``, ``before`` the index into keys of the object each belongs to, -1
    none; ``gated`` whether any object gated it) where that trajectory is less certain than
    the plot: a first pass badly linearised where the plots alone range the object, which
    the refinement passes repair. A precise trajectory (GPS) that misses a plot has met a
    wild plot, not its own error."""
    return [keys[j] for j in np.unique(before[(before >= 0) & ~gated])
            if uncertain_at(objects.tracks[keys[j]], batch,
                            rows[(before == j) & ~gated]).any()]


def isolated_outliers(track: ObjectTrack, batch: MeasurementBatch, rows: np.ndarray,
                      mine: np.ndarray, sel: np.ndarray) -> np.ndarray:
    """(S,) bool for the plots ``rows[sel]`` (S,) of the object of ``track`` (``mine`` (P,):
    which of ``rows`` are its plots): outside the chi-square gate ``KEEP_PROBABILITY`` of the
    object's trajectory (scored as left out of it) while its plots before and after in time
    fit it (inside the association gate ``GATE_PROBABILITY``): a lone outlier, e.g. a
    clutter plot the plot tracker took in a scan that missed the object. A run of such plots,
    or one between plots the trajectory fits only barely, is the trajectory's failure, not
    the plots' (a sparse object whose motion model went astray where only a slow radar sees
    it: its good plots lie at NIS 20-50), and is kept."""
    own = np.flatnonzero(mine)
    _, nis, _ = score_rows_left_out(batch, rows[own], track, rows[own])
    dof = np.maximum(np.isfinite(batch.z[rows[own], :4]).sum(axis=1), 1)
    out = nis > chi2_ppf(KEEP_PROBABILITY, dof)                    # NaN: not outside
    astray = nis > chi2_ppf(GATE_PROBABILITY, dof)                 # NaN: fits
    lone = out.copy()
    lone[1:] &= ~astray[:-1]
    lone[:-1] &= ~astray[1:]
    return lone[np.searchsorted(own, sel)]


def uncertain_at(track: ObjectTrack, batch: MeasurementBatch, sel: np.ndarray) -> np.ndarray:
    """(M,) bool: at the times of ``batch`` rows ``sel`` (M,), the trajectory's position
    sigma (root of the trace, m) exceeds the row's range sigma, or the trajectory does not
    reach that time (a quick trajectory may start after its object's first plots)."""
    t = batch.t[sel]
    k = np.clip(np.searchsorted(track.t, t), 0, track.t.size - 1)
    spread_m = np.sqrt(np.trace(track.P[k, :3, :3], axis1=1, axis2=2))
    return (spread_m > batch.sigma[sel, 0]) | (t < track.t[0]) | (t > track.t[-1])


def further_returns(owner: np.ndarray, llr: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """``owner`` (P,) (index into the objects, -1 none) with the further returns of other
    objects unassigned, for a sensor that gives several returns of one object a frame (a
    lidar's hull points). Each object still takes one plot a frame (the per-frame
    assignment, :func:`one_plot_per_frame`), so an object's second return, within the wide
    gate of a ship beside it, went to the ship. A plot given to an object is left to no
    object where another object holding a plot of the same frame explains it better
    (``llr`` (P, K), -inf outside a gate): it is that object's further return, not the
    other's plot. ``frame`` (P,)."""
    out = owner.copy()
    held = np.flatnonzero(owner >= 0)
    if held.size == 0:
        return out
    frames, at = np.unique(frame[held], return_inverse=True)
    holds = np.zeros((frames.size, llr.shape[1]), dtype=bool)      # frame x object
    holds[at, owner[held]] = True
    rival = np.where(holds[at], llr[held], -np.inf)                  # objects of the frame
    rival[np.arange(held.size), owner[held]] = -np.inf
    mine = llr[held, owner[held]]
    out[held[rival.max(axis=1) > mine]] = -1          # -inf against a gated rival: theirs
    return out


def one_plot_per_frame(objects: Objects, keys: list[str], batch: MeasurementBatch,
                       rows: np.ndarray, owner: np.ndarray, gated: np.ndarray,
                       frame: np.ndarray) -> np.ndarray:
    """``owner`` (P,) (index into ``keys``, -1 none, of the object each plot row ``rows`` goes
    to) with at most one plot per object and frame (``frame`` (P,)): an object is one
    reflector, seen once per scan. Where an object holds several plots of one frame (a plot
    it held that no object gated, beside the plot the per-frame assignment gave it), the
    gated plot stays (``gated`` (P,)), else the one likelier under the object's trajectory;
    the others are unassigned."""
    out = owner.copy()
    held = np.flatnonzero(out >= 0)
    if held.size == 0:
        return out
    pair = out[held].astype(np.int64) * (int(frame.max()) + 1) + frame[held]
    _, inverse, count = np.unique(pair, return_inverse=True, return_counts=True)
    for g in np.flatnonzero(count > 1):
        idx = held[inverse == g]
        track = objects.tracks.get(keys[int(out[idx[0]])])
        score = np.where(gated[idx], np.inf, 0.0)
        if track is not None and track.t.size:
            _, _, ll = score_rows(batch, rows[idx], track)
            score = score + np.nan_to_num(ll, nan=-np.inf)
        keep = idx[int(np.argmax(score))]
        out[idx[idx != keep]] = -1
    return out
