"""CZML for Cesium: time-tagged positions per object, with their uncertainty.

A document packet sets the clock over the run's span. Each object is a packet with its
``availability``, a ``position`` of ``cartographicDegrees`` (seconds after the packet's
``epoch``, lon, lat, height above the WGS-84 ellipsoid) interpolated linearly, a trailing
``path`` and a ``point`` in the report's colour, and an ``ellipsoid`` whose time-tagged
``radii`` are the 3-sigma position uncertainty east, north and up (m): Cesium orients an
entity's ellipsoid in the east-north-up frame at its position, so the ellipsoid is the
3-sigma box's inscribed ellipsoid of the trajectory's own covariance diagonal. Written with
czml3, atomically.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from czml3 import Clock, Color, Document, Ellipsoid, Packet, Path as CzmlPath, Point, Position
from czml3 import PolylineMaterial, SolidColorMaterial, TimeInterval
from czml3.properties import EllipsoidRadii, Material

from rangeproc.interchange.trajectories import ObjectTrajectory, iso_utc
from rangeproc.io.writers import atomic_path
from rangeproc.report.objects import object_color

#: Multiple of the 1-sigma uncertainty drawn as the ellipsoid's radii.
SIGMA_SCALE = 3.0
#: The ellipsoid's radii never drawn below this (m): Cesium does not draw a zero radius.
MIN_RADIUS_M = 0.01


def _rgba(hex_rgb: str, alpha: int = 255) -> list[int]:
    return [int(hex_rgb[i:i + 2], 16) for i in (1, 3, 5)] + [alpha]


def _interleaved(dt: np.ndarray, *columns: np.ndarray) -> list[float]:
    """[dt0, c0[0], c1[0], ..., dt1, ...] for CZML's sampled properties."""
    return np.column_stack([dt, *columns]).ravel().tolist()


def object_packet(obj: ObjectTrajectory, k: int) -> Packet:
    """One object's CZML packet (its index ``k`` picks the colour)."""
    start, end = iso_utc(obj.utc[[0, -1]])
    dt = (obj.utc - obj.utc[0]) / np.timedelta64(1, "s")
    color = _rgba(object_color(k))
    radii = np.maximum(SIGMA_SCALE * obj.sigma_enu, MIN_RADIUS_M)
    return Packet(
        id=obj.id, name=obj.id,
        description=f"rangeproc object {obj.id}: {len(obj)} epochs; ellipsoid = "
                    f"{SIGMA_SCALE:g}-sigma position uncertainty (east, north, up)",
        availability=TimeInterval(start=start, end=end),
        position=Position(epoch=start, interpolationAlgorithm="LINEAR",
                          cartographicDegrees=_interleaved(dt, obj.lon, obj.lat, obj.height)),
        path=CzmlPath(width=2, leadTime=0, trailTime=float(dt[-1]) + 1.0,
                      material=PolylineMaterial(solidColor=SolidColorMaterial(
                          color=Color(rgba=color)))),
        point=Point(pixelSize=7, color=Color(rgba=color)),
        ellipsoid=Ellipsoid(radii=EllipsoidRadii(epoch=start, cartesian=_interleaved(
            dt, radii[:, 0], radii[:, 1], radii[:, 2])),
            material=Material(solidColor=SolidColorMaterial(color=Color(rgba=_rgba(
                object_color(k), 70))))))


def write_czml(objects: Sequence[ObjectTrajectory], path: Path, title: str) -> Path:
    """Write ``objects`` as a CZML document at ``path`` (atomic); returns ``path``."""
    first = min(o.utc[0] for o in objects) if objects else np.datetime64("1970-01-01", "ns")
    last = max(o.utc[-1] for o in objects) if objects else first
    start, end = iso_utc(np.array([first, last]))
    header = Packet(id="document", name=title, version="1.0",
                    clock=Clock(interval=TimeInterval(start=start, end=end), currentTime=start,
                                multiplier=1.0, range="LOOP_STOP", step="SYSTEM_CLOCK_MULTIPLIER"))
    doc = Document(packets=[header, *(object_packet(o, k) for k, o in enumerate(objects))])
    with atomic_path(path) as tmp:
        tmp.write_text(doc.dumps(), encoding="utf-8")
    return Path(path)
