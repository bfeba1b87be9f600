"""Exports of a run's fused trajectories for tools outside Python (issue 11, part 3).

``export_run(out_dir, formats)`` reads ``OUT_DIR/fused.parquet`` and writes, beside it,
``fused.kml`` (Google Earth: a time-stamped ``gx:Track`` per object, ``interchange.kml``),
``fused.czml`` (Cesium: time-tagged positions with a 3-sigma ellipsoid, ``interchange.czml``)
and ``fused.csv`` (spreadsheets: the table with a UTC column, ``interchange.table``). Times
become calendar UTC through the epoch of the range's time scale
(``interchange.trajectories``).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.errors import DataError
from rangeproc.interchange.trajectories import (UNIX_EPOCH, object_trajectories, parse_epoch,
                                                read_fused, to_utc)

#: Export formats, in the order they are written.
FORMATS = ("kml", "czml", "csv")
#: The files they are written to (in the run's output folder).
EXPORT_FILES = tuple(f"fused.{fmt}" for fmt in FORMATS)


def export_run(out_dir: Path, formats: Sequence[str] = FORMATS, *,
               epoch: str | np.datetime64 = UNIX_EPOCH, interval_s: float = 0.0,
               dest: Path | None = None, title: str | None = None,
               table: pd.DataFrame | None = None) -> list[Path]:
    """Write ``fused.<format>`` for each of ``formats`` into ``dest`` (default ``out_dir``).

    epoch: the UTC instant of time 0 of the range's time scale (ISO 8601 with an offset, or a
    ``datetime64``); interval_s: at most one epoch per this many seconds per object in KML
    and CZML (0: every epoch; the CSV always holds every row); table: the fused table when the
    caller has it (a run that has just written it), else ``OUT_DIR/fused.parquet`` is read.
    Returns the written paths. Raises DataError (exit 2) naming the file or option at fault.
    """
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise DataError(f"--format: unknown format '{unknown[0]}' (expected one of: "
                        f"{', '.join(FORMATS)})")
    if interval_s < 0 or not np.isfinite(interval_s):
        raise DataError(f"--interval: must be a finite number of seconds >= 0, got {interval_s}")
    origin = parse_epoch(epoch) if isinstance(epoch, str) else np.datetime64(epoch, "ns")
    out_dir = Path(out_dir)
    dest = Path(dest) if dest is not None else out_dir
    if table is None:
        table = read_fused(out_dir)
    utc = to_utc(table["time"].to_numpy(), origin, str(out_dir / "fused.parquet"))
    objects = object_trajectories(table, utc, interval_s)
    title = title or f"rangeproc {out_dir.resolve().name}"
    written = []
    for fmt in dict.fromkeys(formats):            # each once, in the order given
        if fmt == "kml":
            from rangeproc.interchange.kml import write_kml
            written.append(write_kml(objects, dest / "fused.kml", title))
        elif fmt == "czml":
            from rangeproc.interchange.czml import write_czml
            written.append(write_czml(objects, dest / "fused.czml", title))
        else:
            from rangeproc.interchange.table import write_csv
            written.append(write_csv(table, utc, dest / "fused.csv"))
    return written
