"""The fused trajectories of a run, per object, on absolute UTC time: what every export reads.

``fused.parquet`` carries ``time`` in seconds on the range's time scale (contract section 2:
Unix seconds when the inputs' times were ISO strings, otherwise whatever scale the range
uses, e.g. GPS seconds of week). Viewers need calendar time, so an export takes the UTC
instant of time 0 on that scale (``epoch``; default 1970-01-01T00:00:00Z, i.e. the times are
Unix seconds) and adds the seconds to it.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.errors import DataError
from rangeproc.timescale import YEAR_RANGE

#: Columns every export needs from ``fused.parquet`` (contract section 4).
NEEDED = ("target_id", "time", "lat", "lon", "height", "sigma_e", "sigma_n", "sigma_u")


@dataclass(frozen=True, slots=True)
class ObjectTrajectory:
    """One object's exported epochs, time-ordered.

    time: (N,) s on the range time scale; utc: (N,) ``datetime64[ns]`` UTC; lat, lon: (N,)
    WGS-84 degrees; height: (N,) m above the ellipsoid; sigma_enu: (N, 3) 1-sigma position
    uncertainty east, north, up (m); bridged: (N,) bool, epochs inside a gap with no data
    (He 2015's least-squares bridge; all False when the run did not mark any).
    """

    id: str
    time: np.ndarray
    utc: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    height: np.ndarray
    sigma_enu: np.ndarray
    bridged: np.ndarray

    def __len__(self) -> int:
        return int(self.time.shape[0])


def to_utc(time: np.ndarray, epoch: np.datetime64, source: str) -> np.ndarray:
    """``epoch + time`` as ``datetime64[ns]`` (time (N,) s); DataError naming ``source`` when an
    instant falls outside the years :data:`YEAR_RANGE` (a wrong epoch or time scale)."""
    time = np.asarray(time, dtype=float)
    lo = (np.datetime64(f"{YEAR_RANGE[0]}-01-01", "ns") - epoch) / np.timedelta64(1, "s")
    hi = (np.datetime64(f"{YEAR_RANGE[1]}-01-01", "ns") - epoch) / np.timedelta64(1, "s")
    bad = np.flatnonzero(~((time >= lo) & (time < hi)))
    if bad.size:
        raise DataError(f"{source}: row {int(bad[0])}: time {time[bad[0]]:.6g} s after the epoch "
                        f"{np.datetime_as_string(epoch, unit='s')}Z is outside the years "
                        f"{YEAR_RANGE[0]}-{YEAR_RANGE[1]} (give the epoch of the range's time "
                        "scale with --epoch or [output] epoch)")
    return epoch + np.round(time * 1e9).astype("timedelta64[ns]")


def iso_utc(utc: np.ndarray) -> list[str]:
    """ISO-8601 strings with millisecond resolution and a ``Z`` (e.g. 2026-05-11T09:30:00.100Z)."""
    return [s + "Z" for s in np.datetime_as_string(utc, unit="ms")]


def read_fused(out_dir: Path) -> pd.DataFrame:
    """``OUT_DIR/fused.parquet``; DataError naming the file when it is missing, unreadable or
    lacks a column every export needs."""
    path = Path(out_dir) / "fused.parquet"
    if not path.is_file():
        raise DataError(f"{path}: not found (run `rangeproc run` first)")
    try:
        table = pd.read_parquet(path)
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types for a bad file
        raise DataError(f"{path}: not a readable Parquet file ({type(exc).__name__})") from None
    missing = [c for c in NEEDED if c not in table.columns]
    if missing:
        raise DataError(f"{path}: column '{missing[0]}' missing")
    return table


def object_trajectories(table: pd.DataFrame, utc: np.ndarray, interval_s: float = 0.0
                        ) -> list[ObjectTrajectory]:
    """The fused ``table``'s objects (in its target order) with their rows' UTC times
    ``utc`` (N,); interval_s: keep one epoch per this many seconds per object (0: every
    epoch), each object's first and last epochs always kept."""
    time = table["time"].to_numpy(float)
    objects = []
    for oid, rows in table.groupby("target_id", sort=False).indices.items():
        rows = rows[np.argsort(time[rows], kind="stable")]
        rows = rows[_thinned(time[rows], interval_s)]
        bridged = (table["bridged"].to_numpy(dtype=bool)[rows] if "bridged" in table.columns
                   else np.zeros(rows.size, dtype=bool))
        objects.append(ObjectTrajectory(
            id=str(oid), time=time[rows], utc=utc[rows],
            lat=table["lat"].to_numpy(float)[rows], lon=table["lon"].to_numpy(float)[rows],
            height=table["height"].to_numpy(float)[rows],
            sigma_enu=table[["sigma_e", "sigma_n", "sigma_u"]].to_numpy(float)[rows],
            bridged=bridged))
    return objects


def _thinned(t: np.ndarray, interval_s: float) -> np.ndarray:
    """Indices into the sorted times ``t`` (N,) one per ``interval_s`` s, first and last kept."""
    if interval_s <= 0.0 or t.size <= 2:
        return np.arange(t.size)
    slot = np.floor((t - t[0]) / interval_s)
    keep = np.flatnonzero(np.r_[True, slot[1:] != slot[:-1]])
    return np.union1d(keep, [t.size - 1])
