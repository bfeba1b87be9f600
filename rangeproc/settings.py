"""Settings of a run: the validated config as frozen dataclasses, and the unit tables.

Plain data, no logic beyond defaults: ``rangeproc.config`` is the one module that reads TOML
and builds these (and re-exports them, so ``from rangeproc.config import SensorSettings``
works as before). SI units throughout (metres, seconds, radians), except geodetic degrees.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

SENSOR_KINDS = ("radar", "theodolite", "gps", "mistram", "ins")
ANGLE_UNITS = ("deg", "rad", "mil")
#: Motion models of the IMM, in the order of ``estimation.imm``'s model codes.
IMM_MODELS = ("cv", "ca", "ct")
#: Default strong-tracking weakening factor beta (seed 001 leaves it to experience). With
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


@dataclass(frozen=True, kw_only=True, slots=True)
class Geodetic:
    """A WGS-84 point: ``lat``, ``lon`` in degrees (east positive), ``height`` in metres."""

    lat: float
    lon: float
    height: float


@dataclass(frozen=True, kw_only=True, slots=True)
class OutputSettings:
    """``[output]``: ``dir`` resolved to an absolute path; ``rate_hz`` fused sample rate (Hz);
    ``export``: interchange formats written with every run (``rangeproc.interchange``:
    "kml", "czml", "csv"); ``epoch``: the UTC instant (ISO 8601 with an offset) of time 0 on
    the range's time scale, for the report's and the exports' calendar times (None: not given;
    the calendar is then known only for Unix-scale times, ``rangeproc.timescale``)."""

    dir: Path
    rate_hz: float = 10.0
    export: tuple[str, ...] = ()
    epoch: str | None = None


@dataclass(frozen=True, kw_only=True, slots=True)
class InitialState:
    """A target's known state (``[[targets]] initial``), for data that cannot start a track
    by itself (e.g. MISTRAM range rates alone).

    time: s on the range time scale; position: WGS-84 ``lat``, ``lon`` (deg), ``height`` (m);
    velocity ``ve, vn, vu`` (m/s) in the range ENU frame; ``sigma_position`` (m) and
    ``sigma_velocity`` (m/s): 1-sigma per axis.
    """

    time: float
    position: Geodetic
    velocity: tuple[float, float, float]
    sigma_position: float
    sigma_velocity: float


@dataclass(frozen=True, kw_only=True, slots=True)
class TargetSettings:
    """``[[targets]]`` entry: ``id`` and the optional ``initial`` state."""

    id: str
    initial: InitialState | None = None


@dataclass(frozen=True, kw_only=True, slots=True)
class StationSettings:
    """A MISTRAM ground station (fixed)."""

    id: str
    site: Geodetic


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

    id: str
    kind: str
    file: Path
    site: Geodetic | None = None
    platform: str | None = None
    lever_arm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angle_unit: str = "deg"
    time_offset: float = 0.0
    sigma: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    target: str | None = None
    stations: tuple[StationSettings, ...] = ()
    allow_disjoint_time: bool = False
    calibrate: tuple[str, ...] = CALIBRATION_NAMES
    calibration: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))


@dataclass(frozen=True, kw_only=True, slots=True)
class ProcessingSettings:
    """Optional ``[processing]`` section (rangeproc's own; every field has a working default).

    gate_probability: chi-square gate probability for innovation gating (per measurement row).
    noise_passes: refinement passes after the first (re-linearisation at the smoothed track,
        noise and process-noise re-estimation).
    adapt_noise: estimate per-sensor noise (and local bursts) from the data.
    process_noise: white-jerk PSD q (m^2/s^5) of the constant-acceleration model; None =
        estimate it from the data (maximum likelihood, then local EM).
    filter: "ekf" (linearised, Joseph form), "ukf" (unscented), "stukf" (strong-tracking UKF
        with multiple suboptimal fading factors, seed 001), "sage-husa" (the EKF with
        improved Sage-Husa adaptive measurement noise, seed 002), "imm" (interacting multiple
        models with Kim's smoother), "askf" (augmented-state filter with the maneuver-norm
        constraint, seed 004) or "spline" (seed 000's self-adaptive spline filter, then the
        batch cubic B-spline fit).
    sage_husa_window: rows per sensor component in the Sage-Husa window (seed 002: 100).
    sage_husa_mean: Sage-Husa also estimates and removes the measurement-noise mean.
    maneuver_norm: the constant maneuver acceleration norm (m/s^2) of ``filter = "askf"``
        (seed 004); None = estimate it.
    stukf_forgetting, stukf_weakening, stukf_ratios: the strong-tracking forgetting factor rho
        of the innovation covariance (seed 001: 0.95), weakening factor beta >= 1 and prior
        ratios alpha >= 1 of position, velocity and acceleration (``estimation.fading``).
    imm_models, imm_sojourn: the IMM's model set (of "cv", "ca", "ct") and the mean time (s)
        spent in a model before switching, to each other model alike (``estimation.imm``).
    spline_knot_spacing: regular knot spacing (s) of the batch spline fit of
        ``filter = "spline"``; None = from the data's dynamics (``fusion.spline_refine``).
    spline_anomaly_probability: probability ``1 - alpha`` of seed 000's chi-square anomaly
        test (``filter = "spline"``; default 0.999).
    max_gap: a target unobserved for longer than this (s) is split into separate spans with no
        output epochs in between; also the distance that makes a sensor's time stamps isolated.
    time_margin: a sensor whose rows all lie farther than this (s) from every other sensor's
        rows is refused (wrong time scale or time_offset), unless ``allow_disjoint_time``.
    max_speed: physical speed limit (m/s) of targets and platforms (range rates, velocities,
        jumps between consecutive fixes).
    max_range: physical range limit (m) of radars and laser rangers; also the highest height.
    calibration: estimate the sensors' biases, latency and mount misalignment
        (``fusion.registration``) in the refinement passes.
    refraction: "none", "4/3" or "exponential": remove atmospheric refraction from radar and
        theodolite elevations and ranges (``fusion.refraction_rows``) in the refinement passes;
        refractivity / optical_refractivity: surface refractivity (N-units) of radars and of
        theodolites (optical; laser ranges too).
    hampel_window, hampel_threshold: half-width (samples) and threshold (robust sigmas) of the
        Hampel pre-edit (``editing.hampel``); ``hampel_window = 0`` switches it off.
    """

    gate_probability: float = 0.9999
    noise_passes: int = 2
    adapt_noise: bool = True
    process_noise: float | None = None
    filter: str = "ekf"
    max_gap: float = 60.0
    time_margin: float = 60.0
    max_speed: float = 2.0e4
    max_range: float = 5.0e7
    sage_husa_window: int = 100
    sage_husa_mean: bool = False
    maneuver_norm: float | None = None
    stukf_forgetting: float = 0.95
    stukf_weakening: float = STUKF_WEAKENING
    stukf_ratios: tuple[float, float, float] = (1.0, 1.0, 1.0)
    imm_models: tuple[str, ...] = ("cv", "ca", "ct")
    imm_sojourn: float = 10.0
    spline_knot_spacing: float | None = None
    spline_anomaly_probability: float = 0.999
    calibration: bool = True
    refraction: str = "none"
    refractivity: float = 313.0
    optical_refractivity: float = OPTICAL_REFRACTIVITY
    hampel_window: int = 7
    hampel_threshold: float = 6.0


@dataclass(frozen=True, kw_only=True, slots=True)
class Config:
    """The whole validated config. ``path`` is the config file (absolute)."""

    path: Path
    origin: Geodetic
    output: OutputSettings
    targets: tuple[TargetSettings, ...]
    sensors: tuple[SensorSettings, ...]
    processing: ProcessingSettings = ProcessingSettings()


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
