"""In-memory form of one sensor's log after reading: NumPy columns in SI units."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True, slots=True)
class SensorLog:
    """One sensor file, read, unit-converted and sorted by time (stable sort).

    Attributes:
        sensor_id: the config ``id``.
        kind: one of ``radar``, ``theodolite``, ``gps``, ``mistram``, ``ins``.
        time: (N,) float64 seconds on the range time scale, ``time_offset`` already added,
            ascending.
        columns: name -> (N,) float64, SI: metres, m/s, **radians** for every angle
            (azimuth, elevation, roll, pitch, yaw); geodetic ``lat``/``lon`` stay in **degrees**,
            ``height`` metres. NaN = component not measured (empty cell / null).
            radar: range, azimuth, elevation, range_rate
            theodolite: azimuth, elevation, range
            gps: lat, lon, height, ve, vn, vu
            mistram: range_rate
            ins: roll, pitch, yaw, lat, lon, height, ve, vn, vu
            Optional columns absent from the file are present here as all-NaN arrays.
        row: (N,) int64, the 1-based data-row number in the file (CSV: line number minus 1,
            i.e. first data row = 1; Parquet: row index + 1). Used in messages and reports.
        track_id: (N,) int64 sensor-local track number, or None when the file has no track_id.
        station: (N,) int64 index into the sensor's ``stations`` (mistram only), else None.
        n_read: rows in the file (before dropping rows with nothing measured).
    """

    sensor_id: str
    kind: str
    time: np.ndarray
    columns: Mapping[str, np.ndarray]
    row: np.ndarray
    track_id: np.ndarray | None
    station: np.ndarray | None
    n_read: int

    def __len__(self) -> int:
        return int(self.time.shape[0])


def select_rows(log: SensorLog, keep: np.ndarray) -> SensorLog:
    """A new log holding only the rows where ``keep`` (N,) bool is True (arrays read-only)."""
    def take(a: np.ndarray | None) -> np.ndarray | None:
        if a is None:
            return None
        out = a[keep]
        out.flags.writeable = False
        return out

    columns = {k: take(v) for k, v in log.columns.items()}
    return SensorLog(sensor_id=log.sensor_id, kind=log.kind, time=take(log.time),
                     columns=MappingProxyType(columns), row=take(log.row),
                     track_id=take(log.track_id), station=take(log.station), n_read=log.n_read)


def replace_columns(log: SensorLog, columns: Mapping[str, np.ndarray]) -> SensorLog:
    """A new log with some measurement columns replaced (same rows; arrays made read-only)."""
    merged = dict(log.columns)
    for k, v in columns.items():
        v.flags.writeable = False
        merged[k] = v
    return SensorLog(sensor_id=log.sensor_id, kind=log.kind, time=log.time,
                     columns=MappingProxyType(merged), row=log.row, track_id=log.track_id,
                     station=log.station, n_read=log.n_read)
