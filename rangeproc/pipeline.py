"""``rangeproc run CONFIG``: the eight stages of ``rangeproc.stages`` in order, read -> screen ->
assemble -> associate -> fuse -> products -> write -> report, each timed by the progress clock
under its name; ``run`` strings them together.
"""
from __future__ import annotations

import logging
import platform as _platform
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

import rangeproc
from rangeproc.config import Config, load_config
from rangeproc.errors import DataError
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.stages.accounting import accounting_lines, row_accounting, rows_summary
from rangeproc.fusion.isolated import mark_isolated
from rangeproc.fusion.edit_audit import edit_summary, rejected_examples
from rangeproc.fusion.edit_table import edit_table
from rangeproc.io.memory import release_freed
from rangeproc.io.writers import file_sha256, write_json
from rangeproc.progress import StageClock
from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.run_warnings import collect_warnings
from rangeproc.stages.assemble import assemble_all, sensor_sites
from rangeproc.stages.associate import associate
from rangeproc.stages.fuse import estimator_settings, fuse_objects, target_prior
from rangeproc.stages.products import (achievable_tracks, sensor_summaries, settle,
                                       without_covariances)
from rangeproc.stages.read import read_all
from rangeproc.stages.report import draw_figures, write_report_page
from rangeproc.stages.screen import screen
from rangeproc.stages.write import check_output_dir, make_output_dir, staged_outputs, write_tables
from rangeproc.summary_types import (
    AssociationSummary,
    RejectedPoints,
    RunSummary,
    SensorSummary,
    TargetSummary,
)
from rangeproc.timescale import TimeScale, time_scale
from rangeproc.tracking.routing import (
    ASSOCIATED_KINDS,
    association_summary,
    association_table,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class RunOutput:
    """What a run produced: paths written, tracks, residuals, the summary (``summary.json``,
    ``summary_types.RunSummary``) and the wall-clock seconds per stage."""

    out_dir: Path
    tracks: tuple[TrackEstimate, ...]
    residuals: tuple[SensorResiduals, ...]
    summary: RunSummary
    written: tuple[Path, ...]
    timings: dict[str, float]



@dataclass(frozen=True, slots=True)
class _FreeingClock:
    """The run's :class:`StageClock` whose stages start by handing the C heap's free pages
    back (``io.memory.release_freed``): what the stages before let go leaves the resident
    set instead of waiting, fragmented, for reuse."""

    clock: StageClock

    @property
    def seconds(self) -> dict[str, float]:
        """Seconds per stage (the wrapped clock's)."""
        return self.clock.seconds

    @contextmanager
    def stage(self, name: str, total: int = 1) -> Iterator[Callable[..., None]]:
        """``StageClock.stage``, the free pages handed back first."""
        with self.clock.stage(name, total) as tick:
            release_freed()
            yield tick


def freeing(tick: Callable[..., None]) -> Callable[..., None]:
    """``tick(n=1, note="")`` that first hands the C heap's free pages back
    (``io.memory.release_freed``)."""
    def each(n: int = 1, note: str = "") -> None:
        release_freed()
        tick(n, note)
    return each


def without_objects(summary: AssociationSummary, gone: set[str]) -> AssociationSummary:
    """The association summary without the objects left out (``fusion.isolated``)."""
    if gone and summary.get("objects"):
        summary["objects"] = {k: v for k, v in summary["objects"].items() if k not in gone}
    return summary


def account(cfg: Config, sensor_summary: dict[str, SensorSummary], fates: dict[str, np.ndarray],
            logs: dict) -> None:
    """Each sensor's ``rows`` in its summary entry, and the lines of the sensors that lose
    rows (``stages.accounting``)."""
    for s in cfg.sensors:
        sensor_summary[s.id]["rows"] = rows_summary(
            fates[s.id], s.platform is not None, s.kind in ASSOCIATED_KINDS)
    for line in accounting_lines(cfg, fates, logs):
        log.warning("%s", line)


def run_summary(cfg: Config, sensors: dict[str, SensorSummary],
                targets: dict[str, TargetSummary], association: AssociationSummary,
                rejected: RejectedPoints, warnings: list[str], scale: TimeScale,
                elapsed_s: float, stage_seconds: dict[str, float]) -> RunSummary:
    """``summary.json`` (``summary_types.RunSummary``): the versions, the config's and inputs'
    hashes, and the sections the stages built."""
    return {
        "rangeproc_version": rangeproc.__version__,
        "python": _platform.python_version(), "numpy": np.__version__,
        "config": {"file": str(cfg.path), "sha256": file_sha256(cfg.path)},
        "inputs": {s.id: {"file": str(s.file), "sha256": file_sha256(s.file)}
                   for s in cfg.sensors},
        "sensors": sensors, "targets": targets, "association": association,
        "rejected_points": rejected,
        "warnings": warnings,
        "time_scale": scale.as_dict(),
        "elapsed_s": elapsed_s,
        "stage_seconds": stage_seconds,
    }


def run(config_path: str | Path, *, clock: StageClock | None = None) -> RunOutput:
    """Process one flight: read the config and logs, fuse every target, write the outputs.

    ``clock`` times the stages (read, screen, assemble, fuse, write, report) and drives the progress
    display; the default shows nothing. Every warning logged on the way is also kept in
    ``summary["warnings"]`` (one line each) for the report page and the terminal's headline.
    """
    with collect_warnings() as warnings:
        return _run(config_path, clock, warnings)


def _run(config_path: str | Path, clock_in: StageClock | None, warnings: list[str]
         ) -> RunOutput:
    clock = _FreeingClock(clock_in or StageClock())
    started = time.perf_counter()
    cfg = load_config(config_path)
    check_output_dir(cfg)
    frame = RangeFrame(cfg.origin)
    with clock.stage("read", len(cfg.sensors)) as tick:
        raw = read_all(cfg, tick)
    with clock.stage("screen", len(cfg.sensors)) as tick:
        screened = screen(cfg, raw, tick)
    logs = screened.logs
    sensor_summary = sensor_summaries(cfg, raw, logs, screened.edits)
    read_rows = {sid: lg.row for sid, lg in raw.items()}
    del raw
    with clock.stage("assemble", sum(s.kind != "ins" for s in cfg.sensors)) as tick:
        rows = assemble_all(cfg, frame, logs, tick)
    settings = estimator_settings(cfg)
    sensor_ids = tuple(s.id for s in cfg.sensors)
    n_no_platform = {sid: a.n_no_platform for sid, a in rows.items()}
    sites = sensor_sites(cfg, frame, rows)
    priors = {tgt.id: target_prior(tgt, frame) for tgt in cfg.targets}
    with clock.stage("associate", 1) as tick:
        # the association's trial trajectories do not restart locked-out tracks nor discount
        # correlated rows (an object that loses its plots there, or that fits them only
        # discounted, is a hint for the association: fusion.lockout, fusion.centralised)
        trial = replace(settings, restart_lockouts=False, discount_first_pass=False)
        associated = associate(cfg, rows, trial, priors, tick)
    parts_of = associated.parts_of
    with clock.stage("fuse", len(parts_of) * (1 + settings.processing.noise_passes)) as tick:
        # each pass lets go of the one before: its pages handed back at each pass's tick
        fused = fuse_objects(cfg, parts_of, sensor_ids, settings, priors, freeing(tick))
    with clock.stage("products", len(fused)) as tick:
        estimated = [oid for oid, _ in fused]
        fused, tracks, residuals, target_summary = settle(
            cfg, frame, fused, settings, sensor_summary, n_no_platform,
            screened.unit_suspicions, logs, screened.edits, tick,
            getattr(associated.synthesis, "return_spread", None))
    if not tracks:
        raise DataError(f"{cfg.path.name}: no target has usable measurements (after editing: "
                        + "; ".join(f"{sid} {len(lg)} rows" for sid, lg in logs.items()) + ")")
    edit_rows = edit_table(screened.edits, fused, logs,
                           {s.id: s.angle_unit for s in cfg.sensors})
    for sid, counts in edit_summary(edit_rows, fused, sensor_ids).items():
        sensor_summary[sid].update(counts)
    # the fusion's per-epoch covariances, residuals and explained variances are not read
    # after the edit table: let go before the row accounting and the achievable pass
    fused = without_covariances(fused)
    # the calendar of the run's times (UTC clock time or seconds from start on the page)
    scale = time_scale([tr.time for tr in tracks] + [r.time for r in residuals],
                       cfg.output.epoch)
    out_dir = make_output_dir(cfg)
    synthesis = associated.synthesis
    with staged_outputs(out_dir) as stage:
        with clock.stage("write"):
            association = association_table(
                cfg, synthesis, {sid: (lg.row, lg.time) for sid, lg in logs.items()},
                associated.kept, {sid: lg.n_read for sid, lg in logs.items()},
                cfg.targets[0].id if synthesis is None else None)
            association = mark_isolated(association, screened.edits)
            account(cfg, sensor_summary, row_accounting(
                cfg, {sid: lg.n_read for sid, lg in logs.items()}, read_rows, logs,
                screened.edits, associated.kept, association, fused), logs)
        # the achievable accuracy once the fusion's covariances and residuals are gone:
        # its pass's filter history is a long sortie's largest array after them
        with clock.stage("products", len(tracks)) as tick:
            tracks = achievable_tracks(tracks, fused, tick)
        # the fusion results and the logs are not read again: their arrays are let go
        # before the report draws
        del fused, logs, screened
        exports: list[Path] = []

        def tables() -> None:           # written while the report's child draws its first figures
            exports.extend(write_tables(stage, cfg, tracks, edit_rows, association))

        with clock.stage("report", 4 + len(residuals) + 2 * (synthesis is not None)) as tick:
            figures = draw_figures(stage / "report", tracks, residuals, sensor_summary, sites,
                                   associated, association, edit_rows, scale, first=tables,
                                   progress=lambda name: tick(1, name))
        summary = run_summary(
            cfg, sensor_summary, target_summary,
            without_objects(association_summary(synthesis, sensor_ids),
                            set(estimated) - set(target_summary)),
            rejected_examples(edit_rows), warnings, scale, time.perf_counter() - started,
            dict(clock.seconds))
        with clock.stage("write"):
            page = write_report_page(stage / "report", figures, summary,
                                     f"rangeproc: {cfg.path.stem}")
            write_json(summary, stage / "summary.json")
    written = [out_dir / "fused.parquet", out_dir / "edits.parquet",
               out_dir / "association.parquet", *(out_dir / p.name for p in exports),
               *(out_dir / "report" / f.name for f in (*figures, page)),
               out_dir / "summary.json"]
    return RunOutput(out_dir, tuple(tracks), tuple(residuals), summary, tuple(written),
                     dict(clock.seconds))
