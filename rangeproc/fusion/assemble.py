"""Turn sensor logs into measurement rows with per-row geometry (range ENU frame).

Per kind (DATA_CONTRACT sections 1-2):

* a 2-D radar (elevation empty in every row): elevation 0 with
  :data:`PLANE_ELEVATION_SIGMA`, the target in the sensor's horizontal plane.
* radar / theodolite at a fixed ``site``: SPHERICAL rows ``[R, A, E, Rdot]`` with the site's
  position and its own local-ENU rotation (azimuth from the site's true north).
* radar / theodolite on a ``platform``: the INS attitude and position are interpolated to each
  row time (attitude by Slerp), the lever arm is applied, and the rotation maps range ENU to the
  deck axes (right, forward, up) so the unstabilised deck angles are modelled directly
  (He 2015 sec. 3.2 stabilisation, done inside the measurement model; rows outside the INS
  span or in an INS gap are dropped and counted).
* gps: CARTESIAN rows: position converted to range ENU then expressed in the receiver's local
  ENU axes (where the noise is diagonal: horizontal, horizontal, vertical), velocity as given
  (local ENU at the receiver).
* mistram: SPHERICAL rows with only the range rate, sensor = the row's station.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from rangeproc.config import SensorSettings
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.frames.platform import platform_geometry
from rangeproc.fusion.batch import MeasurementBatch, SensorRows, empty_rows
from rangeproc.io.logs import SensorLog
from rangeproc.models.measurement import CARTESIAN, ELEVATION, SPHERICAL

#: rad: 1-sigma of the elevation 0 given to every row of a 2-D radar (a radar file whose
#: elevation column is empty throughout: a navigation radar's or a scanning lidar's plots).
#: Its fan beam is some 20 deg tall, so the target is in the sensor's horizontal plane to
#: about a tenth of a radian; without this the height is unobservable and the smoothed height
#: (and with it the slant range's horizontal part) wanders freely.
PLANE_ELEVATION_SIGMA = 0.1

#: Body FRD -> (right, forward, up) deck axes used by the SPHERICAL model (its own inverse).
FRD_TO_DECK = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def mount_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(3, 3) sensor-to-body rotation ``M = Rz(yaw) Ry(pitch) Rx(roll)`` of a platform
    sensor's mount angles (rad; data contract section 4): the sensor measures
    ``d_sensor = M^T d_body``."""
    return Rotation.from_euler("ZYX", [yaw, pitch, roll]).as_matrix()


def deck_turn(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(3, 3) ``P M^T P``: turns deck axes (right, forward, up) of the INS body into those
    of a sensor mounted with these angles (rad): ``Qr_sensor = deck_turn @ Qr_body``."""
    return FRD_TO_DECK @ mount_rotation(roll, pitch, yaw).T @ FRD_TO_DECK


@dataclass(frozen=True, slots=True)
class Assembled:
    """Rows of one sensor plus bookkeeping: rows dropped for lack of platform geometry."""

    rows: SensorRows
    n_no_platform: int


def _finish(t: np.ndarray, arrays: dict[str, np.ndarray], log: SensorLog,
            keep: np.ndarray | None = None) -> SensorRows:
    n = len(t)
    station = log.station if log.station is not None else np.full(n, -1, dtype=np.int64)
    track = log.track_id if log.track_id is not None else np.full(n, -1, dtype=np.int64)
    rows = SensorRows(t=t, source_row=np.arange(n, dtype=np.int64), station=station,
                      track=track, **arrays)
    if keep is None or keep.all():
        return rows
    return SensorRows(**{f: getattr(rows, f)[keep] for f in SensorRows.__slots__})


def assumed_elevation(batch: MeasurementBatch) -> np.ndarray:
    """(N,) bool: rows of ``batch`` whose elevation is
    a 2-D radar's assumption (0 with :data:`PLANE_ELEVATION_SIGMA`), not a measurement."""
    return ((batch.model == SPHERICAL) & (batch.z[:, ELEVATION] == 0.0)
            & (batch.sigma[:, ELEVATION] == PLANE_ELEVATION_SIGMA))


def _spherical(log: SensorLog, cfg: SensorSettings) -> dict[str, np.ndarray]:
    """Rows ``[R, A, E, Rdot]`` with the known bias corrections removed."""
    n = len(log)
    a = empty_rows(n, SPHERICAL)
    cols = log.columns
    names = ("range", "azimuth", "elevation", "range_rate")
    for i, name in enumerate(names):
        if name in cols:
            a["z"][:, i] = cols[name] - cfg.calibration.get(name, 0.0)
        if name in cfg.sigma:
            a["sigma"][:, i] = cfg.sigma[name]
    if cfg.kind == "radar" and n and np.isnan(a["z"][:, 2]).all():
        a["z"][:, 2] = 0.0
        a["sigma"][:, 2] = PLANE_ELEVATION_SIGMA
    return a


def assemble_sensor(log: SensorLog, cfg: SensorSettings, frame: RangeFrame,
                    ins_logs: dict[str, SensorLog]) -> Assembled:
    """Measurement rows of one non-INS sensor (see module docstring)."""
    n = len(log)
    if cfg.kind in ("radar", "theodolite"):
        a = _spherical(log, cfg)
        if cfg.site is not None:
            pos, rot = frame.site(cfg.site)
            a["s"][:] = pos
            a["Qr"][:] = rot
            return Assembled(_finish(log.time, a, log), 0)
        geom = platform_geometry(ins_logs[str(cfg.platform)], frame, log.time,
                                 np.asarray(cfg.lever_arm, dtype=float))
        a["s"][:] = geom.position
        a["sv"][:] = geom.velocity
        # range ENU -> body FRD is body_to_range^T; then FRD -> deck (right, forward, up),
        # turned into the sensor's own axes by a known mount misalignment.
        mount = deck_turn(*(cfg.calibration.get(n, 0.0)
                            for n in ("mount_roll", "mount_pitch", "mount_yaw")))
        a["Qr"][:] = mount @ FRD_TO_DECK @ np.transpose(geom.body_to_range, (0, 2, 1))
        valid = np.asarray(geom.valid, dtype=bool)
        return Assembled(_finish(log.time, a, log, valid), int(n - valid.sum()))
    if cfg.kind == "gps":
        a = empty_rows(n, CARTESIAN)
        lat, lon, h = log.columns["lat"], log.columns["lon"], log.columns["height"]
        pos_ok = np.isfinite(lat) & np.isfinite(lon)
        # Receiver-local axes: where the position is missing, borrow the nearest valid one.
        if pos_ok.any():
            idx = np.flatnonzero(pos_ok)
            near = idx[np.clip(np.searchsorted(idx, np.arange(n)), 0, len(idx) - 1)]
            rot = frame.local_rotation(lat[near], lon[near])
            a["Qr"][:] = rot
            # An empty height means the vertical was not measured. In the receiver's local
            # ENU axes a height change only moves the point along the local normal (the u
            # axis), so east/north do not depend on the height used for the conversion.
            h_conv = np.where(np.isfinite(h), h, 0.0)[pos_ok]
            p = frame.to_enu(lat[pos_ok], lon[pos_ok], h_conv)
            a["z"][pos_ok, :3] = np.einsum("nij,nj->ni", rot[pos_ok], p)
            a["z"][pos_ok & ~np.isfinite(h), 2] = np.nan
        for i, name in enumerate(("ve", "vn", "vu")):
            a["z"][:, 3 + i] = log.columns[name]
        sig = cfg.sigma
        a["sigma"][:] = [sig["horizontal"], sig["horizontal"], sig["vertical"],
                         sig["velocity"], sig["velocity"], sig["velocity"]]
        return Assembled(_finish(log.time, a, log), 0)
    if cfg.kind == "mistram":
        a = empty_rows(n, SPHERICAL)
        a["z"][:, 3] = log.columns["range_rate"]
        a["sigma"][:, 3] = cfg.sigma["range_rate"]
        sites = np.array([frame.to_enu(st.site.lat, st.site.lon, st.site.height).reshape(3)
                          for st in cfg.stations])
        assert log.station is not None
        a["s"][:] = sites[log.station]
        return Assembled(_finish(log.time, a, log), 0)
    raise ValueError(f"assemble_sensor: kind {cfg.kind!r} has no measurement rows")
