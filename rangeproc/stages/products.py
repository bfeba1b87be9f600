"""Stage 6, products: each object's smoothed state on the output grid, each sensor's residuals,
the summary's per-object and per-sensor figures, and the plausibility lines that need the
fused result (a sensor far from the others, a stated sigma far from the data)."""
from __future__ import annotations

import copy
import logging
import math
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from rangeproc.config import Config, SensorSettings
from rangeproc.editing.record import EditRecord
from rangeproc.editing.units import UnitSuspicion, absent_columns, stated_sigma_line
from rangeproc.errors import DataError
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.agreement import FarSensor, far_line, far_sensors, pair_line
from rangeproc.fusion.calibration_summary import calibration_summary, time_offset_summary
from rangeproc.fusion.estimator_types import EstimatorSettings, FusionResult
from rangeproc.fusion.isolated import isolated_objects, leave_out
from rangeproc.fusion.products import sensor_residuals, track_estimate, with_achievable_sigma
from rangeproc.fusion.formation import formation_spans
from rangeproc.fusion.extent import (HEADING_SPEED, Extent, held_heading, object_extent,
                                     plots_only)
from rangeproc.fusion.persistent_offset import persistent_offset
from rangeproc.fusion.reference_point import (reference_extent, reference_variance,
                                              spread_extent)
from rangeproc.fusion.sensor_use import ObjectUse, sensor_use
from rangeproc.io.logs import SensorLog
from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.summary_types import SensorSummary, TargetSummary


log = logging.getLogger(__name__)


#: Gaps between an object's spans up to this many times ``max_gap`` are bridged in the output
#: (``fusion.bridge``); longer ones stay empty.
BRIDGE_FACTOR = 10.0


def _time_span(t: np.ndarray) -> dict[str, float | None]:
    """``t_first``, ``t_last`` (s, range time scale) of a sensor's screened rows (None when
    it has none)."""
    return {"t_first": float(t.min()) if t.size else None,
            "t_last": float(t.max()) if t.size else None}


def stated_position_sigma(sensors: tuple[SensorSettings, ...] | list[SensorSettings]
                          ) -> np.ndarray:
    """(S, 3) each sensor's stated sigma (SI) of its first three measured components in the
    order of its measurement model: range, azimuth, elevation (radar, theodolite); east,
    north, up (GPS: horizontal, horizontal, vertical); NaN where none is stated."""
    out = np.full((len(sensors), 3), np.nan)
    for i, s in enumerate(sensors):
        names = (("horizontal", "horizontal", "vertical") if s.kind == "gps"
                 else ("range", "azimuth", "elevation"))
        out[i] = [s.sigma.get(n, np.nan) for n in names]
    return out


def _gaps(t_used: np.ndarray, min_gap: float) -> list[list[float]]:
    if len(t_used) < 2:
        return []
    dt = np.diff(t_used)
    med = float(np.median(dt)) if len(dt) else 0.0
    thr = max(min_gap, 10.0 * med)
    k = np.flatnonzero(dt > thr)
    return [[float(t_used[i]), float(t_used[i + 1])] for i in k]


def report_disagreement(cfg: Config, far_list: list[FarSensor],
                        suspicions: dict[str, UnitSuspicion],
                        left_out: Mapping[str, tuple[str, ...]] | None = None) -> None:
    """One line per sensor that does not fit: a sensor whose rows sit far from every other
    sensor's view (``far_list``, ``fusion.agreement``) and whose angles also fit a smaller
    unit (``editing.units``) cannot be meant so (DataError); either finding alone is a
    warning, and two sensors that only see each other far away get one line naming both.
    The line of a sensor whose objects are ``left_out`` (``fusion.isolated``) says so."""
    files = {s.id: s.file.name for s in cfg.sensors}
    far = {f.sensor_id: f for f in far_list}
    left_out = left_out or {}

    def note(*sids: str) -> str:
        gone = [oid for sid in sids for oid in left_out.get(sid, ())]
        if not gone:
            return ""
        return (f"; left out of fused.parquet: {', '.join(gone)} (its rows are in "
                "edits.parquet, reason isolated; [processing] keep_isolated = true keeps it)")
    for sid, f in far.items():
        if sid in suspicions:
            u = suspicions[sid]
            raise DataError(
                f"{u.finding}, and read as {u.configured} its rows sit "
                f"{f.distance_m / 1e3:.3g} km from every other sensor's view of the objects at "
                f"the same times ({', '.join(f.others)}): set angle_unit = \"{u.likely}\"")
    said: set[str] = set()
    for sid, f in far.items():
        if sid in said:
            continue
        mate = far.get(f.others[0]) if len(f.others) == 1 else None
        if mate is not None and mate.others == (sid,):
            log.warning("%s%s", pair_line(f, mate, files), note(sid, mate.sensor_id))
            said.add(mate.sensor_id)
        else:
            log.warning("%s%s", far_line(f, files[sid]), note(sid))
    for sid, u in suspicions.items():
        if sid not in far:
            log.warning("%s", u.text)


def sensor_summaries(cfg: Config, raw: dict[str, SensorLog], logs: dict[str, SensorLog],
                     edits: EditRecord) -> dict[str, SensorSummary]:
    """``summary.json``'s ``sensors`` entries as far as reading and screening know them
    (``summary_types.ScreenedSensor``, with ``n_used`` and ``n_rejected`` at screening's: an
    INS's rows kept, else 0); :func:`products` adds the objects' use of the rows, the write
    stage the edit counts and ``rows``."""
    return {s.id: {"kind": s.kind, "file": str(s.file), "n_read": logs[s.id].n_read,
                   "n_rows": len(raw[s.id]),
                   "n_used": len(logs[s.id]) if s.kind == "ins" else 0,
                   "n_rejected": 0, "n_no_platform_geometry": 0,
                   "n_edited": edits.counts(s.id), "edit_examples": edits.examples(s.id),
                   "n_unstarted": 0, **_time_span(logs[s.id].time)} for s in cfg.sensors}


def _track_span(track: TrackEstimate) -> dict[str, Any]:
    """The entries of an object's summary that its written track sets: its first and last
    epoch (s), their count and the largest position sigma (m, any axis)."""
    n = len(track.time)
    return {"t_start": float(track.time[0]) if n else None,
            "t_end": float(track.time[-1]) if n else None, "n_epochs": n,
            "max_sigma_position_m": float(np.sqrt(np.max(np.diagonal(
                track.P[:, :3, :3], axis1=1, axis2=2)))) if n else None}


def _target_summary(track: TrackEstimate, result: FusionResult,
                    settings: EstimatorSettings, reference_var: float,
                    extent_sigma: tuple[float, float],
                    persistent_sigma: tuple[float, float] = (0.0, 0.0),
                    spread_sigma: float = 0.0) -> TargetSummary:
    """``summary.json``'s entry of one object (``summary_types.TargetSummary``);
    reference_var: m², the variance of its reference point about the returns that the
    sensors' stated sigmas show (``fusion.reference_point``); extent_sigma: m, the hull's
    fitted 1-sigma spread along and across the heading (``fusion.extent``);
    persistent_sigma: m, the 1-sigma offset of the returns from the track that persists from
    scan to scan, along and across (``fusion.persistent_offset``); spread_sigma: m, the
    1-sigma spread of its reference point about the track that its returns' spread within a
    scan shows, on each axis (``fusion.reference_point.spread_extent``)."""
    t_used = result.batch.t[result.used.any(axis=1)]
    p = settings.processing
    return {
        "reference_sigma_m": float(np.sqrt(reference_var)),
        "extent_sigma_m": {"along": float(extent_sigma[0]), "across": float(extent_sigma[1])},
        "persistent_offset_sigma_m": {"along": float(persistent_sigma[0]),
                                      "across": float(persistent_sigma[1])},
        "return_spread_sigma_m": float(spread_sigma),
        "gaps": _gaps(t_used, 1.0),
        "spans": [list(sp) for sp in result.spans],
        "unwritten": [list(sp) for sp in track.unwritten],
        "max_gap_s": p.max_gap,
        "process_noise_q": {"unit": "m^2/s^5", "median": float(np.median(result.q)),
                            "p95": float(np.percentile(result.q, 95)),
                            "max": float(np.max(result.q))},
        "filter": {"configured": p.filter, "used": result.filter_used[0] or p.filter,
                   "why": result.filter_used[1] or "configured"},
        "divergence_resets": result.n_resets,
        "maneuver_norm": {"unit": "m/s^2", "given": p.maneuver_norm,
                          "imposed": result.maneuver_norm},
        **_track_span(track)}


def _lever_arm(tid: str, result: FusionResult, radar: np.ndarray,
               levers: Mapping[str, tuple[int, tuple[float, float, float]]]
               ) -> tuple[float, float, float] | None:
    """The ``lever_arm`` of target ``tid`` (``levers``: target id -> (its index in
    ``[[targets]]``, its lever arm), the nonzero ones) where it applies: an object measured by
    plots alone (``fusion.extent.plots_only``) that moves fast enough to have a heading;
    otherwise one warning line and None."""
    if tid not in levers:
        return None
    i, lever = levers[tid]
    where = f"targets[{i}].lever_arm of {tid} not applied"
    if not plots_only(result.batch, radar):
        log.warning("%s: its position is the point its gps or tracked rows measure", where)
        return None
    if np.isnan(held_heading(result.xs[result.grid][:, 3:5])).all():
        log.warning("%s: it never moves faster than %g m/s, so its heading is unknown", where,
                    HEADING_SPEED)
        return None
    return lever


def products(cfg: Config, frame: RangeFrame, fused: list[tuple[str, FusionResult]],
             settings: EstimatorSettings, sensor_summary: dict[str, SensorSummary],
             n_no_platform: dict[str, int], tick: Callable[..., None] = lambda *a, **k: None,
             spreads: Mapping[str, np.ndarray] | None = None
             ) -> tuple[list[TrackEstimate], list[SensorResiduals], dict[str, TargetSummary]]:
    """Each fused object's track on the output grid and each sensor's residuals; fills the
    sensors' summary entries (``sensor_summary``, by id) and returns the objects' entries.
    ``spreads``: object id -> its returns' spread within a scan (2, 2) m^2
    (``tracking.return_spread``; none without)."""
    sensor_ids = tuple(s.id for s in cfg.sensors)
    stated = stated_position_sigma(cfg.sensors)
    radar = np.array([s.kind == "radar" for s in cfg.sensors])
    tracks: list[TrackEstimate] = []
    residuals: list[SensorResiduals] = []
    target_summary: dict[str, TargetSummary] = {}
    uses: dict[int, list[ObjectUse]] = {}
    levers = {t.id: (i, t.lever_arm) for i, t in enumerate(cfg.targets) if any(t.lever_arm)}
    for tid, result in fused:
        stated_var = reference_variance(result.batch, result.noise, stated, radar)
        plots = plots_only(result.batch, radar)
        # the smoothed state at each row (N, n), gathered once and only for an object of
        # plots alone: for any other both extents are 0 without reading it
        at_rows = result.xs[result.meas_epoch] if plots else result.xs[:0]
        fitted = object_extent(result.batch, at_rows, result.used, radar)
        persistent = persistent_offset(result.batch, at_rows, result.used, radar)
        del at_rows
        spread = spread_extent((spreads or {}).get(tid)) if plots else Extent()
        lever = _lever_arm(tid, result, radar, levers)
        track = track_estimate(tid, result, frame, cfg.output.rate_hz,
                               max_bridge=BRIDGE_FACTOR * settings.processing.max_gap,
                               stated=stated, lever_arm=lever, with_achievable=False,
                               reference=reference_extent(stated_var, fitted, persistent,
                                                          spread))
        tracks.append(track)
        for i in np.unique(result.batch.sensor):
            i = int(i)
            sid = sensor_ids[i]
            r = sensor_residuals(tid, result, i, cfg.sensors[i].kind)
            residuals.append(r)
            uses.setdefault(i, []).append(ObjectUse(tid, result, i, r))
        for i, n in result.n_unstarted.items():
            sensor_summary[sensor_ids[i]]["n_unstarted"] += n
        target_summary[tid] = _target_summary(track, result, settings, stated_var,
                                              fitted.sigma, persistent.sigma,
                                              spread.sigma[0])
        tick(1, tid)
    for i, used_by in uses.items():       # totals over the objects (``fusion.sensor_use``)
        sensor_summary[sensor_ids[i]].update(sensor_use(cfg.sensors[i], used_by))
    for sid, n in n_no_platform.items():
        sensor_summary[sid]["n_no_platform_geometry"] = n
    specs = settings.calibration
    for i, sen in enumerate(cfg.sensors):
        if (offset := time_offset_summary(sen)) is not None:
            sensor_summary[sen.id]["time_offset"] = offset
        if sen.kind != "ins":
            sensor_summary[sen.id]["calibration"] = calibration_summary(
                sen, i, specs[i] if specs else None,
                [c for _, result in fused for c in result.calibration])
    return tracks, residuals, target_summary


def settle(cfg: Config, frame: RangeFrame, fused: list[tuple[str, FusionResult]],
           settings: EstimatorSettings, sensor_summary: dict[str, SensorSummary],
           n_no_platform: dict[str, int], suspicions: dict[str, UnitSuspicion],
           logs: Mapping[str, SensorLog], edits: EditRecord,
           tick: Callable[..., None] = lambda *a, **k: None,
           spreads: Mapping[str, np.ndarray] | None = None
           ) -> tuple[list[tuple[str, FusionResult]], list[TrackEstimate],
                      list[SensorResiduals], dict[str, TargetSummary]]:
    """:func:`products` and the plausibility lines: the sensors far from the others (with an
    angle-unit suspicion: exit 2), whose lone objects are left out (``fusion.isolated``)
    unless ``keep_isolated``, then the stated sigmas far from the noise the data show.
    Returns the fused objects kept, their tracks, residuals and summary entries; fills
    ``sensor_summary`` and adds the rows left out to ``edits``. ``spreads`` as for
    :func:`products`."""
    before = copy.deepcopy(sensor_summary)
    tracks, residuals, targets = products(cfg, frame, fused, settings, sensor_summary,
                                          n_no_platform, tick, spreads)
    far = far_sensors(tracks, [s.id for s in cfg.sensors])
    left_out = {} if cfg.processing.keep_isolated else isolated_objects(cfg, far)
    report_disagreement(cfg, far, suspicions, left_out)
    if left_out:
        fused = leave_out(fused, left_out, logs, edits)
        sensor_summary.clear()
        sensor_summary.update(before)
        tracks, residuals, targets = products(cfg, frame, fused, settings, sensor_summary,
                                              n_no_platform, spreads=spreads)
    plausibility(cfg, sensor_summary, logs)
    # objects first or last seen beside another within its radar's resolution: the span
    # hidden in the other's plots (fusion.formation)
    tracks = formation_spans(tracks, dict(fused), frame, cfg.output.rate_hz,
                             BRIDGE_FACTOR * settings.processing.max_gap,
                             stated_position_sigma(cfg.sensors))
    for track in tracks:                         # the summary's span of an extended object
        entry = targets.get(track.target_id)
        if entry is not None and len(track.time) != entry["n_epochs"]:
            entry.update(_track_span(track))
    return fused, tracks, residuals, targets


def without_covariances(fused: list[tuple[str, FusionResult]]
                        ) -> list[tuple[str, FusionResult]]:
    """The fusion results without their per-epoch covariances ``Ps``, per-row residuals
    ``res`` and explained variances ``hph`` (empty arrays of their widths): what the
    achievable pass (:func:`achievable_tracks`) does not read, let go before it runs once
    the caller drops the results given."""
    def light(r: FusionResult) -> FusionResult:
        return replace(r, Ps=np.empty((0,) + r.Ps.shape[1:]),
                       res=np.empty((0,) + r.res.shape[1:]),
                       hph=np.empty((0,) + r.hph.shape[1:]))
    return [(tid, light(r)) for tid, r in fused]


def achievable_tracks(tracks: list[TrackEstimate], fused: list[tuple[str, FusionResult]],
                      tick: Callable[..., None] = lambda *a, **k: None
                      ) -> list[TrackEstimate]:
    """``tracks`` (from :func:`settle`) with the achievable 1-sigma position of each fused
    object's epochs (``fusion.products.with_achievable_sigma``). Run after the edit table
    and the row accounting, on :func:`without_covariances`' results: the pass's filter
    history (an (E, 45) covariance per epoch) is then never resident beside the fusion's."""
    results = dict(fused)
    out = []
    for track in tracks:
        result = results.get(track.target_id)
        out.append(track if result is None else with_achievable_sigma(track, result))
        tick(1, track.target_id)
    return out


def plausibility(cfg: Config, sensor_summary: Mapping[str, SensorSummary],
                 logs: Mapping[str, SensorLog]) -> None:
    """The lines of stated sigmas far from the noise the data show, of the components each
    sensor's file measures (``logs``, the screened logs by id): judged on the noise of the
    object that agrees best with the stated sigma (:func:`most_agreeing_noise`)."""
    for sen in cfg.sensors:
        noise = most_agreeing_noise(sensor_summary[sen.id])
        if (line := stated_sigma_line(sen, noise, absent_columns(logs[sen.id]))):
            log.warning("%s", line)


#: An object's own noise estimate speaks for the sensor in the sigma check with at least
#: this many of the sensor's rows used.
MIN_OBJECT_ROWS = 20


def most_agreeing_noise(entry: Mapping[str, Any]) -> dict[str, dict]:
    """A sensor summary entry's ``noise`` with each component's estimate replaced by the one,
    among the summary's and those of the objects with at least ``MIN_OBJECT_ROWS`` rows used
    (``by_object``), nearest the stated sigma in ratio; None (no judgement) where the objects
    with an estimate hold under half the sensor's used rows. A sigma in the wrong unit is wrong
    for every object the sensor sees; an object that holds rows of several things (residuals
    of kilometres) says nothing about the sensor's unit, and no longer raises the line where
    another object's rows fit the stated sigma or most rows went to objects too short to
    estimate a noise from."""
    noise = {c: dict(v) for c, v in (entry.get("noise") or {}).items()}
    objects = entry.get("by_object") or {}
    for c, v in noise.items():
        held = sum(o.get("n_used", 0) for o in objects.values()
                   if (o.get("noise") or {}).get(c) is not None)
        if objects and held < 0.5 * sum(o.get("n_used", 0) for o in objects.values()):
            v["estimated"] = None
    for obj in objects.values():
        if obj.get("n_used", 0) < MIN_OBJECT_ROWS:
            continue
        for c, est in (obj.get("noise") or {}).items():
            v = noise.get(c)
            if v is None or est is None or not v.get("apriori") or not est > 0:
                continue
            now = v.get("estimated")
            if now is None:                          # too few rows estimated: no judgement
                continue
            if not now > 0 or (abs(math.log(est / v["apriori"]))
                                              < abs(math.log(now / v["apriori"]))):
                v["estimated"] = est
    return noise
