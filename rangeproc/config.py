"""Config: TOML -> frozen dataclasses. The only module that reads a run's config (a campaign's
own file is read by ``rangeproc.campaign.spec``).

Every error raises :class:`~rangeproc.errors.ConfigError` with a one-line message naming the
config file and the key at fault, e.g. ``sample.toml: sensors[2].sigma.azimth: unknown key``.
Angles in the config (``sigma`` angle entries) are converted to radians here using the sensor's
``angle_unit``; everything downstream is SI (metres, seconds, radians).
"""
from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import Any

from rangeproc.config_checks import (ValueChecks, a_kind, join_names, show_value, toml_syntax_error,
                                     type_name)
from rangeproc.errors import DataError
from rangeproc.interchange import FORMATS

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from rangeproc.settings import (  # re-exported: the config's public types
    ANGLE_COMPONENTS as ANGLE_COMPONENTS,
    ANGLE_TO_RADIANS as ANGLE_TO_RADIANS,
    ANGLE_UNITS as ANGLE_UNITS,
    CALIBRATION_BY_KIND as CALIBRATION_BY_KIND,
    CALIBRATION_NAMES as CALIBRATION_NAMES,
    REFRACTION_MODELS as REFRACTION_MODELS,
    calibration_terms as calibration_terms,
    Config as Config,
    DEFAULT_SIGMAS as DEFAULT_SIGMAS,
    IMM_MODELS as IMM_MODELS,
    Geodetic as Geodetic,
    InitialState as InitialState,
    OutputSettings as OutputSettings,
    ProcessingSettings as ProcessingSettings,
    SENSOR_KINDS as SENSOR_KINDS,
    SensorSettings as SensorSettings,
    StationSettings as StationSettings,
    TargetSettings as TargetSettings,
)
from rangeproc.timescale import parse_epoch


_TOP_KEYS = ("range", "output", "targets", "sensors", "processing")
_SENSOR_KEYS = ("id", "kind", "file", "site", "platform", "lever_arm", "angle_unit",
                "time_offset", "sigma", "target", "stations", "allow_disjoint_time",
                "calibrate", "calibration")
_GEODETIC_KEYS = ("lat", "lon", "height")
_INITIAL_KEYS = ("time", "lat", "lon", "height", "ve", "vn", "vu", "sigma_position",
                 "sigma_velocity")
#: defaults of ``initial`` sigmas when not stated: 1-sigma per axis (m, m/s)
INITIAL_SIGMA_POSITION = 100.0
INITIAL_SIGMA_VELOCITY = 50.0
#: |speed| (m/s) of anything: the speed of light (initial velocities, processing.max_speed)
MAX_SPEED = 3.0e8
_PROCESSING_KEYS = ("gate_probability", "noise_passes", "adapt_noise", "process_noise",
                    "filter", "max_gap", "time_margin", "max_speed", "max_range",
                    "sage_husa_window", "sage_husa_mean", "maneuver_norm",
                    "stukf_forgetting", "stukf_weakening", "stukf_ratios", "imm_models",
                    "imm_sojourn", "spline_knot_spacing", "spline_anomaly_probability",
                    "calibration", "refraction", "refractivity", "optical_refractivity",
                    "hampel_window", "hampel_threshold")

# Plausibility bounds of config numbers: a finite value outside them is a typo or a unit
# mistake, and would overflow or exhaust the processing (e.g. rate_hz = 1e9 asks for a
# billion output epochs per second).
#: heights of the origin, sites and stations (m): deepest trench to beyond the Moon's distance
HEIGHT_BOUNDS = (-12_000.0, 1.0e9)
#: |time| (s) of any time stamp, time_offset or initial time: about 317 years, float64 still
#: resolves 2e-6 s there (also the screening's bound on the stamps, ``editing.timecheck``)
MAX_ABS_TIME = 1.0e10
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
#: processing.max_gap, time_margin (s), max_speed (m/s), max_range (m): (low, high)
PROCESSING_BOUNDS: Mapping[str, tuple[float, float]] = MappingProxyType({
    "max_gap": (1e-3, 1e7), "time_margin": (0.0, 1e10), "max_speed": (1.0, MAX_SPEED),
    "max_range": (1.0, 1.0e12), "stukf_forgetting": (1e-3, 1.0),
    "stukf_weakening": (1.0, 1e3), "imm_sojourn": (1e-3, 1e7)})
#: Bounds of each strong-tracking prior ratio alpha (seed 001: alpha >= 1).
STUKF_RATIO_BOUNDS = (1.0, 1e3)
FILTERS = ("ekf", "ukf", "stukf", "sage-husa", "askf", "imm", "spline")
#: processing.spline_knot_spacing (s): regular knots of the batch spline fit
SPLINE_SPACING_BOUNDS = (1e-3, 1e5)
#: processing.spline_anomaly_probability: 1 - alpha of seed 000's chi-square anomaly test
SPLINE_PROBABILITY_BOUNDS = (0.5, 1.0)
_SITED_KINDS = ("radar", "theodolite")   # need exactly one of site / platform
_TARGETED_KINDS = ("gps", "mistram")     # carried by one cooperative target
DEFAULT_TARGET = "T1"


# --------------------------------------------------------------------------------------------
# Loader
# --------------------------------------------------------------------------------------------

def load_config(path: str | Path) -> Config:
    """Read and validate a rangeproc TOML config (data contract section 3).

    Relative ``output.dir`` and ``sensors[i].file`` are resolved against the config file's
    folder. Angle sigmas are converted to radians with the sensor's ``angle_unit``; sigma
    components the user did not state are filled from :data:`DEFAULT_SIGMAS`.

    Targets: when ``[[targets]]`` is present, every gps/mistram ``target`` must name one of them
    (and may be omitted only when exactly one target is declared). When ``[[targets]]`` is
    absent, the targets are the distinct ``target`` names of the gps/mistram sensors in order of
    first appearance, or the single default target ``"T1"`` when no sensor names one. A
    gps/mistram sensor without ``target`` is given the only target; when there are several
    targets, ``target`` is required.

    Sensor data files are not opened here (a missing file is reported by the reader).

    Raises:
        ConfigError: one line ``<config file name>: <key path>: <problem>``, key paths with
            TOML names and 0-based list indices, e.g. ``sensors[2].sigma.azimth``.
    """
    cfg_path = Path(path).expanduser().resolve()
    v = _Validator(cfg_path.name)
    try:
        with cfg_path.open("rb") as fh:
            doc = tomllib.load(fh)
    except FileNotFoundError:
        raise v.error("", f"config file not found ({cfg_path})") from None
    except IsADirectoryError:
        raise v.error("", f"is a directory, not a config file ({cfg_path})") from None
    except OSError as exc:
        raise v.error("", f"cannot read config file: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise v.error("", f"not UTF-8 text (byte {exc.start})") from None
    except tomllib.TOMLDecodeError as exc:
        raise toml_syntax_error(cfg_path.name, exc) from None
    return v.config(doc, cfg_path)


class _Validator(ValueChecks):
    """Walks the parsed TOML document; every check raises a one-line ConfigError."""

    # ---- geodetic positions ------------------------------------------------------------
    def geodetic(self, x: object, key: str) -> Geodetic:
        t = self.table(x, key, _GEODETIC_KEYS)
        lat = self.number(self.required(t, "lat", key), f"{key}.lat")
        lon = self.number(self.required(t, "lon", key), f"{key}.lon")
        height = self.bounded(self.required(t, "height", key), f"{key}.height",
                              *HEIGHT_BOUNDS, "m")
        if not -90.0 <= lat <= 90.0:
            raise self.error(f"{key}.lat", f"latitude {lat:g} outside [-90, 90] degrees")
        if not -180.0 <= lon < 360.0:
            raise self.error(f"{key}.lon", f"longitude {lon:g} outside [-180, 360) degrees")
        return Geodetic(lat=lat, lon=lon, height=height)

    # ---- sections ------------------------------------------------------------------------
    def config(self, doc: dict[str, Any], cfg_path: Path) -> Config:
        self.table(doc, "", _TOP_KEYS)
        rng = self.table(self.required(doc, "range", ""), "range", ("origin",))
        origin = self.geodetic(self.required(rng, "origin", "range"), "range.origin")
        output = self.output(doc.get("output", {}), cfg_path.parent)
        declared = self.targets(doc["targets"]) if "targets" in doc else None
        raw = self.array(self.required(doc, "sensors", ""), "sensors")
        if not raw:
            raise self.error("sensors", "at least one sensor is required")
        sensors = [self.sensor(s, f"sensors[{i}]", cfg_path.parent) for i, s in enumerate(raw)]
        self.unique_ids([s.id for s in sensors], lambda i: f"sensors[{i}].id", "sensor")
        self.check_platforms(sensors)
        targets, sensors = self.assign_targets(declared, sensors)
        processing = self.processing(doc.get("processing", {}))
        return Config(path=cfg_path, origin=origin, output=output, targets=targets,
                      sensors=tuple(sensors), processing=processing)

    def output(self, x: object, folder: Path) -> OutputSettings:
        t = self.table(x, "output", ("dir", "rate_hz", "export", "epoch"))
        out_dir = Path(self.string(t.get("dir", "out"), "output.dir")).expanduser()
        rate = self.positive(t.get("rate_hz", 10.0), "output.rate_hz")
        rate = self.bounded(rate, "output.rate_hz", *RATE_HZ_BOUNDS, "Hz")
        formats = []
        for i, f in enumerate(self.array(t.get("export", []), "output.export")):
            name = self.string(f, f"output.export[{i}]").strip().lower()
            if name not in FORMATS:
                raise self.error(f"output.export[{i}]", f"unknown format '{f}' (expected one "
                                 f"of: {join_names(FORMATS)})")
            formats.append(name)
        epoch = None                     # not given: the calendar follows rangeproc.timescale
        if "epoch" in t:
            epoch = self.string(t["epoch"], "output.epoch")
            try:
                parse_epoch(epoch, "output.epoch")
            except DataError as exc:
                raise self.error("", str(exc)) from None
        return OutputSettings(dir=(folder / out_dir).resolve(), rate_hz=rate,
                              export=tuple(dict.fromkeys(formats)), epoch=epoch)

    def targets(self, x: object) -> tuple[TargetSettings, ...]:
        items = self.array(x, "targets")
        if not items:
            raise self.error("targets", "empty (omit [[targets]] to use the default target T1)")
        ids, initial = [], []
        for i, item in enumerate(items):
            t = self.table(item, f"targets[{i}]", ("id", "initial"))
            ids.append(self.string(self.required(t, "id", f"targets[{i}]"), f"targets[{i}].id"))
            initial.append(self.initial(t["initial"], f"targets[{i}].initial")
                           if "initial" in t else None)
        self.unique_ids(ids, lambda i: f"targets[{i}].id", "target")
        return tuple(TargetSettings(id=ident, initial=init) for ident, init in zip(ids, initial))

    def initial(self, x: object, key: str) -> InitialState:
        t = self.table(x, key, _INITIAL_KEYS)
        time = self.bounded(self.required(t, "time", key), f"{key}.time", -MAX_ABS_TIME,
                            MAX_ABS_TIME, "s")
        position = self.geodetic({k: t[k] for k in _GEODETIC_KEYS if k in t}, key)
        velocity = tuple(self.bounded(t.get(k, 0.0), f"{key}.{k}", -MAX_SPEED, MAX_SPEED, "m/s")
                         for k in ("ve", "vn", "vu"))
        sp = self.positive(t.get("sigma_position", INITIAL_SIGMA_POSITION),
                           f"{key}.sigma_position")
        sv = self.positive(t.get("sigma_velocity", INITIAL_SIGMA_VELOCITY),
                           f"{key}.sigma_velocity")
        return InitialState(time=time, position=position, velocity=velocity,  # type: ignore
                            sigma_position=self.bounded(sp, f"{key}.sigma_position",
                                                        *SIGMA_BOUNDS, "m"),
                            sigma_velocity=self.bounded(sv, f"{key}.sigma_velocity",
                                                        *SIGMA_BOUNDS, "m/s"))

    def processing(self, x: object) -> ProcessingSettings:
        t = self.table(x, "processing", _PROCESSING_KEYS)
        kw: dict[str, Any] = {}
        if "gate_probability" in t:
            kw["gate_probability"] = self.probability(t["gate_probability"],
                                                      "processing.gate_probability",
                                                      GATE_PROBABILITY_BOUNDS)
        if "noise_passes" in t:
            n = t["noise_passes"]
            if not isinstance(n, int) or isinstance(n, bool):
                raise self.error("processing.noise_passes",
                                 f"expected an integer, got {type_name(n)} ({show_value(n)})")
            if not 0 <= n <= MAX_NOISE_PASSES:
                raise self.error("processing.noise_passes",
                                 f"must be in [0, {MAX_NOISE_PASSES}], got {n}")
            kw["noise_passes"] = n
        if "adapt_noise" in t:
            kw["adapt_noise"] = self.boolean(t["adapt_noise"], "processing.adapt_noise")
        if "process_noise" in t:
            q = self.positive(t["process_noise"], "processing.process_noise")
            kw["process_noise"] = self.bounded(q, "processing.process_noise",
                                               *PROCESS_NOISE_BOUNDS, "m^2/s^5")
        if "sage_husa_window" in t:
            w = t["sage_husa_window"]
            if not isinstance(w, int) or isinstance(w, bool) or not 2 <= w <= 100_000:
                raise self.error("processing.sage_husa_window",
                                 f"expected an integer in [2, 100000], got {show_value(w)}")
            kw["sage_husa_window"] = w
        if "maneuver_norm" in t:
            mn = self.positive(t["maneuver_norm"], "processing.maneuver_norm")
            kw["maneuver_norm"] = self.bounded(mn, "processing.maneuver_norm", 1e-6, 1e5,
                                               "m/s^2")
        if "spline_knot_spacing" in t:
            ks = self.positive(t["spline_knot_spacing"], "processing.spline_knot_spacing")
            kw["spline_knot_spacing"] = self.bounded(ks, "processing.spline_knot_spacing",
                                                     *SPLINE_SPACING_BOUNDS, "s")
        if "spline_anomaly_probability" in t:
            kw["spline_anomaly_probability"] = self.probability(
                t["spline_anomaly_probability"], "processing.spline_anomaly_probability",
                SPLINE_PROBABILITY_BOUNDS)
        if "calibration" in t:
            kw["calibration"] = self.boolean(t["calibration"], "processing.calibration")
        if "refraction" in t:
            m = self.string(t["refraction"], "processing.refraction")
            if m not in REFRACTION_MODELS:
                raise self.error("processing.refraction", f"unknown model {m!r} (expected one "
                                 f"of: {join_names(REFRACTION_MODELS)})")
            kw["refraction"] = m
        for name in ("refractivity", "optical_refractivity"):
            if name in t:
                kw[name] = self.bounded(t[name], f"processing.{name}", 0.0, 1000.0,
                                        "N-units")
        if "hampel_window" in t:
            w = t["hampel_window"]
            if not isinstance(w, int) or isinstance(w, bool) or not 0 <= w <= 1000:
                raise self.error("processing.hampel_window",
                                 f"expected an integer in [0, 1000], got {show_value(w)}")
            kw["hampel_window"] = w
        if "hampel_threshold" in t:
            kw["hampel_threshold"] = self.bounded(t["hampel_threshold"],
                                                  "processing.hampel_threshold", 1.0, 1e6,
                                                  "robust sigmas")
        if "sage_husa_mean" in t:
            kw["sage_husa_mean"] = self.boolean(t["sage_husa_mean"], "processing.sage_husa_mean")
        for name, (lo, hi) in PROCESSING_BOUNDS.items():
            if name in t:
                kw[name] = self.bounded(t[name], f"processing.{name}", lo, hi)
        if "stukf_ratios" in t:
            r = t["stukf_ratios"]
            if not isinstance(r, list) or len(r) != 3:
                raise self.error("processing.stukf_ratios", "expected 3 numbers (position, "
                                 f"velocity, acceleration), got {show_value(r)}")
            kw["stukf_ratios"] = tuple(self.bounded(v, f"processing.stukf_ratios[{i}]",
                                                    *STUKF_RATIO_BOUNDS) for i, v in enumerate(r))
        if "imm_models" in t:
            kw["imm_models"] = self.imm_models(t["imm_models"])
        if "filter" in t:
            f = self.string(t["filter"], "processing.filter")
            if f not in FILTERS:
                raise self.error("processing.filter",
                                 f"unknown filter {f!r} (expected one of: {join_names(FILTERS)})")
            kw["filter"] = f
        return ProcessingSettings(**kw)

    def imm_models(self, x: object) -> tuple[str, ...]:
        key = "processing.imm_models"
        names = ", ".join(f'"{m}"' for m in IMM_MODELS)
        if not isinstance(x, list) or not x or not all(isinstance(m, str) for m in x):
            raise self.error(key, f"expected a non-empty list of model names ({names}), got "
                                  f"{show_value(x)}")
        for m in x:
            if m not in IMM_MODELS:
                raise self.error(key, f"unknown model {m!r} (expected one of: {names})")
        if len(set(x)) != len(x):
            raise self.error(key, f"a model is listed twice: {show_value(x)}")
        return tuple(x)

    def sensor(self, x: object, key: str, folder: Path) -> SensorSettings:
        t = self.table(x, key, _SENSOR_KEYS)
        ident = self.string(self.required(t, "id", key), f"{key}.id")
        kind = self.string(self.required(t, "kind", key), f"{key}.kind")
        if kind not in SENSOR_KINDS:
            raise self.error(f"{key}.kind",
                             f"unknown sensor kind '{kind}' (expected one of: "
                             f"{join_names(SENSOR_KINDS)})")
        file = Path(self.string(self.required(t, "file", key), f"{key}.file")).expanduser()
        unit = self.string(t.get("angle_unit", "deg"), f"{key}.angle_unit")
        if unit not in ANGLE_UNITS:
            raise self.error(f"{key}.angle_unit",
                             f"unknown angle unit '{unit}' (expected one of: "
                             f"{join_names(ANGLE_UNITS)})")
        time_offset = self.instant(t.get("time_offset", 0.0), f"{key}.time_offset",
                                   MAX_ABS_TIME)
        allow_disjoint = self.boolean(t.get("allow_disjoint_time", False),
                                      f"{key}.allow_disjoint_time")

        site = platform = None
        lever_arm = (0.0, 0.0, 0.0)
        if kind in _SITED_KINDS:
            if ("site" in t) == ("platform" in t):
                raise self.error(key, f"{a_kind(kind)} sensor needs exactly one of 'site' (fixed "
                                      "position) or 'platform' (id of an ins sensor)")
            if "site" in t:
                site = self.geodetic(t["site"], f"{key}.site")
            else:
                platform = self.string(t["platform"], f"{key}.platform")
            if "lever_arm" in t:
                if platform is None:
                    raise self.error(f"{key}.lever_arm",
                                     "only allowed together with 'platform'")
                lever_arm = self.lever_arm(t["lever_arm"], f"{key}.lever_arm")
        else:
            for name in ("site", "platform", "lever_arm"):
                if name in t:
                    raise self.error(f"{key}.{name}", f"not allowed for {a_kind(kind)} sensor")

        target = None
        if "target" in t:
            if kind not in _TARGETED_KINDS:
                raise self.error(f"{key}.target", f"not allowed for {a_kind(kind)} sensor (only "
                                                  f"{' and '.join(_TARGETED_KINDS)})")
            target = self.string(t["target"], f"{key}.target")

        stations: tuple[StationSettings, ...] = ()
        if kind == "mistram":
            stations = self.stations(self.required(t, "stations", key), f"{key}.stations")
        elif "stations" in t:
            raise self.error(f"{key}.stations", f"not allowed for {a_kind(kind)} sensor "
                                                "(only mistram)")

        sigma = self.sigma(t.get("sigma", {}), f"{key}.sigma", kind, unit)
        names = calibration_terms(kind, platform is not None)
        calibrate = self.calibrate(t.get("calibrate", True), f"{key}.calibrate", names)
        known = self.known_calibration(t.get("calibration", {}), f"{key}.calibration",
                                       tuple(n for n in names if n != "latency"), unit)
        return SensorSettings(id=ident, kind=kind, file=(folder / file).resolve(), site=site,
                              platform=platform, lever_arm=lever_arm, angle_unit=unit,
                              time_offset=time_offset, sigma=sigma, target=target,
                              stations=stations, allow_disjoint_time=allow_disjoint,
                              calibrate=calibrate, calibration=known)

    def calibrate(self, x: object, key: str, names: tuple[str, ...]) -> tuple[str, ...]:
        """``calibrate = true | false | [names]``: which of ``names`` may be estimated."""
        if isinstance(x, bool):
            return names if x else ()
        listed = ", ".join(f'"{n}"' for n in names) or "none for this sensor"
        if not isinstance(x, list) or not all(isinstance(n, str) for n in x):
            raise self.error(key, f"expected true, false or a list of terms ({listed}), got "
                                  f"{show_value(x)}")
        for n in x:
            if n not in names:
                raise self.error(key, f"unknown or inapplicable term {n!r} (this sensor has: "
                                      f"{listed})")
        return tuple(n for n in names if n in x)

    def known_calibration(self, x: object, key: str, names: tuple[str, ...], unit: str
                          ) -> Mapping[str, float]:
        """Known corrections ``{name = value}`` (m; angles in ``angle_unit``) -> SI."""
        t = self.table(x, key, names)
        out = {}
        for name, value in t.items():
            v = self.number(value, f"{key}.{name}")
            si = v if name == "range" else v * ANGLE_TO_RADIANS[unit]
            lo, hi = (-MAX_CALIBRATION_RANGE, MAX_CALIBRATION_RANGE) if name == "range" \
                else (-MAX_CALIBRATION_ANGLE, MAX_CALIBRATION_ANGLE)
            if not lo <= si <= hi:
                raise self.error(f"{key}.{name}", f"{v:g} is outside the plausible range "
                                                  f"[{lo:g}, {hi:g}] (SI units)")
            out[name] = si
        return MappingProxyType(out)

    def lever_arm(self, x: object, key: str) -> tuple[float, float, float]:
        items = self.array(x, key)
        if len(items) != 3:
            raise self.error(key, f"expected 3 numbers [x, y, z] (body FRD, m), got "
                                  f"{len(items)}")
        a, b, c = (self.bounded(v, f"{key}[{i}]", -MAX_LEVER_ARM, MAX_LEVER_ARM, "m")
                   for i, v in enumerate(items))
        return (a, b, c)

    def stations(self, x: object, key: str) -> tuple[StationSettings, ...]:
        items = self.array(x, key)
        if not items:
            raise self.error(key, "a mistram sensor needs at least one station")
        out = []
        for j, item in enumerate(items):
            k = f"{key}[{j}]"
            t = self.table(item, k, ("id",) + _GEODETIC_KEYS)
            ident = self.string(self.required(t, "id", k), f"{k}.id")
            site = self.geodetic({n: v for n, v in t.items() if n != "id"}, k)
            out.append(StationSettings(id=ident, site=site))
        self.unique_ids([s.id for s in out], lambda j: f"{key}[{j}].id", "station")
        return tuple(out)

    def sigma(self, x: object, key: str, kind: str, unit: str) -> Mapping[str, float]:
        defaults = DEFAULT_SIGMAS[kind]
        t = self.table(x, key, tuple(defaults))
        out = dict(defaults)
        for name, value in t.items():
            s = self.positive(value, f"{key}.{name}")
            si = s * ANGLE_TO_RADIANS[unit] if name in ANGLE_COMPONENTS else s
            hi = MAX_SIGMA_ANGLE if name in ANGLE_COMPONENTS else SIGMA_BOUNDS[1]
            if not SIGMA_BOUNDS[0] <= si <= hi:
                raise self.error(f"{key}.{name}", f"{s:g} is outside the plausible range "
                                                  f"[{SIGMA_BOUNDS[0]:g}, {hi:g}] (SI units)")
            out[name] = si
        return MappingProxyType(out)

    # ---- cross-references ----------------------------------------------------------------
    def check_platforms(self, sensors: Sequence[SensorSettings]) -> None:
        kinds = {s.id: s.kind for s in sensors}
        for i, s in enumerate(sensors):
            if s.platform is None:
                continue
            if s.platform not in kinds:
                ins = [k for k, v in kinds.items() if v == "ins"]
                raise self.error(f"sensors[{i}].platform",
                                 f"'{s.platform}' names no sensor (ins sensors: "
                                 f"{join_names(ins) or 'none'})")
            if kinds[s.platform] != "ins":
                raise self.error(f"sensors[{i}].platform", f"'{s.platform}' is "
                                 f"{a_kind(kinds[s.platform])} sensor, not an ins")

    def assign_targets(self, declared: tuple[TargetSettings, ...] | None,
                       sensors: list[SensorSettings]
                       ) -> tuple[tuple[TargetSettings, ...], list[SensorSettings]]:
        if declared is None:
            named = dict.fromkeys(s.target for s in sensors if s.target is not None)
            declared = tuple(TargetSettings(id=t) for t in named) or (
                TargetSettings(id=DEFAULT_TARGET),)
        else:
            ids = [t.id for t in declared]
            for i, s in enumerate(sensors):
                if s.target is not None and s.target not in ids:
                    raise self.error(f"sensors[{i}].target",
                                     f"'{s.target}' is not a declared target "
                                     f"(declared: {join_names(ids)})")
        out = []
        for i, s in enumerate(sensors):
            if s.kind in _TARGETED_KINDS and s.target is None:
                if len(declared) > 1:
                    raise self.error(f"sensors[{i}].target",
                                     f"required for {a_kind(s.kind)} sensor when there are several "
                                     f"targets ({join_names([t.id for t in declared])})")
                s = dataclasses.replace(s, target=declared[0].id)
            out.append(s)
        return declared, out
