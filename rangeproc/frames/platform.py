"""Moving-platform geometry: sensor position, velocity and orientation from an INS log, and
stabilisation of deck (body-frame) angles.

Conventions (DATA_CONTRACT section 1): body frame FRD (x bow, y starboard, z down); attitude
body-to-NED ``C = Rz(yaw) Ry(pitch) Rx(roll)`` relative to the local NED frame at the platform.

Deck (unstabilised) angles of a platform-mounted sensor are measured in the body frame:
azimuth ``az_u`` from +x toward +y (clockwise seen from above), elevation ``el_u`` above the deck
plane (toward -z); the line-of-sight unit vector in FRD is
``[cos el_u cos az_u, cos el_u sin az_u, -sin el_u]``. Stabilised angles are the same
line of sight in the local NED frame at the platform: azimuth clockwise from north, elevation
above the local horizontal. Range is invariant. This is the stabilisation of He 2015 eq. (11),
done through the rotation (FRD unit vector -> C -> NED -> az/el) rather than the printed,
garbled closed form.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from rangeproc.errors import DataError
from rangeproc.frames.attitude import (
    NED_TO_ENU,
    body_to_ned,
    clean_series,
    locate,
    rates_at_samples,
)
from rangeproc.frames.geodesy import RangeFrame
from rangeproc.frames.rotation_kernels import euler_matrices, relative_rotvecs, slerp_matrices
from rangeproc.io.logs import SensorLog

__all__ = [
    "SensorGeometry",
    "deck_angles",
    "deck_to_range",
    "deck_to_stabilised",
    "deck_unit_vector",
    "platform_geometry",
    "range_to_deck",
    "stabilised_to_deck",
]

log = logging.getLogger(__name__)

_TWO_PI = 2.0 * np.pi
_INS_REQUIRED = ("roll", "pitch", "yaw", "lat", "lon", "height")


@dataclass(frozen=True, slots=True, eq=False)
class SensorGeometry:
    """A platform-mounted sensor at N query times (all in the range ENU frame).

    Attributes:
        position: (N, 3) sensor position (INS point + rotated lever arm), m.
        velocity: (N, 3) sensor velocity, m/s.
        body_to_range: (N, 3, 3) rotation mapping a body-FRD vector into range ENU.
        valid: (N,) bool; False outside the INS time span or inside an INS gap (the other
            fields then hold the nearest INS sample's values, never NaN).
    """

    position: np.ndarray
    velocity: np.ndarray
    body_to_range: np.ndarray
    valid: np.ndarray


def _lerp(values: np.ndarray, k: np.ndarray, frac: np.ndarray) -> np.ndarray:
    """Linear interpolation of (K, 3) sample values on interval k at fraction frac -> (N, 3)."""
    return values[k] + frac[:, None] * (values[k + 1] - values[k])


def platform_geometry(
    ins: SensorLog,
    frame: RangeFrame,
    t_query: ArrayLike,
    lever_arm: ArrayLike = (0.0, 0.0, 0.0),
    *,
    max_gap: float = 1.0,
) -> SensorGeometry:
    """Sensor position, velocity and body->range rotation at ``t_query`` from an INS log.

    Method (INS rows with a non-finite time, attitude or position are dropped and become gaps;
    among equal times the first row is kept):

    - INS position: the INS lat/lon/height converted to range ENU, interpolated **linearly**
      in time (adequate for 50-100 Hz INS: error ~ a dt^2 / 8, 0.1 mm at 1 m/s^2, 100 Hz).
    - Orientation: ``M_k = L_k^T @ NED_TO_ENU @ C_k`` at each INS sample (L_k =
      ``frame.local_rotation`` at the INS position, C_k = :func:`body_to_ned`), interpolated by
      slerp (``frames.rotation_kernels``, compiled; as scipy's ``Slerp``). At the samples
      this is exactly ``local_rotation^T @ NED_TO_ENU @ C_bn``; between samples it also
      carries the (~1e-6 rad/s) turn of the local vertical along the track.
    - Sensor position: ``p_ins + M @ lever_arm``.
    - Sensor velocity: at each INS sample the INS velocity (ve, vn, vu: local ENU, rotated to
      range ENU by L_k^T) where all three are finite, else the second-order central difference
      of the INS positions (one-sided at gaps); then interpolated linearly to t_query. Plus the
      lever-arm rate ``M @ (w x lever_arm)``, where the body-frame angular velocity w is the
      same central difference applied to the slerp's per-interval rates
      ``rotvec(M_k^-1 M_k+1) / h_k`` and interpolated linearly.

    Args:
        ins: an ``ins`` SensorLog (columns roll, pitch, yaw rad; lat, lon deg; height m;
            ve, vn, vu m/s, optional / all-NaN).
        frame: the range frame.
        t_query: (N,) times, s (a scalar gives N = 1).
        lever_arm: (3,) sensor offset from the INS reference point, body FRD, m.
        max_gap: INS intervals longer than this (s) are not interpolated across.

    Returns:
        SensorGeometry with N rows.

    Raises:
        DataError: a required INS column is missing, times decrease, or fewer than 2 usable rows.
    """
    src = ins.sensor_id
    missing = [c for c in _INS_REQUIRED if c not in ins.columns]
    if missing:
        raise DataError(f"{src}: column {missing[0]}: required INS column missing")
    lever = np.asarray(lever_arm, np.float64)
    if lever.shape != (3,) or not np.isfinite(lever).all():
        raise ValueError(f"{src}: lever_arm must be 3 finite numbers (body FRD, m), got {lever}")
    if not float(max_gap) > 0.0:
        raise ValueError(f"max_gap must be > 0 s, got {max_gap}")
    n_rows = len(ins)
    nan = np.full(n_rows, np.nan)
    vel_local = np.stack(
        [np.asarray(ins.columns.get(c, nan), np.float64) for c in ("ve", "vn", "vu")], axis=-1
    )
    t, (roll, pitch, yaw, lat, lon, hgt), keep = clean_series(
        ins.time, *(ins.columns[c] for c in _INS_REQUIRED), source=src, row=ins.row
    )
    if t.shape[0] < 2:
        raise DataError(
            f"{src}: fewer than 2 rows with finite time, roll, pitch, yaw, lat, lon, height"
        )
    vel_local = vel_local[keep]

    pos = frame.to_enu(lat, lon, hgt)  # (K, 3) INS point, range ENU
    local_to_range = np.swapaxes(frame.local_rotation(lat, lon), -1, -2)  # (K, 3, 3) L^T
    m_rot = (local_to_range @ NED_TO_ENU) @ euler_matrices(roll, pitch, yaw)   # (K, 3, 3)
    turn = relative_rotvecs(m_rot)                 # (K-1, 3) rotvec(M_k^T M_k+1), body axes

    h = np.diff(t)
    v_fd = rates_at_samples(t, np.diff(pos, axis=0) / h[:, None], max_gap)
    v_ins = np.einsum("kij,kj->ki", local_to_range, vel_local)
    v_samp = np.where(np.isfinite(vel_local).all(axis=1)[:, None], v_ins, v_fd)
    # on interval k the slerp is R_k exp(s [d_k]x), s = (t - t_k) / h_k: dR/dt = R [w_k]x
    # with the body rate w_k = d_k / h_k; at the samples, the gap-aware central difference
    w_samp = rates_at_samples(t, turn / h[:, None], max_gap)

    loc = locate(t, t_query, max_gap)
    m_q = slerp_matrices(m_rot, turn, loc.k, loc.frac)   # (N, 3, 3) body FRD -> range ENU
    w_q = _lerp(w_samp, loc.k, loc.frac)
    position = _lerp(pos, loc.k, loc.frac) + m_q @ lever
    velocity = _lerp(v_samp, loc.k, loc.frac) + np.einsum(
        "nij,nj->ni", m_q, np.cross(w_q, lever)  # d/dt (M l) = M (w x l)
    )
    n_bad = int((~loc.valid).sum())
    if n_bad:
        log.info("%s: %d of %d query times outside the INS span or in gaps > %.3g s",
                 src, n_bad, loc.valid.size, max_gap)
    return SensorGeometry(position=position, velocity=velocity, body_to_range=m_q,
                          valid=loc.valid)


def deck_unit_vector(az: ArrayLike, el: ArrayLike) -> np.ndarray:
    """Angles (rad) -> (..., 3) unit vector ``[cos el cos az, cos el sin az, -sin el]``.

    In the body FRD frame for deck angles; the same formula gives NED from stabilised angles.
    """
    a, e = np.broadcast_arrays(np.asarray(az, np.float64), np.asarray(el, np.float64))
    ce = np.cos(e)
    return np.stack([ce * np.cos(a), ce * np.sin(a), -np.sin(e)], axis=-1)


def deck_angles(v: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`deck_unit_vector` for any nonzero (..., 3) FRD (or NED) vector.

    Returns:
        (az in [0, 2 pi) from +x toward +y, el in [-pi/2, pi/2] toward -z), rad.
    """
    v = np.asarray(v, np.float64)
    az = np.arctan2(v[..., 1], v[..., 0])
    az = np.where(az < 0.0, az + _TWO_PI, az)
    az = np.where(az >= _TWO_PI, 0.0, az)
    el = np.arctan2(-v[..., 2], np.hypot(v[..., 0], v[..., 1]))
    return az, el


def _rotate(
    az: ArrayLike, el: ArrayLike, roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike, inverse: bool
) -> tuple[np.ndarray, np.ndarray]:
    arrays = np.broadcast_arrays(*(np.asarray(x, np.float64) for x in (az, el, roll, pitch, yaw)))
    shape = arrays[0].shape
    a, e, r, p, y = (x.reshape(-1) for x in arrays)
    u = deck_unit_vector(a, e)
    u_out = body_to_ned(r, p, y).apply(u, inverse=inverse)
    az_o, el_o = deck_angles(u_out)
    return az_o.reshape(shape)[()], el_o.reshape(shape)[()]


def deck_to_stabilised(
    az_u: ArrayLike, el_u: ArrayLike, roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Deck angles -> stabilised angles (He 2015 eq. 11; range is unchanged).

    Args:
        az_u, el_u: deck azimuth (from +x toward +y) and elevation (above the deck, toward -z),
            rad.
        roll, pitch, yaw: platform attitude, rad (body-to-NED ``Rz(yaw) Ry(pitch) Rx(roll)``).
        All broadcast against each other.

    Returns:
        (az_s clockwise from north in [0, 2 pi), el_s above the local horizontal), rad.
    """
    return _rotate(az_u, el_u, roll, pitch, yaw, inverse=False)


def stabilised_to_deck(
    az_s: ArrayLike, el_s: ArrayLike, roll: ArrayLike, pitch: ArrayLike, yaw: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Stabilised angles (az from north, el above horizontal) -> deck angles; inverse of
    :func:`deck_to_stabilised`. All angles rad; az_u returned in [0, 2 pi)."""
    return _rotate(az_s, el_s, roll, pitch, yaw, inverse=True)


def deck_to_range(
    geometry: SensorGeometry, az_u: ArrayLike, el_u: ArrayLike, r: ArrayLike
) -> np.ndarray:
    """Deck measurements (rad, rad, m), each (N,), -> (N, 3) target positions in range ENU, m."""
    los = deck_unit_vector(az_u, el_u) * np.asarray(r, np.float64)[..., None]
    return geometry.position + np.einsum("nij,nj->ni", geometry.body_to_range, los)


def range_to_deck(
    geometry: SensorGeometry, target_enu: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N, 3) target positions in range ENU -> deck (az_u, el_u, r) seen by the sensor (rad, m)."""
    d = np.asarray(target_enu, np.float64) - geometry.position
    d_body = np.einsum("nji,nj->ni", geometry.body_to_range, d)  # M^T d
    az, el = deck_angles(d_body)
    return az, el, np.linalg.norm(d_body, axis=-1)
