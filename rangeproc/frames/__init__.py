"""Reference frames: WGS-84 geodesy and the range ENU frame, platform attitude, and
moving-platform sensor geometry / stabilisation. Conventions: DATA_CONTRACT section 1 and the
module docstrings (angles in radians except geodetic lat/lon in degrees)."""
from rangeproc.frames.attitude import NED_TO_ENU, body_to_ned, interpolate_attitude
from rangeproc.frames.geodesy import (
    WGS84,
    RangeFrame,
    aer_to_enu,
    ecef_to_enu_matrix,
    ecef_to_geodetic,
    enu_to_aer,
    geodetic_to_ecef,
)
from rangeproc.frames.platform import (
    SensorGeometry,
    deck_angles,
    deck_to_range,
    deck_to_stabilised,
    deck_unit_vector,
    platform_geometry,
    range_to_deck,
    stabilised_to_deck,
)

__all__ = [
    "NED_TO_ENU",
    "WGS84",
    "RangeFrame",
    "SensorGeometry",
    "aer_to_enu",
    "body_to_ned",
    "deck_angles",
    "deck_to_range",
    "deck_to_stabilised",
    "deck_unit_vector",
    "ecef_to_enu_matrix",
    "ecef_to_geodetic",
    "enu_to_aer",
    "geodetic_to_ecef",
    "interpolate_attitude",
    "platform_geometry",
    "range_to_deck",
    "stabilised_to_deck",
]
