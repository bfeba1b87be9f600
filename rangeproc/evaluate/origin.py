"""The range origin for ``rangeproc evaluate``: from ``--origin`` or from the run's config.

A geodetic truth (``lat, lon, height``) is compared with the fused output in the run's range ENU
frame, the local tangent plane at the config's ``[range] origin`` (WGS-84: latitude and
longitude in degrees, height in metres above the ellipsoid). The run records its config's path
and SHA-256 in ``OUT_DIR/summary.json`` ("config": {"file", "sha256"}); ``--origin`` overrides it
(and is the only source once the config was moved or deleted).
"""
from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass
from pathlib import Path

from rangeproc.config import HEIGHT_BOUNDS, Geodetic, load_config
from rangeproc.errors import ConfigError
from rangeproc.io.writers import file_sha256

log = logging.getLogger(__name__)

ORIGIN_FORM = "LAT,LON,HEIGHT (WGS-84 degrees, degrees, metres above the ellipsoid)"


@dataclass(frozen=True, kw_only=True, slots=True)
class Origin:
    """A range origin and where it came from (``source``: "--origin" or the config's path).

    ``missing``: why there is none (``origin`` None), e.g. the config recorded by the run is
    no longer there."""

    origin: Geodetic | None
    source: str
    missing: str = ""


def parse_origin(text: str, what: str = "--origin") -> Geodetic:
    """``"LAT,LON,HEIGHT"`` (deg, deg, m) -> Geodetic; ConfigError naming ``what`` if unusable."""
    parts = [p.strip() for p in text.split(",")]
    try:
        lat, lon, height = (float(p) for p in parts)
    except ValueError:
        raise ConfigError(f"{what}: expected {ORIGIN_FORM}, got {text!r}") from None
    if not all(math.isfinite(x) for x in (lat, lon, height)):
        raise ConfigError(f"{what}: {text!r} is not three finite numbers")
    if not -90.0 <= lat <= 90.0:
        raise ConfigError(f"{what}: latitude {lat:g} outside [-90, 90] degrees")
    if not -180.0 <= lon < 360.0:
        raise ConfigError(f"{what}: longitude {lon:g} outside [-180, 360) degrees")
    if not HEIGHT_BOUNDS[0] <= height <= HEIGHT_BOUNDS[1]:
        raise ConfigError(f"{what}: height {height:g} m outside [{HEIGHT_BOUNDS[0]:g}, "
                          f"{HEIGHT_BOUNDS[1]:g}] m")
    return Geodetic(lat=lat, lon=lon, height=height)


def run_origin(out_dir: Path, given: Geodetic | None = None) -> Origin:
    """The origin of the run in ``out_dir``: ``given`` (``--origin``) if not None, else the
    ``[range] origin`` of the config named in ``out_dir/summary.json``.

    Logs a warning when that config changed since the run (its SHA-256 differs). Returns an
    :class:`Origin` with ``origin`` None and the reason in ``missing`` when there is neither.
    Raises ConfigError when the recorded config exists but is not a valid config.
    """
    if given is not None:
        return Origin(origin=given, source="--origin")
    summary = Path(out_dir) / "summary.json"
    try:
        record = json.loads(summary.read_text()).get("config") or {}
    except FileNotFoundError:
        return Origin(origin=None, source="", missing=f"{summary} not found")
    except (OSError, ValueError, AttributeError) as exc:
        return Origin(origin=None, source="", missing=f"{summary} unreadable ({exc})")
    file = record.get("file") if isinstance(record, dict) else None
    if not file:
        return Origin(origin=None, source="", missing=f"{summary} names no config")
    path = Path(file)
    if not path.is_file():
        return Origin(origin=None, source="",
                      missing=f"the run's config {path} (from {summary.name}) is not there")
    if record.get("sha256") and file_sha256(path) != record["sha256"]:
        log.warning("%s changed since the run (SHA-256 differs from %s); its [range] origin is "
                    "used", path, summary.name)
    return Origin(origin=load_config(path).origin, source=str(path))
