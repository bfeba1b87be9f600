"""Tacview ACMI 2.2: every fused object's time-tagged position and the sensors' sites.

Specification: "Technical Reference - ACMI flight recordings 2.2" (Tacview),
https://www.tacview.net/documentation/acmi/en/ . What is written, as UTF-8 with a byte-order
mark and LF line ends (the specification's tips):

* the header ``FileType=text/acmi/tacview``, ``FileVersion=2.2``;
* global properties (object ``0``): ``ReferenceTime``, the first epoch's UTC instant floored
  to the whole second; ``ReferenceLongitude`` and ``ReferenceLatitude``, whole degrees
  nearest the median position, which every written longitude and latitude is an offset from
  (the reader adds them); ``Title``, ``DataSource``, ``DataRecorder``, and ``Comments`` saying
  what the altitudes are;
* time frames ``#<seconds after ReferenceTime>`` in ascending order, exact to the nanosecond
  (trailing zeros dropped); in each, ``<id>,T=<lon>|<lat>|<alt>`` for every object with an
  epoch at that instant, longitude and latitude to 1e-7 degree (about 1 cm), altitude to
  0.01 m (all three components always written);
* one ACMI object per fused object, ids 1..N (hexadecimal, as the specification wants) in the
  fused table's order. Its first line also sets ``Name`` (the target id), ``Type=Air+FixedWing``
  (rangeproc does not know what an object is; Tacview then draws it as an aircraft and shows
  its speed and altitude) and ``Color`` (Tacview's named colours: the report's colours for the
  first four objects, Blue, Orange, Green, Violet, then Red, Cyan, Yellow, cycling). It is
  removed (``-<id>``) in the frame of its last epoch, right after that position, so Tacview
  shows it over exactly its fused span. ``--interval`` thins the epochs as for KML and CZML;
* the sensors' sites as static objects in the first frame, ids N+1.. in the config's order:
  ``Type=Ground+Static+Sensor``, ``Name`` = the sensor id (a MISTRAM station: the station id,
  with ``Group`` = the MISTRAM sensor's id). Sensors on a platform (``platform = "..."``, moved
  by its INS) and GPS receivers (carried by a target) have no fixed site and are left out.

Altitude: ACMI's is metres above mean sea level, rangeproc's heights are above the WGS-84
ellipsoid, and no geoid model ships with rangeproc, so the ellipsoidal height is written as it
is (the file's ``Comments`` says so). Tracks and sites keep their relative geometry; Tacview's
terrain may sit off them by the local geoid height (tens of metres in places), as with KML.

Text values escape a comma as ``\\,`` (the specification) and an end of line as ``\\`` before
it. Two forms: ``fused.acmi`` (format ``acmi``: the text) and ``fused.zip.acmi`` (format
``acmi-zip``: a zip archive whose one member, ``fused.txt.acmi``, is the same text; Tacview's
naming of the zipped and text forms; the member's date is fixed, so equal runs give equal
bytes). Written atomically.
"""
from __future__ import annotations

import json
import logging
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

import rangeproc
from rangeproc.interchange.trajectories import ObjectTrajectory
from rangeproc.io.writers import atomic_path

if TYPE_CHECKING:
    from rangeproc.config import Config

log = logging.getLogger(__name__)

#: Tacview's type (tags) of a fused object and of a sensor's site.
OBJECT_TYPE = "Air+FixedWing"
SITE_TYPE = "Ground+Static+Sensor"
#: Tacview's named colours, the k-th fused object's is ``COLORS[k % 7]``.
COLORS = ("Blue", "Orange", "Green", "Violet", "Red", "Cyan", "Yellow")
#: The member of ``fused.zip.acmi`` and its (fixed) date.
ZIP_MEMBER = "fused.txt.acmi"
ZIP_DATE = (1980, 1, 1, 0, 0, 0)
NS = 1_000_000_000


@dataclass(frozen=True, slots=True)
class Site:
    """A sensor's fixed site: WGS-84 ``lat``, ``lon`` (deg), ``height`` (m above the
    ellipsoid); ``group``: the sensor a station belongs to (MISTRAM), else None."""

    id: str
    lat: float
    lon: float
    height: float
    group: str | None = None


def config_sites(cfg: Config) -> list[Site]:
    """The fixed sites of a run's sensors, in the config's order: each sensor's ``site``, then
    its stations (MISTRAM); platform sensors and GPS receivers have none."""
    sites = []
    for s in cfg.sensors:
        if s.site is not None:
            sites.append(Site(s.id, s.site.lat, s.site.lon, s.site.height))
        sites.extend(Site(st.id, st.site.lat, st.site.lon, st.site.height, s.id)
                     for st in s.stations)
    return sites


def run_sites(out_dir: Path) -> list[Site]:
    """The sites of the run in ``out_dir``: from the config its ``summary.json`` names. One
    warning line and no sites when there is no summary or the config cannot be read; a
    warning, and its sites as they are now, when the config changed since the run."""
    from rangeproc.config import load_config      # config imports this package
    from rangeproc.errors import ConfigError
    from rangeproc.io.writers import file_sha256

    summary = Path(out_dir) / "summary.json"
    try:
        entry = json.loads(summary.read_text(encoding="utf-8"))["config"]
        path, sha = Path(entry["file"]), entry.get("sha256")
    except (OSError, ValueError, KeyError, TypeError) as exc:
        why = "not found" if isinstance(exc, FileNotFoundError) else "names no config"
        log.warning("export: fused.acmi has no sensor sites: %s %s (the run's config holds "
                    "them)", summary, why)
        return []
    try:
        cfg = load_config(path)
        changed = sha is not None and file_sha256(path) != sha
    except (ConfigError, OSError) as exc:
        log.warning("export: fused.acmi has no sensor sites: the run's config: %s", exc)
        return []
    if changed:
        log.warning("export: %s changed since the run; fused.acmi shows its sensor sites as "
                    "they are now", path)
    return config_sites(cfg)


def acmi_text(objects: Sequence[ObjectTrajectory], sites: Sequence[Site], title: str) -> str:
    """The ACMI 2.2 text of ``objects`` and ``sites`` (module docstring), lines ending in LF."""
    lon_all = np.concatenate([*(o.lon for o in objects), [s.lon for s in sites]])
    lat_all = np.concatenate([*(o.lat for o in objects), [s.lat for s in sites]])
    ref_lon = int(np.round(np.median(lon_all))) if lon_all.size else 0
    ref_lat = int(np.round(np.median(lat_all))) if lat_all.size else 0
    ns = [o.utc.astype("datetime64[ns]").astype(np.int64) for o in objects if len(o)]
    ref_ns = (min(int(t.min()) for t in ns) // NS) * NS if ns else 0
    lines = ["FileType=text/acmi/tacview", "FileVersion=2.2"]
    if ns:
        stamp = np.datetime_as_string(np.datetime64(ref_ns, "ns"), unit="s")
        lines.append(f"0,ReferenceTime={stamp}Z")
    lines += [f"0,ReferenceLongitude={ref_lon}", f"0,ReferenceLatitude={ref_lat}",
              f"0,Title={_text(title)}", "0,DataSource=rangeproc fused.parquet",
              f"0,DataRecorder=rangeproc {rangeproc.__version__}",
              "0,Comments=" + _text("Objects are rangeproc's fused objects, static objects "
                                    "the sensors' sites; altitudes are heights above the "
                                    "WGS-84 ellipsoid, not above mean sea level (no geoid "
                                    "model applied)")]

    def position(lon: float, lat: float, alt: float) -> str:
        return f"T={lon - ref_lon:.7f}|{lat - ref_lat:.7f}|{alt:.2f}"

    site_lines = [f"{len(objects) + j + 1:x},{position(s.lon, s.lat, s.height)},"
                  f"Type={SITE_TYPE},Name={_text(s.id)}"
                  + (f",Group={_text(s.group)}" if s.group is not None else "")
                  for j, s in enumerate(sites)]
    kept = [k for k, o in enumerate(objects) if len(o)]
    if not kept:
        if site_lines:
            lines += ["#0", *site_lines]
        return "\n".join(lines) + "\n"
    time = np.concatenate([objects[k].utc.astype("datetime64[ns]").astype(np.int64) - ref_ns
                           for k in kept])
    owner = np.concatenate([np.full(len(objects[k]), k) for k in kept])
    index = np.concatenate([np.arange(len(objects[k])) for k in kept])
    body = [position(lo, la, al) for k in kept for lo, la, al in
            zip(objects[k].lon.tolist(), objects[k].lat.tolist(), objects[k].height.tolist())]
    start = np.cumsum([0] + [len(objects[k]) for k in kept])[:-1]
    row_of = dict(zip(kept, start.tolist()))
    order = np.lexsort((owner, time))
    previous = None
    for t, k, i in zip(time[order].tolist(), owner[order].tolist(), index[order].tolist()):
        if t != previous:
            lines.append(f"#{_seconds(t)}")
            if previous is None:
                lines.extend(site_lines)
            previous = t
        obj, ident = objects[k], f"{k + 1:x}"
        line = f"{ident},{body[row_of[k] + i]}"
        if i == 0:
            line += f",Type={OBJECT_TYPE},Name={_text(obj.id)},Color={COLORS[k % len(COLORS)]}"
        lines.append(line)
        if i == len(obj) - 1:
            lines.append(f"-{ident}")
    return "\n".join(lines) + "\n"


def write_acmi(text: str, path: Path, zipped: bool = False) -> Path:
    """Write the ACMI ``text`` at ``path`` (atomic), as UTF-8 with a byte-order mark, or as
    the one member of a zip archive when ``zipped``; returns ``path``."""
    data = text.encode("utf-8-sig")
    with atomic_path(path) as tmp:
        if zipped:
            with zipfile.ZipFile(tmp, "w") as archive:
                archive.writestr(zipfile.ZipInfo(ZIP_MEMBER, date_time=ZIP_DATE), data,
                                 compress_type=zipfile.ZIP_DEFLATED)
        else:
            tmp.write_bytes(data)
    return Path(path)


def _seconds(ns: int) -> str:
    """Nanoseconds ``ns`` as decimal seconds, exact, without trailing zeros ('12.3', '0')."""
    whole, frac = divmod(ns, NS)
    return f"{whole}.{frac:09d}".rstrip("0").rstrip(".")


def _text(value: str) -> str:
    """A text property's value with commas and ends of line escaped (backslash before)."""
    return str(value).replace("\r", "").replace("\n", "\\\n").replace(",", "\\,")
