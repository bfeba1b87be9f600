"""Stage 6, products: each object's smoothed state on the output grid, each sensor's residuals,
the summary's per-object and per-sensor figures, and the plausibility lines that need the
fused result (a sensor far from the others, a stated sigma far from the data)."""
from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from rangeproc.config import Config, SensorSettings
from rangeproc.editing.record import EditRecord
from rangeproc.editing.units import UnitSuspicion, absent_columns, stated_sigma_line
from rangeproc.errors import DataError
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.agreement import far_line, far_sensors, pair_line
from rangeproc.fusion.calibration_summary import calibration_summary, time_offset_summary
from rangeproc.fusion.centralised import EstimatorSettings, FusionResult
from rangeproc.fusion.products import sensor_residuals, track_estimate
from rangeproc.io.logs import SensorLog
from rangeproc.models.measurement import COMPONENTS
from rangeproc.results import SensorResiduals, TrackEstimate


log = logging.getLogger(__name__)


#: Gaps between an object's spans up to this many times ``max_gap`` are bridged in the output
#: (``fusion.bridge``); longer ones stay empty.
BRIDGE_FACTOR = 10.0


def _time_span(t: np.ndarray) -> dict[str, float | None]:
    """``t_first``, ``t_last`` (s, range time scale) of a sensor's screened rows (None when
    it has none)."""
    return {"t_first": float(t.min()) if t.size else None,
            "t_last": float(t.max()) if t.size else None}


def _noise_summary(s: SensorSettings, index: int, res: FusionResult) -> tuple[dict, dict]:
    model = int(res.batch.model[res.batch.sensor == index][0])
    names, units = COMPONENTS[model]
    noise, bias = {}, {}
    rows = res.batch.sensor == index
    for c, (name, unit) in enumerate(zip(names, units)):
        key = {"e": "horizontal", "n": "horizontal", "u": "vertical", "ve": "velocity",
               "vn": "velocity", "vu": "velocity"}.get(name, name)
        if not np.isfinite(res.batch.z[rows, c]).any():
            continue
        used = rows & res.used[:, c] & np.isfinite(res.res[:, c])
        noise[name] = {"unit": unit, "apriori": s.sigma.get(key),
                       "estimated": res.noise.get((index, c))}
        bias[name] = {"unit": unit,
                      "median_residual": float(np.median(res.res[used, c])) if used.any()
                      else None}
    return noise, bias


def pooled_noise(s: SensorSettings, index: int, fused: list[tuple[str, FusionResult]]
                 ) -> dict[str, dict]:
    """Sensor ``index``'s noise estimate per component pooled over every object it sees
    (``summary.json``'s ``noise`` layout: unit, a-priori and estimated sigma, SI): the root of
    the objects' estimated variances weighted by the rows each used. A sensor whose rows fit
    one object's track closely (the rows that carry it) and another's loosely is judged on
    all its rows, not on the last object's."""
    pooled: dict[str, dict] = {}
    weight: dict[str, float] = {}
    for _, result in fused:
        rows = result.batch.sensor == index
        if not rows.any():
            continue
        noise, _ = _noise_summary(s, index, result)
        names = COMPONENTS[int(result.batch.model[rows][0])][0]
        for name, entry in noise.items():
            c = names.index(name)
            n = int((rows & result.used[:, c] & np.isfinite(result.res[:, c])).sum())
            est = entry["estimated"]
            out = pooled.setdefault(name, {**entry, "estimated": None})
            if est is None or not np.isfinite(est) or n == 0:
                continue
            total = weight.get(name, 0.0)
            sq = (out["estimated"] or 0.0) ** 2 * total + est ** 2 * n
            weight[name] = total + n
            out["estimated"] = float(np.sqrt(sq / weight[name]))
    return pooled


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


def report_disagreement(cfg: Config, tracks: list[TrackEstimate],
                        suspicions: dict[str, UnitSuspicion]) -> None:
    """One line per sensor that does not fit: a sensor whose rows sit far from every other
    sensor's view (``fusion.agreement``) and whose angles also fit a smaller unit
    (``editing.units``) cannot be meant so (DataError); either finding alone is a warning, and
    two sensors that only see each other far away get one line naming both."""
    files = {s.id: s.file.name for s in cfg.sensors}
    far = {f.sensor_id: f for f in far_sensors(tracks, [s.id for s in cfg.sensors])}
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
            log.warning("%s", pair_line(f, mate, files))
            said.add(mate.sensor_id)
        else:
            log.warning("%s", far_line(f, files[sid]))
    for sid, u in suspicions.items():
        if sid not in far:
            log.warning("%s", u.text)


def sensor_summaries(cfg: Config, raw: dict[str, SensorLog], logs: dict[str, SensorLog],
                     edits: EditRecord) -> dict[str, dict]:
    """``summary.json``'s ``sensors`` entries as far as reading and screening know them (the
    counts of used and rejected rows are added by :func:`products`)."""
    return {s.id: {"kind": s.kind, "file": str(s.file), "n_read": logs[s.id].n_read,
                   "n_rows": len(raw[s.id]),
                   "n_used": len(logs[s.id]) if s.kind == "ins" else 0,
                   "n_rejected": 0, "n_no_platform_geometry": 0,
                   "n_edited": edits.counts(s.id), "edit_examples": edits.examples(s.id),
                   "n_unstarted": 0, **_time_span(logs[s.id].time)} for s in cfg.sensors}


def _count_sensor(ss: dict, result: FusionResult, i: int, r: SensorResiduals,
                  s: SensorSettings, tid: str) -> None:
    """Add one object's use of sensor ``i`` to its summary entry ``ss``."""
    sel = result.batch.sensor == i
    used_rows = result.used[sel].any(axis=1)
    measured_rows = result.dof[sel] > 0
    ss["n_used"] += int(used_rows.sum())
    ss["n_rejected"] += int((measured_rows & ~used_rows).sum())
    ss["n_partly_rejected"] = int((used_rows & r.rejected.any(axis=1)).sum())
    ss["n_components_rejected"] = {
        name: int(r.rejected[:, j].sum()) for j, name in enumerate(r.components)}
    ss["noise"], ss["bias"] = _noise_summary(s, i, result)
    ss.setdefault("target", tid)
    ss.setdefault("targets", []).append(tid)


def _target_summary(track: TrackEstimate, result: FusionResult,
                    settings: EstimatorSettings) -> dict:
    """``summary.json``'s entry of one object."""
    t_used = result.batch.t[result.used.any(axis=1)]
    p = settings.processing
    return {
        "t_start": float(track.time[0]) if len(track.time) else None,
        "t_end": float(track.time[-1]) if len(track.time) else None,
        "n_epochs": len(track.time),
        "gaps": _gaps(t_used, 1.0),
        "spans": [list(sp) for sp in result.spans],
        "max_gap_s": p.max_gap,
        "process_noise_q": {"unit": "m^2/s^5", "median": float(np.median(result.q)),
                            "p95": float(np.percentile(result.q, 95)),
                            "max": float(np.max(result.q))},
        "filter": {"configured": p.filter, "used": result.filter_used[0] or p.filter,
                   "why": result.filter_used[1] or "configured"},
        "divergence_resets": result.n_resets,
        "maneuver_norm": {"unit": "m/s^2", "given": p.maneuver_norm,
                          "imposed": result.maneuver_norm},
        "max_sigma_position_m": float(np.sqrt(np.max(np.diagonal(
            track.P[:, :3, :3], axis1=1, axis2=2)))) if len(track.time) else None}


def products(cfg: Config, frame: RangeFrame, fused: list[tuple[str, FusionResult]],
             settings: EstimatorSettings, sensor_summary: dict[str, dict],
             n_no_platform: dict[str, int], tick: Callable[..., None] = lambda *a, **k: None
             ) -> tuple[list[TrackEstimate], list[SensorResiduals], dict[str, dict]]:
    """Each fused object's track on the output grid and each sensor's residuals; fills the
    sensors' summary entries (``sensor_summary``, by id) and returns the objects' entries."""
    sensor_ids = tuple(s.id for s in cfg.sensors)
    stated = stated_position_sigma(cfg.sensors)
    tracks, residuals, target_summary = [], [], {}
    for tid, result in fused:
        track = track_estimate(tid, result, frame, cfg.output.rate_hz,
                               max_bridge=BRIDGE_FACTOR * settings.processing.max_gap,
                               stated=stated)
        tracks.append(track)
        for i in np.unique(result.batch.sensor):
            i = int(i)
            sid = sensor_ids[i]
            r = sensor_residuals(tid, result, i, cfg.sensors[i].kind)
            residuals.append(r)
            _count_sensor(sensor_summary[sid], result, i, r, cfg.sensors[i], tid)
            sensor_summary[sid]["n_no_platform_geometry"] = n_no_platform[sid]
        for i, n in result.n_unstarted.items():
            sensor_summary[sensor_ids[i]]["n_unstarted"] += n
        target_summary[tid] = _target_summary(track, result, settings)
        tick(1, tid)
    specs = settings.calibration
    for i, sen in enumerate(cfg.sensors):
        if (offset := time_offset_summary(sen)) is not None:
            sensor_summary[sen.id]["time_offset"] = offset
        if sen.kind != "ins":
            sensor_summary[sen.id]["calibration"] = calibration_summary(
                sen, i, specs[i] if specs else None,
                [c for _, result in fused for c in result.calibration])
    return tracks, residuals, target_summary


def plausibility(cfg: Config, tracks: list[TrackEstimate],
                 fused: list[tuple[str, FusionResult]], suspicions: dict[str, UnitSuspicion],
                 logs: dict[str, SensorLog]) -> None:
    """The plausibility lines that need the fused result: sensors far from the others (with
    an angle-unit suspicion: exit 2) and stated sigmas far from the noise the data show
    (:func:`pooled_noise` over every object, of the components each sensor's file measures:
    ``logs``, the screened logs by id)."""
    report_disagreement(cfg, tracks, suspicions)
    for i, sen in enumerate(cfg.sensors):
        if (line := stated_sigma_line(sen, pooled_noise(sen, i, fused),
                                      absent_columns(logs[sen.id]))):
            log.warning("%s", line)
