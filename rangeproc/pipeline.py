"""The processing stages in order: read -> assemble -> fuse -> write -> report.

Each stage is a function from data to new data; ``run`` strings them together and is what
``rangeproc run CONFIG`` calls.
"""
from __future__ import annotations

import errno
import logging
import os
import platform as _platform
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import rangeproc
from rangeproc.config import Config, SensorSettings, TargetSettings, load_config
from rangeproc.fusion.edit_audit import edit_summary, rejected_examples
from rangeproc.editing.record import EditRecord
from rangeproc.editing.screen import screen_logs
from rangeproc.fusion.edit_table import edit_table
from rangeproc.editing.units import UnitSuspicion, angle_unit_checks, stated_sigma_line
from rangeproc.errors import ConfigError, DataError, OutputError, write_failure
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.agreement import far_line, far_sensors, pair_line
from rangeproc.fusion.assemble import Assembled, assemble_sensor
from rangeproc.fusion.batch import merge
from rangeproc.fusion.calibration_summary import calibration_summary, time_offset_summary
from rangeproc.fusion.centralised import EstimatorSettings, FusionResult, fuse_target
from rangeproc.fusion.initialise import NoPositionFix, Prior, given_prior
from rangeproc.fusion.refraction_rows import RefractionSettings
from rangeproc.fusion.registration import SensorCalibration
from rangeproc.fusion.products import sensor_residuals, track_estimate
from rangeproc.interchange import EXPORT_FILES, export_run
from rangeproc.io.logs import SensorLog
from rangeproc.io.output import fused_table
from rangeproc.io.readers import read_sensor
from rangeproc.io.writers import file_sha256, write_json, write_parquet
from rangeproc.models.measurement import COMPONENTS
from rangeproc.parallel import thread_map
from rangeproc.progress import StageClock
from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.run_warnings import collect_warnings
from rangeproc.timescale import time_scale
from rangeproc.tracking.routing import (
    association_summary,
    association_table,
    object_rows,
    stray_points,
    target_of,
)

log = logging.getLogger(__name__)

#: Gaps between an object's spans up to this many times ``max_gap`` are bridged in the output
#: (``fusion.bridge``); longer ones stay empty.
BRIDGE_FACTOR = 10.0


@dataclass(frozen=True, slots=True)
class RunOutput:
    """What a run produced: paths written, tracks, residuals, the summary dict and the
    wall-clock seconds per stage."""

    out_dir: Path
    tracks: tuple[TrackEstimate, ...]
    residuals: tuple[SensorResiduals, ...]
    summary: dict
    written: tuple[Path, ...]
    timings: dict[str, float]


def estimator_settings(cfg: Config) -> EstimatorSettings:
    """The estimator's settings: the ``[processing]`` section (read by name; the forward
    filter follows from ``processing.filter``) with what the sensors add, the calibration
    terms and the refraction."""
    return EstimatorSettings(processing=cfg.processing,
                             calibration=calibration_specs(cfg) if cfg.processing.calibration
                             else (), refraction=refraction_settings(cfg))


def refraction_settings(cfg: Config) -> RefractionSettings | None:
    """The refraction removed from the rows (``processing.refraction``; None for "none"):
    each radar's ``refractivity``, each theodolite's ``optical_refractivity``."""
    p = cfg.processing
    if p.refraction == "none":
        return None
    surface_n = {"radar": p.refractivity, "theodolite": p.optical_refractivity}
    return RefractionSettings(model=p.refraction,
                              surface_n=tuple(surface_n.get(s.kind, 0.0) for s in cfg.sensors),
                              moving=tuple(s.platform is not None for s in cfg.sensors),
                              origin_height=cfg.origin.height)


def calibration_specs(cfg: Config) -> tuple[SensorCalibration | None, ...]:
    """What the registration may estimate per sensor (index as in ``cfg.sensors``): the
    config's ``calibrate`` terms; GPS is the absolute reference of position and time, and
    MISTRAM's latency is estimated only against a GPS on the same target."""
    with_gps = {target_of(s, cfg) for s in cfg.sensors if s.kind == "gps"}
    specs: list[SensorCalibration | None] = []
    for s in cfg.sensors:
        names = s.calibrate
        if s.kind == "gps" or (s.kind == "mistram" and target_of(s, cfg) not in with_gps):
            names = ()
        specs.append(SensorCalibration(s.kind, s.platform is not None, names)
                     if s.kind != "ins" else None)
    return tuple(specs)


def read_all(cfg: Config, tick: Callable[..., None] = lambda *a, **k: None
             ) -> dict[str, SensorLog]:
    """Stage 1: read every sensor file (SensorLog per sensor id)."""
    logs = {}
    for s in cfg.sensors:
        logs[s.id] = read_sensor(s)
        tick(1, s.id)
    return logs


def target_prior(target: TargetSettings, frame: RangeFrame) -> Prior | None:
    """The target's ``initial`` state in the range ENU frame, or None."""
    init = target.initial
    if init is None:
        return None
    p = init.position
    return given_prior(init.time, frame.to_enu(p.lat, p.lon, p.height).reshape(3),
                            np.asarray(init.velocity), init.sigma_position, init.sigma_velocity)


def _needs_initial(cfg: Config, target_id: str, why: str) -> DataError:
    """Exit-2 error for a target whose data cannot start a track: show the key to give."""
    index = next((i for i, t in enumerate(cfg.targets) if t.id == target_id), 0)
    return DataError(
        f"{cfg.path.name}: targets[{index}].initial: target {target_id}: {why}; give its "
        f"state, e.g. [[targets]] id = \"{target_id}\" initial = {{ time = ..., lat = ..., "
        "lon = ..., height = ..., ve = ..., vn = ..., vu = ..., sigma_position = 10.0, "
        "sigma_velocity = 5.0 }")


def fuse_objects(cfg: Config, parts_of: dict, sensor_ids: tuple[str, ...],
                 settings: EstimatorSettings, priors: dict[str, Prior],
                 tick: Callable[..., None]) -> list[tuple[str, FusionResult]]:
    """Stage 4: the centralised smoother over every object's rows, objects side by side in
    threads (``rangeproc.parallel``; the results do not depend on the thread count).

    parts_of: object id -> its row parts (emptied as objects are handed out); returns
    (object id, result) in ``parts_of``'s order, leaving out objects without measurements or
    (undeclared ones) without a position fix. A declared target without a position fix is an
    exit-2 error."""
    order = list(parts_of)
    jobs = []
    for oid in order:
        parts = parts_of.pop(oid)
        if not parts:
            log.warning("target %s: no measurements", oid)
            tick(1 + settings.processing.noise_passes, oid)
        else:
            jobs.append((oid, parts))

    def fuse_one(oid: str, parts: list) -> FusionResult | None:
        batch = merge(parts, sensor_ids)
        parts.clear()
        try:
            return fuse_target(batch, cfg.output.rate_hz, settings,
                               tick=lambda n=1, note="", t=oid: tick(n, f"{t} {note}"),
                               prior=priors.get(oid))
        except NoPositionFix as exc:
            if oid in priors:
                raise _needs_initial(cfg, oid, str(exc)) from None
            log.warning("object %s left out: %s", oid, exc)
            return None

    results = dict(zip([oid for oid, _ in jobs],
                       thread_map(lambda job: fuse_one(*job), jobs,
                                  cost=lambda job: sum(len(rows.t) for _, rows in job[1]))))
    return [(oid, results[oid]) for oid in order if results.get(oid) is not None]


def assemble_all(cfg: Config, frame: RangeFrame, logs: dict[str, SensorLog],
                 tick: Callable[..., None] = lambda *a, **k: None) -> dict[str, Assembled]:
    """Stage 2: measurement rows with geometry for every non-INS sensor (sensors side by side
    in threads, ``rangeproc.parallel``)."""
    ins = {s.id: logs[s.id] for s in cfg.sensors if s.kind == "ins"}
    sensors = [s for s in cfg.sensors if s.kind != "ins"]
    out = {}
    for s, rows in zip(sensors, thread_map(lambda s: assemble_sensor(logs[s.id], s, frame, ins),
                                           sensors, cost=lambda s: len(logs[s.id]))):
        out[s.id] = rows
        tick(1, s.id)
    return out


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
                f"{u.text.split(' (set angle_unit')[0]}, and read as {u.configured} its rows sit "
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


def run(config_path: str | Path, *, clock: StageClock | None = None) -> RunOutput:
    """Process one flight: read the config and logs, fuse every target, write the outputs.

    ``clock`` times the stages (read, screen, assemble, fuse, write, report) and drives the progress
    display; the default shows nothing. Every warning logged on the way is also kept in
    ``summary["warnings"]`` (one line each) for the report page and the terminal's headline.
    """
    with collect_warnings() as warnings:
        return _run(config_path, clock, warnings)


def _run(config_path: str | Path, clock: StageClock | None, warnings: list[str]) -> RunOutput:
    from rangeproc.report.figures import write_report
    from rangeproc.report.page import write_page

    clock = clock or StageClock()
    started = time.perf_counter()
    cfg = load_config(config_path)
    check_output_dir(cfg)
    frame = RangeFrame(cfg.origin)
    with clock.stage("read", len(cfg.sensors)) as tick:
        raw = read_all(cfg, tick)
    unit_suspicions = angle_unit_checks(cfg.sensors, raw)
    edits = EditRecord()
    with clock.stage("screen", len(cfg.sensors)) as tick:
        logs = screen_logs(cfg, raw, edits, tick)
    with clock.stage("assemble", sum(s.kind != "ins" for s in cfg.sensors)) as tick:
        rows = assemble_all(cfg, frame, logs, tick)
    settings = estimator_settings(cfg)
    sensor_ids = tuple(s.id for s in cfg.sensors)
    kinds = {s.id: s.kind for s in cfg.sensors}
    tracks, residuals, target_summary = [], [], {}
    sensor_summary: dict[str, dict] = {
        s.id: {"kind": s.kind, "file": str(s.file), "n_read": logs[s.id].n_read,
               "n_rows": len(raw[s.id]), "n_used": len(logs[s.id]) if s.kind == "ins" else 0,
               "n_rejected": 0, "n_no_platform_geometry": 0,
               "n_edited": edits.counts(s.id), "edit_examples": edits.examples(s.id),
               "n_unstarted": 0, **_time_span(logs[s.id].time)} for s in cfg.sensors}
    del raw
    n_no_platform = {sid: a.n_no_platform for sid, a in rows.items()}
    sites = _sites(cfg, frame, rows)
    priors = {tgt.id: target_prior(tgt, frame) for tgt in cfg.targets}
    with clock.stage("associate", 1) as tick:
        parts_of, synthesis = object_rows(cfg, rows, settings, priors, tick)
    kept = {sid: a.rows.source_row for sid, a in rows.items()}
    stray = stray_points(cfg, rows, synthesis)
    rows.clear()                                     # the object parts hold the data now
    with clock.stage("fuse", len(parts_of) * (1 + settings.processing.noise_passes)) as tick:
        fused = fuse_objects(cfg, parts_of, sensor_ids, settings, priors, tick)
    stated = stated_position_sigma(cfg.sensors)
    with clock.stage("products", len(fused)) as tick:   # tracks, residuals, summaries
        for tid, result in fused:
            track = track_estimate(tid, result, frame, cfg.output.rate_hz,
                                   max_bridge=BRIDGE_FACTOR * settings.processing.max_gap,
                                   stated=stated)
            tracks.append(track)
            for i in np.unique(result.batch.sensor):
                i = int(i)
                sid = sensor_ids[i]
                r = sensor_residuals(tid, result, i, kinds[sid])
                residuals.append(r)
                ss = sensor_summary[sid]
                sel = result.batch.sensor == i
                used_rows = result.used[sel].any(axis=1)
                measured_rows = result.dof[sel] > 0
                ss["n_used"] += int(used_rows.sum())
                ss["n_rejected"] += int((measured_rows & ~used_rows).sum())
                ss["n_partly_rejected"] = int((used_rows & r.rejected.any(axis=1)).sum())
                ss["n_components_rejected"] = {
                    name: int(r.rejected[:, j].sum()) for j, name in enumerate(r.components)}
                ss["n_no_platform_geometry"] = n_no_platform[sid]
                ss["noise"], ss["bias"] = _noise_summary(cfg.sensors[i], i, result)
                ss.setdefault("target", tid)
                ss.setdefault("targets", []).append(tid)
            for i, n in result.n_unstarted.items():
                sensor_summary[sensor_ids[i]]["n_unstarted"] += n
            t_used = result.batch.t[result.used.any(axis=1)]
            target_summary[tid] = {
                "t_start": float(track.time[0]) if len(track.time) else None,
                "t_end": float(track.time[-1]) if len(track.time) else None,
                "n_epochs": len(track.time),
                "gaps": _gaps(t_used, 1.0),
                "spans": [list(sp) for sp in result.spans],
                "max_gap_s": settings.processing.max_gap,
                "process_noise_q": {"unit": "m^2/s^5", "median": float(np.median(result.q)),
                                    "p95": float(np.percentile(result.q, 95)),
                                    "max": float(np.max(result.q))},
                "divergence_resets": result.n_resets,
                "maneuver_norm": {"unit": "m/s^2", "given": settings.processing.maneuver_norm,
                                  "imposed": result.maneuver_norm},
                "max_sigma_position_m": float(np.sqrt(np.max(np.diagonal(
                    track.P[:, :3, :3], axis1=1, axis2=2)))) if len(track.time) else None}
            tick(1, tid)
        specs = settings.calibration
        for i, sen in enumerate(cfg.sensors):
            if (offset := time_offset_summary(sen)) is not None:
                sensor_summary[sen.id]["time_offset"] = offset
            if sen.kind != "ins":
                sensor_summary[sen.id]["calibration"] = calibration_summary(
                    sen, i, specs[i] if specs else None,
                    [c for _, result in fused for c in result.calibration])
    report_disagreement(cfg, tracks, unit_suspicions)
    for sen in cfg.sensors:
        if (line := stated_sigma_line(sen, sensor_summary[sen.id].get("noise") or {})):
            log.warning("%s", line)
    if not tracks:
        raise DataError(f"{cfg.path.name}: no target has usable measurements (after editing: "
                        + "; ".join(f"{sid} {len(lg)} rows" for sid, lg in logs.items()) + ")")
    edit_rows = edit_table(edits, fused, logs, {s.id: s.angle_unit for s in cfg.sensors})
    for sid, counts in edit_summary(edit_rows, fused, sensor_ids).items():
        sensor_summary[sid].update(counts)
    # the calendar of the run's times (UTC clock time or seconds from start on the page)
    scale = time_scale([tr.time for tr in tracks] + [r.time for r in residuals],
                       cfg.output.epoch)
    out_dir = make_output_dir(cfg)
    with staged_outputs(out_dir) as stage:
        with clock.stage("write"):
            association = association_table(
                cfg, synthesis, {sid: (lg.row, lg.time) for sid, lg in logs.items()}, kept,
                {sid: lg.n_read for sid, lg in logs.items()},
                cfg.targets[0].id if synthesis is None else None)

        exports: list[Path] = []

        def write_tables() -> None:     # written while the report's child draws its first figures
            table = fused_table(tracks)
            write_parquet(table, stage / "fused.parquet")
            write_parquet(edit_rows, stage / "edits.parquet")
            write_parquet(association, stage / "association.parquet")
            if cfg.output.export:       # [output] export: KML / CZML / CSV / ACMI beside it
                exports.extend(export_run(stage, cfg.output.export, epoch=cfg.output.epoch,
                                          title=f"rangeproc {cfg.path.stem}", table=table,
                                          config=cfg))

        with clock.stage("report", 4 + len(residuals) + 2 * (synthesis is not None)) as tick:
            figures = write_report(stage / "report", tracks, residuals,
                                   sites=sites, calibration={
                                       sid: ss["calibration"] for sid, ss in
                                       sensor_summary.items() if ss.get("calibration")},
                                   association=association if synthesis is not None else None,
                                   stray=stray, first=write_tables, edits=edit_rows,
                                   progress=lambda name: tick(1, name), scale=scale)
        summary = {
            "rangeproc_version": rangeproc.__version__,
            "python": _platform.python_version(), "numpy": np.__version__,
            "config": {"file": str(cfg.path), "sha256": file_sha256(cfg.path)},
            "inputs": {s.id: {"file": str(s.file), "sha256": file_sha256(s.file)}
                       for s in cfg.sensors},
            "sensors": sensor_summary, "targets": target_summary,
            "association": association_summary(synthesis, sensor_ids),
            "rejected_points": rejected_examples(edit_rows),
            "warnings": warnings,
            "time_scale": scale.as_dict(),
            "elapsed_s": time.perf_counter() - started,
            "stage_seconds": dict(clock.seconds),
        }
        with clock.stage("write"):
            page = write_page(stage / "report", figures, summary, f"rangeproc: {cfg.path.stem}")
            write_json(summary, stage / "summary.json")
    written = [out_dir / "fused.parquet", out_dir / "edits.parquet",
               out_dir / "association.parquet", *(out_dir / p.name for p in exports),
               *(out_dir / "report" / f.name for f in (*figures, page)),
               out_dir / "summary.json"]
    return RunOutput(out_dir, tuple(tracks), tuple(residuals), summary, tuple(written),
                     dict(clock.seconds))


#: Staging folders are named ``<prefix><pid of the run>-<random>``.
STAGING_PREFIX = ".rangeproc-staging-"


def remove_orphaned_staging(out_dir: Path) -> None:
    """Remove staging folders in ``out_dir`` left by runs on this host whose process no longer
    exists (killed with SIGKILL, e.g. a campaign worker lost mid-sortie: its ``finally``
    never ran). A live run's folder is left alone."""
    for folder in out_dir.glob(f"{STAGING_PREFIX}*"):
        pid = folder.name[len(STAGING_PREFIX):].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (PermissionError, OSError):
            pass                                         # alive, or not ours to judge


@contextmanager
def staged_outputs(out_dir: Path) -> Iterator[Path]:
    """Yield a hidden staging folder inside ``out_dir``; publish its contents on success.

    Every output of a run is first written into the staging folder; only when all of them are
    complete are they moved into place (``report/`` swapped as a whole, ``fused.parquet``,
    ``edits.parquet``, ``association.parquet``, the exports of ``[output] export``, then
    ``summary.json`` last, each by an atomic rename). A run that
    fails at any stage therefore leaves the previous run's outputs untouched and no partial or
    mixed set behind. An operating-system failure to write (a full disk, a read-only folder:
    ``errors.write_failure``) is an :class:`OutputError` naming the output's published
    path in ``out_dir``, not its staged one.
    """
    remove_orphaned_staging(out_dir)
    try:
        stage = Path(tempfile.mkdtemp(prefix=f"{STAGING_PREFIX}{os.getpid()}-", dir=out_dir))
    except OSError as exc:
        if (failure := write_failure(exc, out_dir)) is None:
            raise
        raise failure from exc

    def published(path: str | Path) -> Path:
        """Where a staged path is published (other paths unchanged)."""
        path = Path(path)
        return out_dir / path.relative_to(stage) if path.is_relative_to(stage) else path

    try:
        yield stage
        old = stage / ".old-report"
        if (out_dir / "report").exists():
            os.replace(out_dir / "report", old)
        os.replace(stage / "report", out_dir / "report")
        os.replace(stage / "fused.parquet", out_dir / "fused.parquet")
        os.replace(stage / "edits.parquet", out_dir / "edits.parquet")
        os.replace(stage / "association.parquet", out_dir / "association.parquet")
        for name in EXPORT_FILES:                    # [output] export, when asked for
            if (stage / name).exists():
                os.replace(stage / name, out_dir / name)
        os.replace(stage / "summary.json", out_dir / "summary.json")
    except OutputError as exc:                   # written in the stage: name the final path
        raise OutputError(published(exc.path), exc.cause) from exc.__cause__
    except OSError as exc:                       # a rename into place
        failure = write_failure(exc, published(exc.filename2 or exc.filename or out_dir))
        if failure is None:
            raise
        raise failure from exc
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def check_output_dir(cfg: Config) -> None:
    """Fail fast, before any processing and without creating anything, when ``[output].dir``
    cannot be a writable directory: an existing file (ConfigError), or a folder on the way that
    is not writable or on a read-only file system (OutputError naming it and the cause)."""
    out_dir = cfg.output.dir
    probe = out_dir
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise ConfigError(f"{cfg.path.name}: output.dir: {probe} exists and is not a directory")
    if not os.access(probe, os.W_OK | os.X_OK):      # read-only file system or no permission
        read_only = hasattr(os, "statvfs") and os.statvfs(probe).f_flag & os.ST_RDONLY
        raise OutputError(probe, os.strerror(errno.EROFS if read_only else errno.EACCES))


def make_output_dir(cfg: Config) -> Path:
    """Create ``[output].dir`` (just before the first write)."""
    out_dir = cfg.output.dir
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        if (failure := write_failure(exc, out_dir)) is not None:
            raise failure from exc
        raise ConfigError(f"{cfg.path.name}: output.dir: cannot create {out_dir}: "
                          f"{exc.strerror or exc}") from exc
    return out_dir


def _sites(cfg: Config, frame: RangeFrame, rows: dict[str, Assembled]) -> dict[str, np.ndarray]:
    sites: dict[str, np.ndarray] = {}
    for s in cfg.sensors:
        if s.site is not None:
            sites[s.id] = frame.site(s.site)[0].reshape(3)
        elif s.platform is not None and s.id in rows and len(rows[s.id].rows.t):
            track = rows[s.id].rows.s                  # platform sensor track, decimated
            sites[s.id] = track[::max(1, len(track) // 2000)].copy()
        for st in s.stations:
            sites[st.id] = frame.site(st.site)[0].reshape(3)
    return sites
