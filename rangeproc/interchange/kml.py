"""KML for Google Earth: one time-stamped track (``gx:Track``) per object.

Each object is a folder holding its ``gx:Track`` (``when`` + ``gx:coord`` = lon, lat, height
above the WGS-84 ellipsoid, altitude mode absolute), with its 1-sigma position uncertainty
(east, north, up, m) and the bridged flag per epoch as ``gx:SimpleArrayData``, which Google
Earth shows in the track's elevation profile, and a line string of its bridged stretches
(dashed is not in KML; they are drawn thinner and grey). Colours are the report's
(``report.objects.object_color``). Written with simplekml, atomically.

Note: KML heights are nominally above mean sea level; Google Earth's absolute mode uses its
own geoid, so a track may sit tens of metres off the terrain model. The ellipsoidal height
is written as it is (no geoid model ships with rangeproc).
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import simplekml

from rangeproc.interchange.trajectories import ObjectTrajectory, iso_utc
from rangeproc.io.writers import atomic_path
from rangeproc.report.common import true_runs
from rangeproc.report.objects import object_color

#: Per-epoch values carried along each track (gx:SimpleArrayData): name -> display name.
ARRAYS = {"sigma_e": "1-sigma east (m)", "sigma_n": "1-sigma north (m)",
          "sigma_u": "1-sigma up (m)", "bridged": "bridged gap (1 = no data)"}


def kml_color(hex_rgb: str, alpha: int = 255) -> str:
    """'#rrggbb' -> KML's 'aabbggrr'."""
    r, g, b = hex_rgb[1:3], hex_rgb[3:5], hex_rgb[5:7]
    return f"{alpha:02x}{b}{g}{r}"


def write_kml(objects: Sequence[ObjectTrajectory], path: Path, title: str) -> Path:
    """Write ``objects`` as a KML document at ``path`` (atomic); returns ``path``."""
    doc = simplekml.Kml(name=title)
    schema = doc.newschema(name="rangeproc_epoch")
    for name, label in ARRAYS.items():
        schema.newgxsimplearrayfield(name=name, type=simplekml.Types.float, displayname=label)
    for k, obj in enumerate(objects):
        folder = doc.newfolder(name=obj.id)
        track = folder.newgxtrack(name=obj.id, altitudemode=simplekml.AltitudeMode.absolute)
        track.description = (f"{len(obj)} epochs, {iso_utc(obj.utc[:1])[0]} to "
                             f"{iso_utc(obj.utc[-1:])[0]}; median 1-sigma horizontal "
                             f"{float(np.median(np.hypot(*obj.sigma_enu[:, :2].T))):.2f} m")
        track.newwhen(iso_utc(obj.utc))
        track.newgxcoord(list(zip(obj.lon.tolist(), obj.lat.tolist(), obj.height.tolist())))
        data = track.extendeddata.schemadata
        data.schemaurl = schema.id
        for j, name in enumerate(("sigma_e", "sigma_n", "sigma_u")):
            data.newgxsimplearraydata(name, [f"{v:.3f}" for v in obj.sigma_enu[:, j]])
        data.newgxsimplearraydata("bridged", [str(int(b)) for b in obj.bridged])
        color = kml_color(object_color(k))
        track.style.linestyle.color = color
        track.style.linestyle.width = 2
        track.style.iconstyle.color = color
        track.style.iconstyle.icon.href = \
            "http://maps.google.com/mapfiles/kml/shapes/placemark_circle.png"
        for lo, hi in zip(*true_runs(obj.bridged)):
            line = folder.newlinestring(name=f"{obj.id} bridged",
                                        altitudemode=simplekml.AltitudeMode.absolute,
                                        coords=list(zip(obj.lon[lo:hi].tolist(),
                                                        obj.lat[lo:hi].tolist(),
                                                        obj.height[lo:hi].tolist())))
            line.style.linestyle.color = kml_color("#7f7f7f")
            line.style.linestyle.width = 1
    with atomic_path(path) as tmp:
        tmp.write_text(doc.kml(format=False), encoding="utf-8")
    return Path(path)

