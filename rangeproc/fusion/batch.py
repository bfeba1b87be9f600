"""The measurement batch: every usable row of every sensor for one target, as flat arrays."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rangeproc.estimation.forward import FilterRows
from rangeproc.models.measurement import N_COMPONENTS


@dataclass(frozen=True, slots=True)
class MeasurementBatch:
    """Rows of all sensors of one target, sorted by time (stable: sensor order at equal times).

    t: (N,) s; model: (N,) int64 measurement model code (``rangeproc.models.measurement``);
    z: (N, 6) measured components (SI, NaN = not measured); sigma: (N, 6) a-priori 1-sigma;
    s, sv: (N, 3) sensor position (m) and velocity (m/s) in range ENU; Qr: (N, 3, 3) rotation
    range ENU -> sensor-local axes; sensor: (N,) int64 index into ``sensor_ids``;
    source_row: (N,) int64 index of the row in that sensor's SensorLog; station: (N,) int64
    MISTRAM station index or -1; track: (N,) int64 sensor-local track id or -1.
    """

    t: np.ndarray
    model: np.ndarray
    z: np.ndarray
    sigma: np.ndarray
    s: np.ndarray
    sv: np.ndarray
    Qr: np.ndarray
    sensor: np.ndarray
    source_row: np.ndarray
    station: np.ndarray
    track: np.ndarray
    sensor_ids: tuple[str, ...]

    def __len__(self) -> int:
        return int(self.t.shape[0])

    def rows(self, sl: slice | np.ndarray) -> MeasurementBatch:
        """The rows in ``sl``: views for a slice, copies for an index array."""
        return MeasurementBatch(self.t[sl], self.model[sl], self.z[sl], self.sigma[sl],
                                self.s[sl], self.sv[sl], self.Qr[sl], self.sensor[sl],
                                self.source_row[sl], self.station[sl], self.track[sl],
                                self.sensor_ids)

    def filter_rows(self, epoch_t: np.ndarray, meas_epoch: np.ndarray) -> FilterRows:
        """The rows as the forward filter takes them (``estimation.forward.run_filter``), with
        a pass's epochs ``epoch_t`` (E,) s and each row's epoch index ``meas_epoch`` (N,)."""
        return FilterRows(epoch_t, meas_epoch, self.model, self.z, self.sigma, self.s, self.sv,
                          self.Qr, self.sensor)

    def series(self) -> list[np.ndarray]:
        """Row indices (time ordered) of each independent series: sensor x MISTRAM station x
        sensor track."""
        key = (self.sensor * 1_000_003 + (self.station + 1)) * 1_000_003 + (self.track + 1)
        order = np.argsort(key, kind="stable")      # stable keeps time order within a key
        cuts = np.flatnonzero(np.diff(key[order])) + 1
        return [g for g in np.split(order, cuts) if len(g) > 0]

    def thinned(self, stride: int, least_rate_hz: float, least_rows: int) -> np.ndarray:
        """Sorted indices of an evenly thinned subset of the rows: each series
        (:meth:`series`) keeps every ``k``-th row and its last, ``k = stride`` unless that
        leaves it under ``least_rate_hz`` rows per second of its own span or under
        ``least_rows`` rows (then less thinned, or whole).

        Thinning per series, not every ``stride``-th row of the merged batch: rows at equal
        times come in a fixed order (sensor, then station), and a global stride aliases with
        it, keeping some MISTRAM stations or sensors and dropping others for minutes."""
        keep = np.zeros(len(self), dtype=bool)
        for rows in self.series():
            span = float(self.t[rows[-1]] - self.t[rows[0]])
            need = max(least_rows, int(np.ceil(least_rate_hz * span)), 1)
            k = max(1, min(stride, len(rows) // need))
            keep[rows[::k]] = True
            keep[rows[-1]] = True
        if len(self):
            keep[0] = keep[-1] = True               # the first and last epochs stay
        return np.flatnonzero(keep)

    def with_sigma(self, sigma: np.ndarray) -> MeasurementBatch:
        """A copy sharing every array but ``sigma`` (N, 6)."""
        return MeasurementBatch(self.t, self.model, self.z, sigma, self.s, self.sv, self.Qr,
                                self.sensor, self.source_row, self.station, self.track,
                                self.sensor_ids)


@dataclass(frozen=True, slots=True)
class SensorRows:
    """One sensor's contribution before merging (same fields as the batch, unsorted)."""

    t: np.ndarray
    model: np.ndarray
    z: np.ndarray
    sigma: np.ndarray
    s: np.ndarray
    sv: np.ndarray
    Qr: np.ndarray
    source_row: np.ndarray
    station: np.ndarray
    track: np.ndarray


def empty_rows(n: int, model: int) -> dict[str, np.ndarray]:
    """Allocate the arrays of ``n`` rows of one model, NaN measurements and unit sigmas."""
    return {
        "model": np.full(n, model, dtype=np.int64),
        "z": np.full((n, N_COMPONENTS), np.nan),
        "sigma": np.ones((n, N_COMPONENTS)),
        "s": np.zeros((n, 3)),
        "sv": np.zeros((n, 3)),
        "Qr": np.tile(np.eye(3), (n, 1, 1)),
    }


def merge(parts: list[tuple[int, SensorRows]], sensor_ids: tuple[str, ...]) -> MeasurementBatch:
    """Concatenate per-sensor rows (tagged with their sensor index) and sort stably by time."""
    if not parts:
        z = np.empty((0, N_COMPONENTS))
        return MeasurementBatch(np.empty(0), np.empty(0, np.int64), z, z.copy(),
                                np.empty((0, 3)), np.empty((0, 3)), np.empty((0, 3, 3)),
                                np.empty(0, np.int64), np.empty(0, np.int64),
                                np.empty(0, np.int64), np.empty(0, np.int64), sensor_ids)
    t = np.concatenate([p.t for _, p in parts])
    order = np.argsort(t, kind="stable")

    def cat(name: str) -> np.ndarray:       # np.take: the row gather, faster than [order]
        return np.take(np.concatenate([getattr(p, name) for _, p in parts]), order, axis=0)

    sensor = np.concatenate([np.full(len(p.t), i, dtype=np.int64) for i, p in parts])
    return MeasurementBatch(
        t=np.take(t, order), model=cat("model"), z=cat("z"), sigma=cat("sigma"),
        s=cat("s"), sv=cat("sv"), Qr=cat("Qr"), sensor=np.take(sensor, order),
        source_row=cat("source_row"), station=cat("station"), track=cat("track"),
        sensor_ids=sensor_ids)


def concat_batches(parts: list[MeasurementBatch]) -> MeasurementBatch:
    """Rows of several batches of the same sensors, in the given order (a single part is
    returned as it is)."""
    if len(parts) == 1:
        return parts[0]

    def cat(name: str) -> np.ndarray:
        return np.ascontiguousarray(np.concatenate([getattr(p, name) for p in parts]))

    return MeasurementBatch(cat("t"), cat("model"), cat("z"), cat("sigma"), cat("s"), cat("sv"),
                            cat("Qr"), cat("sensor"), cat("source_row"), cat("station"),
                            cat("track"), parts[0].sensor_ids)
