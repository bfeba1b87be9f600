"""Write the PNG report: trajectory, per-sensor residuals, consistency and coverage figures.

``write_report`` is the one entry point. Drawing uses matplotlib's object-oriented API on the
Agg canvas (no pyplot, no global backend switch); style settings are applied in an
``rc_context`` and restored afterwards. Every PNG is written atomically. The figures are
drawn by this process and a forked child side by side (``rangeproc.parallel``).
"""
from __future__ import annotations

import logging
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from rangeproc.parallel import shared_with_child
from rangeproc.report.calibration import plot_calibration
from rangeproc.report.common import (STYLE, TimeOrigin, merge_sensors, safe_name, save_figure,
                                     time_origin)
from rangeproc.report.consistency import plot_consistency
from rangeproc.report.objects import plot_map, plot_object_timeline
from rangeproc.report.residuals import plot_residuals, rejected_points
from rangeproc.report.timeline import plot_coverage
from rangeproc.report.trajectory import plot_trajectory
from rangeproc.results import SensorResiduals, TrackEstimate
from rangeproc.timescale import TimeScale, time_scale

log = logging.getLogger(__name__)

#: Drawing time of a figure relative to one sensor's residual figure (measured on the
#: 10-object scale scenario: consistency 0.88 s, objects 0.77 s, trajectory 0.62 s, a
#: residual figure 0.27-0.48 s); the report draws the costliest first.
_DRAW_COST = {"consistency.png": 2.5, "objects.png": 2.2, "trajectory.png": 1.8,
              "map.png": 1.0, "coverage.png": 1.0, "calibration.png": 0.8}


def residual_file_names(sensor_ids: Sequence[str]) -> list[str]:
    """``residuals_<id>.png`` per sensor id, sanitised and made unique (``_2``, ``_3`` ...)."""
    names: list[str] = []
    seen: set[str] = set()
    for sid in sensor_ids:
        stem = f"residuals_{safe_name(sid)}"
        cand, k = stem, 1
        while cand.lower() in seen:
            k += 1
            cand = f"{stem}_{k}"
        seen.add(cand.lower())
        names.append(f"{cand}.png")
    return names


def write_report(report_dir: Path, tracks: Sequence[TrackEstimate],
                 residuals: Sequence[SensorResiduals], *,
                 sites: Mapping[str, np.ndarray] | None = None,
                 calibration: Mapping[str, Mapping[str, dict]] | None = None,
                 progress: Callable[[str], None] | None = None,
                 association: pd.DataFrame | None = None,
                 stray: np.ndarray | None = None,
                 first: Callable[[], None] = lambda: None,
                 edits: pd.DataFrame | None = None,
                 scale: TimeScale | None = None) -> list[Path]:
    """Draw and write the report figures into ``report_dir`` (created if missing).

    tracks: smoothed trajectories (range ENU metres, s); residuals: post-fit residual sets
    (several sets of one sensor id, e.g. one per target, are drawn together); sites: sensor /
    station id -> (3,) fixed position or (N, 3) platform track in range ENU metres, drawn on
    the map; calibration: ``summary.json``'s per-sensor ``calibration`` entries (drawn when
    any); progress: called with a short message as each figure is written; association: the
    ``association.parquet`` table (columns sensor, row, time, target_id, segment, reason);
    stray: (M, 3) range ENU metres of the unassigned / clutter plots, drawn grey in the plan;
    first: other work this process does while the forked child draws its first figures
    (``rangeproc.parallel.shared_with_child``; before any figure when drawing in one process);
    edits: the ``edits.parquet`` table, whose rejected points (those removed before
    estimation too) the residual figures draw (``residuals.rejected_points``);
    scale: the run's calendar (``rangeproc.timescale``; default: the module's rule on the
    tracks' and residuals' times without an epoch): time axes show UTC clock time when it is
    known, else seconds from the first epoch.

    Writes ``trajectory.png``, ``residuals_<sensor>.png`` per sensor (after the calibration's
    corrections), ``consistency.png``, ``coverage.png``, ``objects.png`` (which sensor saw
    which object when) and ``map.png`` (every object in plan view; both only when
    ``association`` holds any row) and ``calibration.png`` (when any); returns their
    paths in that order. Each file is written atomically (temp
    file + ``os.replace``), so an exception leaves no partial or temp file behind; files
    finished before the exception stay.
    """
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    say = progress or (lambda msg: None)
    views = merge_sensors(residuals)
    if scale is None:
        scale = time_scale([tr.time for tr in tracks] + [v.time for v in views])
    t0 = TimeOrigin(time_origin(tracks, views), scale)
    jobs: list[tuple[str, Callable[[], Figure]]] = [
        ("trajectory.png", lambda: plot_trajectory(tracks, sites, t0))]
    for view, name in zip(views, residual_file_names([v.sensor_id for v in views])):
        jobs.append((name, lambda v=view: plot_residuals(v, t0, rejected_points(v, edits))))
    jobs.append(("consistency.png", lambda: plot_consistency(views, t0)))
    jobs.append(("coverage.png", lambda: plot_coverage(views, tracks, t0, edits)))
    if association is not None and len(association):
        jobs.append(("objects.png", lambda: plot_object_timeline(association, tracks, t0)))
        jobs.append(("map.png", lambda: plot_map(
            tracks, np.zeros((0, 3)) if stray is None else stray, sites)))
    if calibration:
        jobs.append(("calibration.png", lambda: plot_calibration(calibration)))

    # the costliest figures first, so the two processes finish together (longest job first)
    order = sorted(range(len(jobs)), key=lambda k: -_DRAW_COST.get(jobs[k][0], 1.0))

    def draw(k: int) -> None:
        name, plot = jobs[order[k]]
        with matplotlib.rc_context(STYLE):
            save_figure(plot(), report_dir / name)

    def done(k: int) -> None:
        say(f"report: {jobs[order[k]][0]}")
        log.debug("wrote %s", report_dir / jobs[order[k]][0])

    shared_with_child(draw, len(jobs), done, first)
    written = [report_dir / name for name, _ in jobs]
    log.info("report: %d figures in %s", len(written), report_dir)
    return written
