"""Atmospheric refraction removed from radar and theodolite rows (``[processing] refraction``).

The ray from a sensor to the target bends down through an atmosphere whose refractivity falls
with height, so the target is seen higher than it is and a radar's range is the longer
electrical path (``frames.refraction``: 4/3-earth or exponential atmosphere). The geometry
comes from the smoothed track of the first pass (angle-only rows have no range of their own):
for each row the geometric elevation above the sensor's local horizontal and the slant range
give the elevation error ``eps`` and range error ``dR`` (measured minus true, from the
model's apparent elevation and range of that geometry); the apparent
line of sight is the geometric one turned up by ``eps`` in its vertical plane, and the row's
azimuth and elevation (in the sensor's own axes, deck axes on a platform) are corrected by
the difference of the two directions' angles, its range by ``dR``. Radar rows use the radio
surface refractivity, theodolite rows (angles and laser ranges) the optical one.

The sensor's local vertical is its site's up axis (fixed sites), or for a platform the
geocentric up of a sphere below the range origin (the ship's deviation from it, a few
hundred microradians, changes ``eps`` only to second order).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rangeproc.frames.refraction import EARTH_RADIUS, apparent
from rangeproc.fusion.batch import MeasurementBatch
from rangeproc.models.measurement import SPHERICAL


@dataclass(frozen=True, slots=True)
class RefractionSettings:
    """``model`` ("4/3" or "exponential"), per sensor index ``surface_n`` (N-units; 0 = not
    corrected) and ``moving`` (platform sensor), ``origin_height`` (m) of the range origin."""

    model: str
    surface_n: tuple[float, ...]
    moving: tuple[bool, ...]
    origin_height: float


def _angles(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Azimuth (from the second axis toward the first) and elevation of vectors d (M, 3)."""
    return np.arctan2(d[:, 0], d[:, 1]), np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]))


def refraction_corrections(batch: MeasurementBatch, xs: np.ndarray, meas_epoch: np.ndarray,
                           settings: RefractionSettings) -> MeasurementBatch:
    """The batch with refraction removed from the rows of sensors with a surface
    refractivity, at the smoothed track ``xs`` (E, n) (range ENU)."""
    surface_n = np.asarray(settings.surface_n, dtype=float)
    moving = np.asarray(settings.moving, dtype=bool)
    model, origin_height = settings.model, settings.origin_height
    ns_row = surface_n[batch.sensor] if len(surface_n) else np.zeros(len(batch))
    rows = np.flatnonzero((ns_row > 0) & (batch.model == SPHERICAL)
                          & np.isfinite(batch.z[:, :3]).any(axis=1))
    if len(rows) == 0:
        return batch
    s, Qr = batch.s[rows], batch.Qr[rows]
    d = xs[meas_epoch[rows], :3] - s
    rng = np.linalg.norm(d, axis=1)
    u = d / rng[:, None]
    up = Qr[:, 2, :].copy()                                   # the site's up axis
    mv = moving[batch.sensor[rows]]
    if mv.any():
        centre = s[mv] + np.array([0.0, 0.0, EARTH_RADIUS + origin_height])
        up[mv] = centre / np.linalg.norm(centre, axis=1)[:, None]
    sin_el = np.clip(np.einsum("ij,ij->i", u, up), -1.0, 1.0)
    el = np.arcsin(sin_el)
    # what the sensor measures of this geometry (the model's forward direction, solved for
    # the apparent elevation): the errors are the differences
    el_app, rng_app = apparent(el, rng, origin_height + s[:, 2], model, ns_row[rows],
                               iterations=3)
    eps, d_range = el_app - el, rng_app - rng
    horiz = up - sin_el[:, None] * u                          # toward the zenith, normal to u
    norm = np.linalg.norm(horiz, axis=1)
    horiz = horiz / np.where(norm > 0, norm, 1.0)[:, None]
    u_app = np.cos(eps)[:, None] * u + np.sin(eps)[:, None] * horiz
    az_t, el_t = _angles(np.einsum("nij,nj->ni", Qr, u))
    az_a, el_a = _angles(np.einsum("nij,nj->ni", Qr, u_app))
    z = batch.z.copy()
    z[rows, 0] -= d_range
    z[rows, 1] -= np.angle(np.exp(1j * (az_a - az_t)))        # wrapped difference
    z[rows, 2] -= el_a - el_t
    return MeasurementBatch(batch.t, batch.model, z, batch.sigma, batch.s, batch.sv, batch.Qr,
                            batch.sensor, batch.source_row, batch.station, batch.track,
                            batch.sensor_ids)
