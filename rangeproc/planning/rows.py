"""The rows a flight would give: every configured sensor's measurements along a planned
trajectory, with the geometry, noise and rates the config states (``rangeproc plan``).

For each sensor of the config (INS logs are read from their files: a platform sensor needs
its platform's motion) the rows are stamped at the sensor's rate over the trajectory's span,
assembled with its geometry exactly as a run assembles them (``fusion.assemble``: a fixed
site's axes, a GPS receiver's local axes, a platform's deck axes from its INS), and their
values set to the measurement model at the planned state plus Gaussian noise of the sensor's
stated sigma (seeded): what the instruments would report on that flight, with nothing wild.

What a sensor measures and how often:

* with its file present (a config of a flight already made), the components the file holds
  and its median sample interval;
* else the kind's usual components (radar: range, azimuth, elevation; theodolite: azimuth,
  elevation; GPS: position and velocity; MISTRAM: range rate at every station) at the
  sensor's ``rate_hz``, or the kind's :data:`KIND_RATE_HZ`.

A radar or theodolite row is kept only above :data:`MIN_ELEVATION` (below the horizon it
sees nothing), a platform sensor's only where its INS covers the time.
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from rangeproc.config import Config
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.fusion.assemble import assemble_sensor
from rangeproc.fusion.batch import MeasurementBatch, SensorRows, merge
from rangeproc.io.logs import SensorLog
from rangeproc.io.readers import read_sensor
from rangeproc.settings import SensorSettings

log = logging.getLogger(__name__)

#: Sample rate (Hz) of a sensor without a file or ``rate_hz``, per kind (MISTRAM: per station).
KIND_RATE_HZ = {"radar": 20.0, "theodolite": 20.0, "gps": 10.0, "mistram": 10.0}
#: The kind's usual components when no file says which (``SensorLog.columns`` names).
KIND_COLUMNS = {"radar": ("range", "azimuth", "elevation"),
                "theodolite": ("azimuth", "elevation"),
                "gps": ("lat", "lon", "height", "ve", "vn", "vu"),
                "mistram": ("range_rate",)}
ALL_COLUMNS = {"radar": ("range", "azimuth", "elevation", "range_rate"),
               "theodolite": ("azimuth", "elevation", "range"),
               "gps": ("lat", "lon", "height", "ve", "vn", "vu"),
               "mistram": ("range_rate",)}
#: Lowest elevation (rad) at which a radar or theodolite sees the target (0.5 deg).
MIN_ELEVATION = np.radians(0.5)


@dataclass(frozen=True, slots=True)
class SensorPlan:
    """How a sensor is planned: its rate (Hz), components, and where they came from."""

    rate_hz: float
    columns: tuple[str, ...]
    source: str


def sensor_plan(s: SensorSettings, existing: SensorLog | None) -> SensorPlan:
    """The rate and components of sensor ``s``: from its file's log ``existing`` when read,
    else ``rate_hz`` or the kind's default and the kind's usual components."""
    if existing is not None and len(existing.time) > 1:
        t = existing.time
        if existing.station is not None:            # MISTRAM: one station's stamps
            t = t[existing.station == np.bincount(existing.station).argmax()]
        dt = np.diff(np.unique(t))
        rate = float(1.0 / np.median(dt)) if len(dt) else KIND_RATE_HZ[s.kind]
        cols = tuple(c for c in ALL_COLUMNS[s.kind]
                     if np.isfinite(existing.columns[c]).any())
        return SensorPlan(s.rate_hz or rate, cols, "file")
    return SensorPlan(s.rate_hz or KIND_RATE_HZ[s.kind], KIND_COLUMNS[s.kind],
                      "rate_hz" if s.rate_hz else "defaults")


def read_existing(s: SensorSettings) -> SensorLog | None:
    """The sensor's log if its file can be read (a flight already made), else None."""
    try:
        return read_sensor(s) if s.file.exists() else None
    except Exception as exc:          # an unreadable file plans as if absent  # noqa: BLE001
        log.info("plan: %s: file not used (%s)", s.id, exc)
        return None


def _log(s: SensorSettings, t: np.ndarray, columns: tuple[str, ...], frame: RangeFrame,
         p: np.ndarray, station: np.ndarray | None) -> SensorLog:
    """A SensorLog of sensor ``s`` at times ``t`` with ``columns`` present: GPS positions at
    the planned track (the receiver's local axes depend on them), every other value zero
    (set afterwards from the model)."""
    n = len(t)
    cols = {c: np.full(n, np.nan) for c in ALL_COLUMNS[s.kind]}
    for c in columns:
        cols[c] = np.zeros(n)
    if s.kind == "gps":
        lat, lon, h = frame.to_geodetic(p)
        cols["lat"], cols["lon"], cols["height"] = (np.asarray(lat, float), np.asarray(lon, float),
                                                    np.asarray(h, float))
    return SensorLog(sensor_id=s.id, kind=s.kind, time=t, columns=cols,
                     row=np.arange(1, n + 1, dtype=np.int64), track_id=None, station=station,
                     n_read=n)


def planned_rows(cfg: Config, frame: RangeFrame, state: Callable, t0: float, t1: float,
                 seed: int = 1) -> tuple[MeasurementBatch, dict[str, SensorPlan], list[str]]:
    """Every sensor's rows along the planned track (module docstring).

    state: range times (M,) s -> (position, velocity, acceleration) (M, 3) range ENU;
    [t0, t1]: the span (s). Returns the batch (noisy values), each sensor's plan, and a line
    per sensor left out (why).
    """
    g = np.random.default_rng(seed)
    ins = {s.id: read_existing(s) for s in cfg.sensors if s.kind == "ins"}
    ins = {k: v for k, v in ins.items() if v is not None}
    sensor_ids = tuple(s.id for s in cfg.sensors)
    parts: list[tuple[int, SensorRows]] = []
    plans: dict[str, SensorPlan] = {}
    left_out: list[str] = []
    for i, s in enumerate(cfg.sensors):
        if s.kind == "ins":
            continue
        if s.platform is not None and s.platform not in ins:
            left_out.append(f"{s.id}: its platform's INS ({s.platform}) has no readable file")
            continue
        plan = sensor_plan(s, read_existing(s))
        if not plan.columns:
            left_out.append(f"{s.id}: measures nothing")
            continue
        plans[s.id] = plan
        t = np.arange(t0, t1, 1.0 / plan.rate_hz)
        station = None
        if s.kind == "mistram":
            k = max(len(s.stations), 1)
            station = np.tile(np.arange(k, dtype=np.int64), len(t))
            t = np.repeat(t, k)
        p = state(t)[0]
        assembled = assemble_sensor(_log(s, t, plan.columns, frame, p, station), s, frame, ins)
        rows = assembled.rows
        if assembled.n_no_platform:
            log.info("plan: %s: %d rows outside its platform's INS", s.id,
                     assembled.n_no_platform)
        rows = _with_values(rows, s, state, g)
        if len(rows.t) == 0:
            left_out.append(f"{s.id}: never sees the target (below {np.degrees(MIN_ELEVATION):g}"
                            " deg elevation throughout)")
            continue
        parts.append((i, rows))
    return merge(parts, sensor_ids), plans, left_out


def _with_values(rows: SensorRows, s: SensorSettings, state: Callable,
                 g: np.random.Generator) -> SensorRows:
    """The rows with ``z = h(x) + noise`` at the planned state (NaN components stay NaN),
    radar and theodolite rows below :data:`MIN_ELEVATION` left out."""
    if len(rows.t) == 0:
        return rows
    p, v, a = state(rows.t)
    x = np.ascontiguousarray(np.column_stack([p, v, a]))
    z0 = np.where(np.isfinite(rows.z), 0.0, np.nan)
    idx = np.arange(len(rows.t), dtype=np.int64)
    res, _ = smoothed_residuals(idx, rows.model, z0, rows.s, rows.sv, rows.Qr, x,
                                np.zeros((len(rows.t), 45)))
    h = -res                                          # z0 - h(x) with z0 = 0 (angles wrapped)
    z = h + g.normal(0.0, 1.0, h.shape) * rows.sigma
    keep = np.ones(len(rows.t), dtype=bool)
    if s.kind in ("radar", "theodolite"):
        keep = h[:, 2] >= MIN_ELEVATION
    fields = {f: getattr(rows, f) for f in SensorRows.__slots__}
    fields["z"] = np.where(np.isfinite(rows.z), z, np.nan)
    return SensorRows(**{f: val[keep] for f, val in fields.items()})
