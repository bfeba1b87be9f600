"""Config: TOML -> frozen dataclasses. The only module that reads a run's config (a campaign's
own file is read by ``rangeproc.campaign.spec``).

Every error raises :class:`~rangeproc.errors.ConfigError` with a one-line message naming the
config file and the key at fault, e.g. ``sample.toml: sensors[2].sigma.azimth: unknown key``.
Angles in the config (``sigma`` angle entries) are converted to radians here using the sensor's
``angle_unit``; everything downstream is SI (metres, seconds, radians).

The keys are declared once, as the fields of the settings dataclasses (``rangeproc.settings``,
``rangeproc.keys``): each table's known keys, the defaults and the generic checks and messages
come from those declarations (:meth:`_Validator.value`); a key needing more has a parser here,
``_Validator.parse_<name>``, named by its declaration. What remains written out here are the
rules between keys (site or platform by kind, targets, stations).
"""
from __future__ import annotations

import dataclasses
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import MappingProxyType
from typing import Any

from rangeproc.config_checks import ValueChecks, a_kind, join_names, show_value, toml_syntax_error
from rangeproc.errors import DataError
from rangeproc.keys import (allowed_values, declaration, declared, field_types, key_fields,
                            optional_of, toml_keys)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

from rangeproc.settings import (  # re-exported: the config's public types and bounds
    ANGLE_COMPONENTS as ANGLE_COMPONENTS,
    ANGLE_TO_RADIANS as ANGLE_TO_RADIANS,
    ANGLE_UNITS as ANGLE_UNITS,
    CALIBRATION_BY_KIND as CALIBRATION_BY_KIND,
    CALIBRATION_NAMES as CALIBRATION_NAMES,
    FILTERS as FILTERS,
    GATE_PROBABILITY_BOUNDS as GATE_PROBABILITY_BOUNDS,
    HEIGHT_BOUNDS as HEIGHT_BOUNDS,
    MAX_ABS_TIME as MAX_ABS_TIME,
    MAX_CALIBRATION_ANGLE as MAX_CALIBRATION_ANGLE,
    MAX_CALIBRATION_RANGE as MAX_CALIBRATION_RANGE,
    MAX_LEVER_ARM as MAX_LEVER_ARM,
    MAX_NOISE_PASSES as MAX_NOISE_PASSES,
    MAX_SIGMA_ANGLE as MAX_SIGMA_ANGLE,
    MAX_SPEED as MAX_SPEED,
    PROCESS_NOISE_BOUNDS as PROCESS_NOISE_BOUNDS,
    RATE_HZ_BOUNDS as RATE_HZ_BOUNDS,
    REFRACTION_MODELS as REFRACTION_MODELS,
    SIGMA_BOUNDS as SIGMA_BOUNDS,
    SPLINE_PROBABILITY_BOUNDS as SPLINE_PROBABILITY_BOUNDS,
    SPLINE_SPACING_BOUNDS as SPLINE_SPACING_BOUNDS,
    STUKF_RATIO_BOUNDS as STUKF_RATIO_BOUNDS,
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
    v = _Validator(cfg_path.name, cfg_path.parent)
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


def _field(cls: type, name: str) -> dataclasses.Field:
    return next(f for f in dataclasses.fields(cls) if f.name == name)


class _Validator(ValueChecks):
    """Walks the parsed TOML document; every check raises a one-line ConfigError.

    ``folder``: the config file's folder (relative paths are resolved against it).
    """

    def __init__(self, file_name: str, folder: Path) -> None:
        super().__init__(file_name)
        self.folder = folder

    # ---- declared keys -------------------------------------------------------------------
    def value(self, cls: type, name: str, t: Mapping[str, Any], table_key: str,
              **context: Any) -> Any:
        """Key ``name`` of table ``t`` (at dotted ``table_key``), the field ``name`` of
        settings class ``cls``: checked as its declaration says (its parser
        ``parse_<decl.parse>(x, key, **context)`` when it names one, else
        :meth:`~rangeproc.config_checks.ValueChecks.declared`); absent, the field's default
        (``missing required key`` when it has none). A path is made absolute against the
        config file's folder."""
        f = _field(cls, name)
        decl = declaration(f)
        if decl is None or not decl.in_toml:
            raise LookupError(f"{cls.__name__}.{name} is not a declared config key")
        key = f"{table_key}.{name}" if table_key else name
        tp = optional_of(field_types(cls)[name])
        if name in t:
            if decl.parse:
                return getattr(self, f"parse_{decl.parse}")(t[name], key, **context)
            value = self.declared(decl, tp, t[name], key)
        elif f.default is not dataclasses.MISSING:
            value = f.default
        elif f.default_factory is not dataclasses.MISSING:
            value = f.default_factory()
        else:
            raise self.error(key, "missing required key")
        if tp is Path:
            value = (self.folder / value).resolve()
        return value

    def values(self, cls: type, t: Mapping[str, Any], table_key: str) -> dict[str, Any]:
        """Every key field of ``cls`` by :meth:`value`, in declaration order."""
        return {f.name: self.value(cls, f.name, t, table_key) for f in key_fields(cls)}

    # ---- geodetic positions ------------------------------------------------------------
    def parse_geodetic(self, x: object, key: str) -> Geodetic:
        t = self.table(x, key, toml_keys(Geodetic))
        lat = self.number(self.required(t, "lat", key), f"{key}.lat")
        lon = self.number(self.required(t, "lon", key), f"{key}.lon")
        height = self.value(Geodetic, "height", t, key)
        lat_lo, lat_hi = declared(Geodetic, "lat").bounds or (-90.0, 90.0)
        lon_lo, lon_hi = declared(Geodetic, "lon").bounds or (-180.0, 360.0)
        if not lat_lo <= lat <= lat_hi:
            raise self.error(f"{key}.lat", f"latitude {lat:g} outside [{lat_lo:g}, {lat_hi:g}] "
                                           "degrees")
        if not lon_lo <= lon < lon_hi:
            raise self.error(f"{key}.lon", f"longitude {lon:g} outside [{lon_lo:g}, "
                                           f"{lon_hi:g}) degrees")
        return Geodetic(lat=lat, lon=lon, height=height)

    # ---- sections ------------------------------------------------------------------------
    def config(self, doc: dict[str, Any], cfg_path: Path) -> Config:
        self.table(doc, "", toml_keys(Config))
        rng = self.table(self.required(doc, "range", ""), "range", toml_keys(Config, "range"))
        origin = self.value(Config, "origin", rng, "range")
        output = self.parse_output(doc.get("output", {}), "output")
        declared_targets = self.parse_targets(doc["targets"], "targets") if "targets" in doc \
            else None
        sensors = self.parse_sensors(self.required(doc, "sensors", ""), "sensors")
        targets, sensors = self.assign_targets(declared_targets, sensors)
        processing = self.parse_processing(doc.get("processing", {}), "processing")
        return Config(path=cfg_path, origin=origin, output=output, targets=targets,
                      sensors=tuple(sensors), processing=processing)

    def parse_output(self, x: object, key: str) -> OutputSettings:
        t = self.table(x, key, toml_keys(OutputSettings))
        return OutputSettings(**self.values(OutputSettings, t, key))

    def parse_export(self, x: object, key: str) -> tuple[str, ...]:
        allowed = allowed_values(declared(OutputSettings, "export"))
        formats = []
        for i, f in enumerate(self.array(x, key)):
            name = self.string(f, f"{key}[{i}]").strip().lower()
            if name not in allowed:
                raise self.error(f"{key}[{i}]", f"unknown format '{f}' (expected one "
                                 f"of: {join_names(allowed)})")
            formats.append(name)
        return tuple(dict.fromkeys(formats))

    def parse_epoch(self, x: object, key: str) -> str:
        """The epoch as given, once ``timescale.parse_epoch`` accepts it (not set: the
        calendar follows ``rangeproc.timescale``)."""
        epoch = self.string(x, key)
        try:
            parse_epoch(epoch, key)
        except DataError as exc:
            raise self.error("", str(exc)) from None
        return epoch

    def parse_targets(self, x: object, key: str) -> tuple[TargetSettings, ...]:
        items = self.array(x, key)
        if not items:
            raise self.error(key, "empty (omit [[targets]] to use the default target T1)")
        targets = []
        for i, item in enumerate(items):
            k = f"{key}[{i}]"
            t = self.table(item, k, toml_keys(TargetSettings))
            targets.append(TargetSettings(**self.values(TargetSettings, t, k)))
        self.unique_ids([t.id for t in targets], lambda i: f"{key}[{i}].id", "target")
        return tuple(targets)

    def parse_initial(self, x: object, key: str) -> InitialState:
        t = self.table(x, key, toml_keys(InitialState))
        time = self.value(InitialState, "time", t, key)
        position = self.parse_geodetic({k: t[k] for k in toml_keys(Geodetic) if k in t}, key)
        vel = declared(InitialState, "velocity")
        lo, hi = vel.bounds or (-MAX_SPEED, MAX_SPEED)
        ve, vn, vu = (self.bounded(t.get(part, 0.0), f"{key}.{part}", lo, hi, vel.unit)
                      for part in vel.parts)
        return InitialState(time=time, position=position, velocity=(ve, vn, vu),
                            sigma_position=self.value(InitialState, "sigma_position", t, key),
                            sigma_velocity=self.value(InitialState, "sigma_velocity", t, key))

    def parse_processing(self, x: object, key: str) -> ProcessingSettings:
        t = self.table(x, key, toml_keys(ProcessingSettings))
        return ProcessingSettings(**self.values(ProcessingSettings, t, key))

    def parse_imm_models(self, x: object, key: str) -> tuple[str, ...]:
        models = declared(ProcessingSettings, "imm_models").allowed
        names = ", ".join(f'"{m}"' for m in models)
        if not isinstance(x, list) or not x or not all(isinstance(m, str) for m in x):
            raise self.error(key, f"expected a non-empty list of model names ({names}), got "
                                  f"{show_value(x)}")
        for m in x:
            if m not in models:
                raise self.error(key, f"unknown model {m!r} (expected one of: {names})")
        if len(set(x)) != len(x):
            raise self.error(key, f"a model is listed twice: {show_value(x)}")
        return tuple(x)

    def parse_sensors(self, x: object, key: str) -> list[SensorSettings]:
        raw = self.array(x, key)
        if not raw:
            raise self.error(key, "at least one sensor is required")
        sensors = [self.sensor(s, f"{key}[{i}]") for i, s in enumerate(raw)]
        self.unique_ids([s.id for s in sensors], lambda i: f"{key}[{i}].id", "sensor")
        self.check_platforms(sensors)
        return sensors

    def sensor(self, x: object, key: str) -> SensorSettings:
        """One ``[[sensors]]`` entry: its declared keys, and the rules between them (which
        keys a kind allows or needs)."""
        t = self.table(x, key, toml_keys(SensorSettings))

        def value(name: str, **context: Any) -> Any:
            return self.value(SensorSettings, name, t, key, **context)

        ident, kind, file = value("id"), value("kind"), value("file")
        unit, time_offset = value("angle_unit"), value("time_offset")
        allow_disjoint = value("allow_disjoint_time")

        site = platform = None
        lever_arm = (0.0, 0.0, 0.0)
        if kind in _SITED_KINDS:
            if ("site" in t) == ("platform" in t):
                raise self.error(key, f"{a_kind(kind)} sensor needs exactly one of 'site' (fixed "
                                      "position) or 'platform' (id of an ins sensor)")
            site, platform = value("site"), value("platform")
            if "lever_arm" in t:
                if platform is None:
                    raise self.error(f"{key}.lever_arm",
                                     "only allowed together with 'platform'")
                lever_arm = value("lever_arm")
        else:
            for name in ("site", "platform", "lever_arm"):
                if name in t:
                    raise self.error(f"{key}.{name}", f"not allowed for {a_kind(kind)} sensor")

        target = None
        if "target" in t:
            if kind not in _TARGETED_KINDS:
                raise self.error(f"{key}.target", f"not allowed for {a_kind(kind)} sensor (only "
                                                  f"{' and '.join(_TARGETED_KINDS)})")
            target = value("target")

        stations: tuple[StationSettings, ...] = ()
        if kind == "mistram":
            stations = self.parse_stations(self.required(t, "stations", key), f"{key}.stations")
        elif "stations" in t:
            raise self.error(f"{key}.stations", f"not allowed for {a_kind(kind)} sensor "
                                                "(only mistram)")

        stated = value("sigma", kind=kind, unit=unit)
        sigma = MappingProxyType({**DEFAULT_SIGMAS[kind], **stated})
        names = calibration_terms(kind, platform is not None)
        calibrate = value("calibrate", names=names)
        known = value("calibration", names=tuple(n for n in names if n != "latency"), unit=unit)
        return SensorSettings(id=ident, kind=kind, file=file, site=site,
                              platform=platform, lever_arm=lever_arm, angle_unit=unit,
                              time_offset=time_offset, sigma=sigma, target=target,
                              stations=stations, allow_disjoint_time=allow_disjoint,
                              calibrate=tuple(n for n in names if n in calibrate),
                              calibration=known, rate_hz=value("rate_hz"))

    def parse_instant(self, x: object, key: str) -> float:
        """``time_offset``: seconds, or a calendar instant (``ValueChecks.instant``), within
        its declared bounds."""
        bounds = declared(SensorSettings, "time_offset").bounds
        return self.instant(x, key, bounds[1] if bounds else MAX_ABS_TIME)

    def parse_calibrate(self, x: object, key: str, names: tuple[str, ...]) -> tuple[str, ...]:
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

    def parse_known_calibration(self, x: object, key: str, names: tuple[str, ...], unit: str
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

    def parse_lever_arm(self, x: object, key: str) -> tuple[float, float, float]:
        decl = declared(SensorSettings, "lever_arm")
        lo, hi = decl.bounds or (-MAX_LEVER_ARM, MAX_LEVER_ARM)
        items = self.array(x, key)
        if len(items) != len(decl.parts):
            raise self.error(key, f"expected 3 numbers [x, y, z] (body FRD, m), got "
                                  f"{len(items)}")
        a, b, c = (self.bounded(v, f"{key}[{i}]", lo, hi, decl.unit)
                   for i, v in enumerate(items))
        return (a, b, c)

    def parse_stations(self, x: object, key: str) -> tuple[StationSettings, ...]:
        items = self.array(x, key)
        if not items:
            raise self.error(key, "a mistram sensor needs at least one station")
        out = []
        for j, item in enumerate(items):
            k = f"{key}[{j}]"
            t = self.table(item, k, toml_keys(StationSettings))
            ident = self.value(StationSettings, "id", t, k)
            site = self.parse_geodetic({n: v for n, v in t.items() if n != "id"}, k)
            out.append(StationSettings(id=ident, site=site))
        self.unique_ids([s.id for s in out], lambda j: f"{key}[{j}].id", "station")
        return tuple(out)

    def parse_sigma(self, x: object, key: str, kind: str, unit: str) -> Mapping[str, float]:
        """The stated sigmas in SI (the kind's defaults fill the rest, :meth:`sensor`)."""
        t = self.table(x, key, tuple(DEFAULT_SIGMAS[kind]))
        out = {}
        for name, value in t.items():
            s = self.positive(value, f"{key}.{name}")
            si = s * ANGLE_TO_RADIANS[unit] if name in ANGLE_COMPONENTS else s
            hi = MAX_SIGMA_ANGLE if name in ANGLE_COMPONENTS else SIGMA_BOUNDS[1]
            if not SIGMA_BOUNDS[0] <= si <= hi:
                raise self.error(f"{key}.{name}", f"{s:g} is outside the plausible range "
                                                  f"[{SIGMA_BOUNDS[0]:g}, {hi:g}] (SI units)")
            out[name] = si
        return out

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
