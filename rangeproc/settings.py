"""Settings of a run: the validated config as frozen dataclasses, and the unit tables.

Plain data, no logic beyond defaults: ``rangeproc.config`` is the one module that reads TOML
and builds these (and re-exports them, so ``from rangeproc.config import SensorSettings``
works as before). SI units throughout (metres, seconds, radians), except geodetic degrees.

Each settings field is the one declaration of its config key (``rangeproc.keys.key``): its
default, meaning, unit, allowed values or bounds. To add a key, add a field here; the loader
accepts and checks it, and ``docs/config.md`` lists it (``rangeproc.config_reference``).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from rangeproc.families import FILTERS
from rangeproc.keys import derived, key

SENSOR_KINDS = ("radar", "theodolite", "gps", "mistram", "ins")
ANGLE_UNITS = ("deg", "rad", "mil")
#: Motion models of the IMM, in the order of ``estimation.imm``'s model codes.
IMM_MODELS = ("cv", "ca", "ct")
#: Default strong-tracking weakening factor beta (Ye and Cui leave it to experience). With
#: rho = 0.95 the innovation-covariance estimate V is an exponential average putting about
#: half its weight on the newest innovation, so for white innovations of one component V has
#: a standard deviation of about 0.83 around 1: beta = 3 (some 2.4 of those above the mean)
#: keeps noise alone from fading a consistent filter, and a real model error still does.
STUKF_WEAKENING = 3.0
#: Optical surface refractivity (N-units) at 1013.25 hPa, 15 C, 0.55 um (Barrell & Sears,
#: ``frames.refraction.optical_refractivity``).
OPTICAL_REFRACTIVITY = 277.9
REFRACTION_MODELS = ("none", "4/3", "exponential")
#: Calibration terms (``summary.json`` ``calibration.<name>``, data contract section 4), SI.
CALIBRATION_NAMES = ("range", "azimuth", "elevation", "latency", "mount_roll", "mount_pitch",
                     "mount_yaw")
#: Which terms each sensor kind has (mount terms only on a platform; GPS is the reference).
CALIBRATION_BY_KIND: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "radar": CALIBRATION_NAMES, "theodolite": CALIBRATION_NAMES, "mistram": ("latency",),
    "gps": ("latency",), "ins": ()})


def calibration_terms(kind: str, on_platform: bool) -> tuple[str, ...]:
    """The calibration terms of a sensor of this kind (mount terms only on a platform)."""
    return tuple(n for n in CALIBRATION_BY_KIND[kind]
                 if on_platform or not n.startswith("mount_"))


# --------------------------------------------------------------------------------------------
# Plausibility bounds of config numbers (``rangeproc.config`` re-exports them): a finite value
# outside them is a typo or a unit mistake, and would overflow or exhaust the processing
# (e.g. rate_hz = 1e9 asks for a billion output epochs per second).
# --------------------------------------------------------------------------------------------
#: heights of the origin, sites and stations (m): deepest trench to beyond the Moon's distance
HEIGHT_BOUNDS = (-12_000.0, 1.0e9)
#: |time| (s) of any time stamp, time_offset or initial time: about 317 years, float64 still
#: resolves 2e-6 s there (also the screening's bound on the stamps, ``editing.timecheck``)
MAX_ABS_TIME = 1.0e10
#: |speed| (m/s) of anything: the speed of light (initial velocities, processing.max_speed)
MAX_SPEED = 3.0e8
#: output.rate_hz (Hz): one epoch per 1000 s to 1000 per second
RATE_HZ_BOUNDS = (1e-3, 1000.0)
#: processing.noise_passes
MAX_NOISE_PASSES = 20
#: processing.process_noise (m^2/s^5)
PROCESS_NOISE_BOUNDS = (1e-12, 1e12)
#: processing.gate_probability
GATE_PROBABILITY_BOUNDS = (0.5, 1.0)
#: a-priori sigmas in SI (m, m/s, rad); angles at most one turn
SIGMA_BOUNDS = (1e-12, 1e9)
MAX_SIGMA_ANGLE = 2.0 * math.pi
#: |lever_arm| components (m)
MAX_LEVER_ARM = 1.0e4
#: |known calibration corrections|: range bias (m), angles (rad; a quarter turn)
MAX_CALIBRATION_RANGE = 1.0e5
MAX_CALIBRATION_ANGLE = 0.5 * math.pi
#: Bounds of each strong-tracking prior ratio alpha (Ye and Cui: alpha >= 1).
STUKF_RATIO_BOUNDS = (1.0, 1e3)
#: processing.spline_knot_spacing (s): regular knots of the batch spline fit
SPLINE_SPACING_BOUNDS = (1e-3, 1e5)
#: processing.spline_anomaly_probability: 1 - alpha of Zhou et al.'s chi-square anomaly test
SPLINE_PROBABILITY_BOUNDS = (0.5, 1.0)


# --------------------------------------------------------------------------------------------
# The settings. Each field is the one declaration of its config key (``rangeproc.keys.key``):
# default, meaning, unit, allowed values or bounds. The loader's key lists, checks and
# messages, the estimator's settings and docs/config.md are computed from these fields.
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True, kw_only=True, slots=True)
class Geodetic:
    """A WGS-84 point: ``lat``, ``lon`` in degrees (east positive), ``height`` in metres."""

    lat: float = key(doc="Latitude, north positive.", unit="deg", bounds=(-90.0, 90.0))
    lon: float = key(doc="Longitude, east positive (0 to 360 is accepted too).", unit="deg",
                     bounds=(-180.0, 360.0), half_open=True)
    height: float = key(doc="Height above the WGS-84 ellipsoid.", unit="m",
                        bounds=HEIGHT_BOUNDS)


@dataclass(frozen=True, kw_only=True, slots=True)
class OutputSettings:
    """``[output]``: where and how the fused products are written."""

    dir: Path = key(Path("out"), doc="Output folder, relative to the config file's folder "
                    "(the loader makes it absolute).")
    rate_hz: float = key(10.0, doc="Sample rate of the fused trajectory.", unit="Hz",
                         positive=True, bounds=RATE_HZ_BOUNDS)
    export: tuple[str, ...] = key(
        (), doc="Interchange formats written with every run (``rangeproc.interchange``); "
        "case is ignored, a repeat counts once.", allowed_from="rangeproc.interchange:FORMATS",
        parse="export")
    epoch: str | None = key(
        None, doc="The UTC instant (ISO 8601 with an offset or Z) of time 0 on the range's "
        "time scale, for the report's and the exports' calendar times; not set: the calendar "
        "is known only for Unix-scale times (``rangeproc.timescale``).", parse="epoch")


@dataclass(frozen=True, kw_only=True, slots=True)
class InitialState:
    """A target's known state (``[[targets]] initial``), for data that cannot start a track
    by itself (e.g. MISTRAM range rates alone)."""

    time: float = key(doc="Time of the state on the range time scale.", unit="s",
                      bounds=(-MAX_ABS_TIME, MAX_ABS_TIME))
    position: Geodetic = key(doc="The state's WGS-84 position.", flatten=True)
    velocity: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0), doc="Velocity in the range ENU frame (east, north, up).",
        unit="m/s", parts=("ve", "vn", "vu"), flatten=True, bounds=(-MAX_SPEED, MAX_SPEED))
    sigma_position: float = key(100.0, doc="1-sigma of the position, per axis.", unit="m",
                                positive=True, bounds=SIGMA_BOUNDS)
    sigma_velocity: float = key(50.0, doc="1-sigma of the velocity, per axis.", unit="m/s",
                                positive=True, bounds=SIGMA_BOUNDS)


@dataclass(frozen=True, kw_only=True, slots=True)
class TargetSettings:
    """``[[targets]]`` entry: ``id``, the optional ``initial`` state and the optional
    ``lever_arm`` of the point to report."""

    id: str = key(doc="The target's name (gps and mistram sensors name it in ``target``).")
    initial: InitialState | None = key(
        None, doc="A known state of the target (table below), used where its data cannot "
        "start a track.", parse="initial")
    lever_arm: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0), doc="For a target measured by plots of radars or lidars alone: the "
        "point to report (a GNSS antenna) in the object's body frame (forward, right, down) "
        "from the centre of its returns, applied with the smoothed heading; not applied, "
        "with one warning line, where the target has gps or tracked rows (their point is the "
        "one reported) or never moves faster than 1 m/s (no heading).", unit="m",
        parts=("x", "y", "z"),
        bounds=(-MAX_LEVER_ARM, MAX_LEVER_ARM), parse="lever_arm")


@dataclass(frozen=True, kw_only=True, slots=True)
class StationSettings:
    """A MISTRAM ground station (fixed)."""

    id: str = key(doc="The station's name (the data's ``station`` column).")
    site: Geodetic = key(doc="The station's WGS-84 position.", flatten=True)


@dataclass(frozen=True, kw_only=True, slots=True)
class SensorSettings:
    """``[[sensors]]`` entry, validated and in SI units.

    ``sigma`` maps component name -> a-priori 1-sigma in SI (m, rad, m/s); components the user
    did not state carry rangeproc's defaults (see ``DEFAULT_SIGMAS``). ``file`` is absolute.
    ``lever_arm`` is body FRD in metres (platform sensors only; zeros otherwise).
    ``calibrate``: the calibration terms rangeproc may estimate (``CALIBRATION_NAMES``; by
    default all its kind has); ``calibration``: known corrections, SI (m, rad), with the
    contract's signs (a bias is measured minus true), removed from the rows before anything
    else (a known latency is ``time_offset``).
    """

    id: str = key(doc="The sensor's unique name.")
    kind: str = key(doc="What the sensor measures (data contract section 2).",
                    allowed=SENSOR_KINDS, what="sensor kind")
    file: Path = key(doc="The sensor's data file (CSV or Parquet), relative to the config "
                     "file's folder; not opened by the loader.")
    site: Geodetic | None = key(
        None, doc="Fixed WGS-84 position of a radar or theodolite (exactly one of site or "
        "platform; not allowed for other kinds).", parse="geodetic")
    platform: str | None = key(
        None, doc="id of the ins sensor carrying a radar or theodolite (exactly one of site or "
        "platform; not allowed for other kinds).")
    lever_arm: tuple[float, float, float] = key(
        (0.0, 0.0, 0.0), doc="The sensor's position in the platform's body frame (forward, "
        "right, down); only together with platform.", unit="m", parts=("x", "y", "z"),
        bounds=(-MAX_LEVER_ARM, MAX_LEVER_ARM), parse="lever_arm")
    angle_unit: str = key("deg", doc="Unit of the angles in the data file and of the angle "
                          "entries of sigma and calibration.", allowed=ANGLE_UNITS,
                          what="angle unit")
    time_offset: float = key(
        0.0, doc="Added to the file's time stamps to put them on the range time scale (a "
        "known latency); a date or instant (ISO 8601 with an offset or Z, or a TOML date) "
        "means its seconds since 1970-01-01T00:00:00Z.", unit="s",
        bounds=(-MAX_ABS_TIME, MAX_ABS_TIME), parse="instant", toml="number or date-time")
    sigma: Mapping[str, float] = key(
        factory=lambda: MappingProxyType({}), doc="A-priori 1-sigma per measured component "
        "(m, m/s; angles in angle_unit); components not stated keep the kind's defaults "
        "(table below).", parse="sigma", default_doc="the kind's defaults")
    target: str | None = key(
        None, doc="The target carrying a gps or mistram sensor (only those kinds); may be "
        "omitted when there is one target.", default_doc="the only target")
    stations: tuple[StationSettings, ...] = key(
        (), doc="The ground stations of a mistram sensor (required for mistram, not allowed "
        "for other kinds).", parse="stations")
    allow_disjoint_time: bool = key(
        False, doc="Accept a sensor whose rows all lie farther than processing.time_margin "
        "from every other sensor's (otherwise refused: wrong time scale or time_offset).")
    calibrate: tuple[str, ...] = key(
        CALIBRATION_NAMES, doc="The calibration terms rangeproc may estimate for this sensor "
        "(true: all its kind has, table below; false: none).", allowed=CALIBRATION_NAMES,
        parse="calibrate", toml="boolean or array of strings",
        default_doc="true (every term of the kind)")
    calibration: Mapping[str, float] = key(
        factory=lambda: MappingProxyType({}), doc="Known corrections removed from the rows "
        "before anything else: range bias (m) and angle biases (angle_unit) of the kind's "
        "terms other than latency, measured minus true (a known latency is time_offset).",
        parse="known_calibration", default_doc="none")
    rate_hz: float | None = key(
        None, doc="The sensor's sample rate as rangeproc plan assumes it (MISTRAM: per "
        "station); a run takes the rates from the file.", unit="Hz", positive=True,
        bounds=(1e-3, 1e4), default_doc="the file's rate, else the kind's (radar and "
        "theodolite 20, gps and mistram 10)")


@dataclass(frozen=True, kw_only=True, slots=True)
class ProcessingSettings:
    """Optional ``[processing]`` section (rangeproc's own; every field has a working default).

    Each field's declaration (its ``key(...)``) gives its meaning, unit and bounds; the
    estimator (``fusion.estimator_types.EstimatorSettings``) reads these fields by name.
    """

    gate_probability: float = key(
        0.9999, doc="Chi-square gate probability of innovation gating (per measurement row).",
        bounds=GATE_PROBABILITY_BOUNDS, half_open=True)
    noise_passes: int = key(
        2, doc="Refinement passes after the first (re-linearisation at the smoothed track, "
        "noise and process-noise re-estimation).", bounds=(0, MAX_NOISE_PASSES))
    adapt_noise: bool = key(
        True, doc="Estimate per-sensor noise (and local bursts) from the data.")
    process_noise: float | None = key(
        None, doc="White-jerk PSD q of the constant-acceleration model; not set: estimated "
        "from the data (maximum likelihood, then local EM).", unit="m^2/s^5", positive=True,
        bounds=PROCESS_NOISE_BOUNDS)
    filter: str = key(
        "auto", doc='The forward filter: "auto" ("ekf"; for an object measured by range '
        'rates alone the EKF\'s passes, then the batch spline fit of the whole flight, which '
        'comes nearer the bound there; the summary says which ran), '
        '"ekf" (linearised, Joseph form), "ukf" (unscented), '
        '"stukf" (strong-tracking UKF with multiple suboptimal fading factors, Ye and Cui), '
        '"sage-husa" (the EKF with improved Sage-Husa adaptive measurement noise, Song et '
        'al. 2011), "askf" (augmented-state filter with the maneuver-norm constraint of '
        'patent CN109581356A), "imm" (interacting multiple models with Kim\'s smoother) or '
        '"spline" (Zhou et al.\'s self-adaptive spline filter, then the batch cubic B-spline '
        "fit).",
        allowed=FILTERS, what="filter")
    max_gap: float = key(
        60.0, doc="A target unobserved for longer than this is split into separate spans "
        "with no output epochs in between; also the distance that makes a sensor's time "
        "stamps isolated.", unit="s", bounds=(1e-3, 1e7))
    time_margin: float = key(
        60.0, doc="A sensor whose rows all lie farther than this from every other sensor's "
        "rows is refused (wrong time scale or time_offset), unless allow_disjoint_time.",
        unit="s", bounds=(0.0, 1e10))
    keep_isolated: bool = key(
        False, doc="Keep in fused.parquet the objects of a sensor whose rows sit far from "
        "every other sensor's view of the objects in the air at the same times (a wrong "
        "site or unit, warned); otherwise they are left out and their rows recorded in "
        "edits.parquet with reason isolated.")
    max_speed: float = key(
        2.0e4, doc="Physical speed limit of targets and platforms (range rates, velocities, "
        "jumps between consecutive fixes).", unit="m/s", bounds=(1.0, MAX_SPEED))
    max_range: float = key(
        5.0e7, doc="Physical range limit of radars and laser rangers; also the highest "
        "height.", unit="m", bounds=(1.0, 1.0e12))
    sage_husa_window: int = key(
        100, doc='Rows per sensor component in the Sage-Husa window (filter = "sage-husa"; '
        "Song et al. 2011: 100).", unit="rows", bounds=(2, 100_000))
    sage_husa_mean: bool = key(
        False, doc="Sage-Husa also estimates and removes the measurement-noise mean.")
    maneuver_norm: float | None = key(
        None, doc='The constant maneuver acceleration norm of filter = "askf" (patent '
        "CN109581356A); not set: estimated.", unit="m/s^2", positive=True, bounds=(1e-6, 1e5))
    stukf_forgetting: float = key(
        0.95, doc="Strong-tracking forgetting factor rho of the innovation covariance "
        "(Ye and Cui: 0.95; ``estimation.fading``).", bounds=(1e-3, 1.0))
    stukf_weakening: float = key(
        STUKF_WEAKENING, doc="Strong-tracking weakening factor beta >= 1: noise alone must "
        "not fade a consistent filter (``settings.STUKF_WEAKENING``).", bounds=(1.0, 1e3))
    stukf_ratios: tuple[float, float, float] = key(
        (1.0, 1.0, 1.0), doc="Strong-tracking prior ratios alpha >= 1 of position, velocity "
        "and acceleration.", parts=("position", "velocity", "acceleration"),
        bounds=STUKF_RATIO_BOUNDS)
    imm_models: tuple[str, ...] = key(
        ("cv", "ca", "ct"), doc='The IMM\'s motion models (filter = "imm"; '
        "``estimation.imm``), each at most once.", allowed=IMM_MODELS, what="model",
        parse="imm_models", toml="array of strings")
    imm_sojourn: float = key(
        10.0, doc="Mean time the IMM spends in a model before switching, to each other model "
        "alike.", unit="s", bounds=(1e-3, 1e7))
    spline_knot_spacing: float | None = key(
        None, doc='Regular knot spacing of the batch spline fit of filter = "spline"; not '
        "set: from the data's dynamics (``fusion.spline_refine``).", unit="s", positive=True,
        bounds=SPLINE_SPACING_BOUNDS)
    spline_anomaly_probability: float = key(
        0.999, doc="Probability 1 - alpha of Zhou et al.'s chi-square anomaly test "
        '(filter = "spline").', bounds=SPLINE_PROBABILITY_BOUNDS, half_open=True)
    calibration: bool = key(
        True, doc="Estimate the sensors' biases, latency and mount misalignment "
        "(``fusion.registration``) in the refinement passes.")
    refraction: str = key(
        "none", doc="Remove atmospheric refraction from radar and theodolite elevations and "
        "ranges (``fusion.refraction_rows``) in the refinement passes, with this model.",
        allowed=REFRACTION_MODELS, what="model")
    refractivity: float = key(
        313.0, doc="Surface refractivity of the radars' refraction.", unit="N-units",
        bounds=(0.0, 1000.0))
    optical_refractivity: float = key(
        OPTICAL_REFRACTIVITY, doc="Surface refractivity of the theodolites' (optical; laser "
        "ranges too) refraction.", unit="N-units", bounds=(0.0, 1000.0))
    hampel_window: int = key(
        7, doc="Half-width of the Hampel pre-edit (``editing.hampel``); 0 switches it off.",
        unit="samples", bounds=(0, 1000))
    hampel_threshold: float = key(
        6.0, doc="Threshold of the Hampel pre-edit.", unit="robust sigmas",
        bounds=(1.0, 1e6))


@dataclass(frozen=True, kw_only=True, slots=True)
class Config:
    """The whole validated config. ``path`` is the config file (absolute)."""

    path: Path = derived("The config file (absolute).")
    origin: Geodetic = key(doc="The range's origin: the range ENU frame's origin (table "
                           "below).", table="range", parse="geodetic")
    output: OutputSettings = key(doc="Where and how the products are written (table below).",
                                 parse="output", default_doc="all defaults")
    targets: tuple[TargetSettings, ...] = key(
        doc="The tracked objects with an id (table below).", parse="targets",
        default_doc='the targets the gps and mistram sensors name, else one target "T1"')
    sensors: tuple[SensorSettings, ...] = key(doc="The sensors, at least one (table below).",
                                              parse="sensors")
    processing: ProcessingSettings = key(
        ProcessingSettings(), doc="rangeproc's processing choices (table below).",
        parse="processing", default_doc="all defaults")


# --------------------------------------------------------------------------------------------
# Defaults and unit tables (read-only mappings: no module-level mutable state).
# --------------------------------------------------------------------------------------------

#: a-priori 1-sigma per sensor kind and component, SI (m, rad, m/s); contract key order.
DEFAULT_SIGMAS: Mapping[str, Mapping[str, float]] = MappingProxyType({
    "radar": MappingProxyType(
        {"range": 10.0, "azimuth": 1e-3, "elevation": 1e-3, "range_rate": 0.5}),
    "theodolite": MappingProxyType({"azimuth": 1e-4, "elevation": 1e-4, "range": 5.0}),
    "gps": MappingProxyType({"horizontal": 3.0, "vertical": 5.0, "velocity": 0.2}),
    "mistram": MappingProxyType({"range_rate": 0.1}),
    "ins": MappingProxyType(
        {"roll": 1e-4, "pitch": 1e-4, "yaw": 1e-4, "position": 1.0, "velocity": 0.1}),
})

#: radians per one unit of each ``angle_unit`` (6400 mil per circle).
ANGLE_TO_RADIANS: Mapping[str, float] = MappingProxyType(
    {"deg": math.pi / 180.0, "rad": 1.0, "mil": 2.0 * math.pi / 6400.0})

#: components (sigma keys and data columns) that are angles, in ``angle_unit`` at I/O.
ANGLE_COMPONENTS = frozenset({"azimuth", "elevation", "roll", "pitch", "yaw"})
