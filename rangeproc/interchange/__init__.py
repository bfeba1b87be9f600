"""Exports of a run's fused trajectories for tools outside Python (KML, CZML, CSV, ACMI).

``export_run(out_dir, formats)`` reads ``OUT_DIR/fused.parquet`` and writes, beside it,
``fused.kml`` (Google Earth: a time-stamped ``gx:Track`` per object, ``interchange.kml``),
``fused.czml`` (Cesium: time-tagged positions with a 3-sigma ellipsoid, ``interchange.czml``),
``fused.csv`` (spreadsheets: the table with a UTC column, ``interchange.table``) and
``fused.acmi`` / ``fused.zip.acmi`` (Tacview: each object's time-tagged position and the
sensors' sites, text or zipped, ``interchange.acmi``). Times
become calendar UTC through the epoch of the range's time scale
(``interchange.trajectories``): the one given (``--epoch``, ``[output] epoch``, or the one a
run's ``summary.json`` recorded from ``[output] epoch``), else the Unix epoch: silently for
times on the Unix scale (``rangeproc.timescale``), with one warning line for times whose
calendar date is unknown (e.g. seconds of day, which then fall on 1970-01-01).
"""
from __future__ import annotations

import json
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from rangeproc.errors import DataError
from rangeproc.interchange.trajectories import object_trajectories, read_fused, to_utc
from rangeproc.timescale import BASIS_EPOCH, UNIX_EPOCH, on_unix_scale, parse_epoch

if TYPE_CHECKING:
    from rangeproc.config import Config

log = logging.getLogger(__name__)

#: Export format -> the file it is written to (in the run's output folder).
FILES = {"kml": "fused.kml", "czml": "fused.czml", "csv": "fused.csv", "acmi": "fused.acmi",
         "acmi-zip": "fused.zip.acmi"}
#: Export formats, in the order they are written.
FORMATS = tuple(FILES)
#: What ``rangeproc export`` writes without ``--format``: each format once (ACMI as text).
DEFAULT_FORMATS = ("kml", "czml", "csv", "acmi")
#: The files they are written to (in the run's output folder).
EXPORT_FILES = tuple(FILES.values())


def export_run(out_dir: Path, formats: Sequence[str] = DEFAULT_FORMATS, *,
               epoch: str | np.datetime64 | None = None, interval_s: float = 0.0,
               dest: Path | None = None, title: str | None = None,
               table: pd.DataFrame | None = None, config: Config | None = None) -> list[Path]:
    """Write each of ``formats``' file (:data:`FILES`) into ``dest`` (default ``out_dir``).

    epoch: the UTC instant of time 0 of the range's time scale (ISO 8601 with an offset, or a
    ``datetime64``; None: :func:`calendar_epoch` decides, warning when the times' calendar
    date is unknown); interval_s: at most one epoch per this many seconds per object in KML,
    CZML and ACMI (0: every epoch; the CSV always holds every row); table: the fused table when
    the caller has it (a run that has just written it), else ``OUT_DIR/fused.parquet`` is
    read; config: the run's config, for the sensors' sites in ACMI (None: the config that
    ``OUT_DIR/summary.json`` names, :func:`interchange.acmi.run_sites`).
    Returns the written paths. Raises DataError (exit 2) naming the file or option at fault.
    """
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise DataError(f"--format: unknown format '{unknown[0]}' (expected one of: "
                        f"{', '.join(FORMATS)})")
    if interval_s < 0 or not np.isfinite(interval_s):
        raise DataError(f"--interval: must be a finite number of seconds >= 0, got {interval_s}")
    given = None if epoch is None else (
        parse_epoch(epoch) if isinstance(epoch, str) else np.datetime64(epoch, "ns"))
    out_dir = Path(out_dir)
    dest = Path(dest) if dest is not None else out_dir
    if table is None:
        table = read_fused(out_dir)
    origin = given if given is not None else calendar_epoch(
        table["time"].to_numpy(float), out_dir)
    utc = to_utc(table["time"].to_numpy(), origin, str(out_dir / "fused.parquet"))
    objects = object_trajectories(table, utc, interval_s)
    title = title or f"rangeproc {out_dir.resolve().name}"
    written = []
    acmi = None                                   # the ACMI text, made once for both forms
    for fmt in dict.fromkeys(formats):            # each once, in the order given
        if fmt == "kml":
            from rangeproc.interchange.kml import write_kml
            written.append(write_kml(objects, dest / "fused.kml", title))
        elif fmt == "czml":
            from rangeproc.interchange.czml import write_czml
            written.append(write_czml(objects, dest / "fused.czml", title))
        elif fmt == "csv":
            from rangeproc.interchange.table import write_csv
            written.append(write_csv(table, utc, dest / "fused.csv"))
        else:
            from rangeproc.interchange.acmi import acmi_text, config_sites, run_sites, write_acmi
            if acmi is None:
                sites = run_sites(out_dir) if config is None else config_sites(config)
                acmi = acmi_text(objects, sites, title)
            written.append(write_acmi(acmi, dest / FILES[fmt], zipped=fmt == "acmi-zip"))
    return written


def calendar_epoch(time: np.ndarray, out_dir: Path) -> np.datetime64:
    """The UTC instant of time 0 for an export without an epoch: the ``[output] epoch`` that
    ``OUT_DIR/summary.json`` recorded (``time_scale``), else the Unix epoch. When the times
    (N,) s are not on the Unix scale (``rangeproc.timescale``) the Unix epoch is still used,
    with one warning line saying so and naming ``--epoch``."""

    try:
        recorded = json.loads((Path(out_dir) / "summary.json").read_text(encoding="utf-8"))
        entry = recorded.get("time_scale") or {}
        if entry.get("basis") == BASIS_EPOCH and isinstance(entry.get("epoch"), str):
            return parse_epoch(entry["epoch"], "summary.json time_scale.epoch")
    except (OSError, ValueError, AttributeError, DataError):
        pass                             # no run summary (or an unreadable one): the rule
    unix = parse_epoch(UNIX_EPOCH)
    t = time[np.isfinite(time)]
    if t.size and not on_unix_scale(float(t.min()), float(t.max())):
        first = np.datetime_as_string(unix + np.timedelta64(int(round(t.min() * 1e9)), "ns"),
                                      unit="s")
        log.warning("export: the times (%.6g to %.6g s) have no known calendar date (not Unix "
                    "seconds, and no --epoch or [output] epoch given): they were taken as "
                    "seconds from %s, so they start at %sZ; give the UTC instant of time 0 on "
                    "the range's time scale with --epoch (or [output] epoch), e.g. the day's "
                    "00:00 UTC for seconds of day", float(t.min()), float(t.max()), UNIX_EPOCH,
                    first)
    return unix
