"""The config reference (docs/config.md) and the loader derive from the settings' declarations.

A key is declared once, as a settings dataclass field (``rangeproc.keys.key``); these tests keep
the loader, the declarations and the generated reference in step: the loader accepts exactly
the declared fields, every one of them is in the reference with its default (and that default,
written back into a config, loads as the default), a declaration without a meaning is refused,
and unknown keys are still refused with the loader's one-line message.
"""
from __future__ import annotations

import dataclasses
import re
import sys
import typing
from pathlib import Path

import pytest

from rangeproc.config import _Validator, load_config
from rangeproc.config_reference import config_reference_markdown
from rangeproc.errors import ConfigError
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.keys import declaration, declaration_problems, key, key_fields
from rangeproc.settings import (Config, Geodetic, InitialState, OutputSettings, ProcessingSettings,
                                SensorSettings, StationSettings, TargetSettings)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

#: A valid config with every table: [range], [output], [[targets]] with initial, a sited and a
#: platform radar, an ins, a gps, a mistram with a station, [processing].
BASE = """\
[range]
origin = { lat = 34.9, lon = -117.9, height = 700.0 }

[output]
dir = "out"

[[targets]]
id = "T1"
initial = { time = 0.0, lat = 35.0, lon = -117.0, height = 100.0 }

[[sensors]]
id = "R1"
kind = "radar"
file = "R1.csv"
site = { lat = 35.0, lon = -117.5, height = 713.0 }

[[sensors]]
id = "S1"
kind = "radar"
file = "S1.csv"
platform = "SHIP_INS"

[[sensors]]
id = "SHIP_INS"
kind = "ins"
file = "SHIP_INS.csv"

[[sensors]]
id = "G1"
kind = "gps"
file = "G1.csv"

[[sensors]]
id = "M"
kind = "mistram"
file = "M.csv"
stations = [ { id = "M1", lat = 35.02, lon = -117.50, height = 720.0 } ]

[processing]
"""

#: Where an unknown key goes to reach each table (a TOML edit of BASE), the dotted key the
#: loader names, and the settings class whose declared fields the table's keys must be.
TABLES = {
    "top": (lambda k: f"{k} = 1\n" + BASE, "", Config),
    "range": (lambda k: BASE.replace("[range]\n", f"[range]\n{k} = 1\n"), "range.", None),
    "range.origin": (lambda k: BASE.replace("height = 700.0 }", f"height = 700.0, {k} = 1 }}"),
                     "range.origin.", Geodetic),
    "output": (lambda k: BASE.replace('dir = "out"', f'dir = "out"\n{k} = 1'), "output.",
               OutputSettings),
    "targets": (lambda k: BASE.replace('id = "T1"', f'id = "T1"\n{k} = 1'), "targets[0].",
                TargetSettings),
    "targets.initial": (lambda k: BASE.replace("height = 100.0 }", f"height = 100.0, {k} = 1 }}"),
                        "targets[0].initial.", InitialState),
    "sensors": (lambda k: BASE.replace('id = "R1"', f'id = "R1"\n{k} = 1'), "sensors[0].",
                SensorSettings),
    "sensors.site": (lambda k: BASE.replace("height = 713.0 }", f"height = 713.0, {k} = 1 }}"),
                     "sensors[0].site.", Geodetic),
    "sensors.stations": (lambda k: BASE.replace("height = 720.0 }", f"height = 720.0, {k} = 1 }}"),
                         "sensors[4].stations[0].", StationSettings),
    "processing": (lambda k: BASE + f"{k} = 1\n", "processing.", ProcessingSettings),
}


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "sample.toml"
    path.write_text(text, encoding="utf-8")
    return path


def accepted_keys(tmp_path: Path, table: str) -> tuple[str, ...]:
    """The keys the loader accepts in ``table``, as its unknown-key message lists them."""
    make, prefix, _ = TABLES[table]
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, make("no_such_key")))
    m = re.fullmatch(rf"sample\.toml: {re.escape(prefix)}no_such_key: unknown key \(expected one "
                     r"of: (.*)\)", str(err.value))
    assert m, str(err.value)
    return tuple(m.group(1).split(", "))


def declared_keys(cls: type) -> set[str]:
    """The TOML keys of ``cls``' fields, from ``dataclasses.fields`` itself: a field's name, or
    the keys of a flattened field (a nested dataclass's fields, or its ``parts``)."""
    out = set()
    for f in dataclasses.fields(cls):
        decl = declaration(f)
        if decl is None or not decl.in_toml:
            continue
        tp = typing.get_type_hints(cls)[f.name]
        if decl.table:
            out.add(decl.table)
        elif decl.flatten and dataclasses.is_dataclass(tp):
            out |= declared_keys(tp)
        elif decl.flatten:
            out |= set(decl.parts)
        else:
            out.add(f.name)
    return out


def reference_tables() -> dict[str, dict[str, tuple[str, ...]]]:
    """The generated page's tables: heading -> key -> its cells (type, default, unit, allowed,
    meaning)."""
    out: dict[str, dict[str, tuple[str, ...]]] = {}
    heading = ""
    for line in config_reference_markdown().splitlines():
        if line.startswith("## "):
            heading = line[3:]
            out[heading] = {}
        m = re.match(r"\| `([^`]+)` \| (.*) \|$", line)
        if m and heading:
            out[heading][m.group(1)] = tuple(c.strip() for c in m.group(2).split(" | "))
    return out


def reference_table(title: str) -> dict[str, tuple[str, ...]]:
    tables = reference_tables()
    found = [rows for heading, rows in tables.items() if f"`{title}`" in heading]
    assert len(found) == 1, (title, list(tables))
    return found[0]


# ---- the loader's keys are the declared fields ------------------------------------------------

@pytest.mark.parametrize("table", [t for t in TABLES if TABLES[t][2] is not None])
def test_loader_accepts_exactly_the_declared_fields(tmp_path: Path, table: str) -> None:
    cls = TABLES[table][2]
    assert set(accepted_keys(tmp_path, table)) == declared_keys(cls)


def test_every_settings_field_is_declared_with_a_meaning() -> None:
    assert declaration_problems(Config) == []


def test_every_declared_parser_exists() -> None:
    for cls in (Config, Geodetic, OutputSettings, TargetSettings, InitialState, SensorSettings,
                StationSettings, ProcessingSettings):
        for f in key_fields(cls):
            decl = declaration(f)
            assert decl is not None
            if decl.parse:
                assert callable(getattr(_Validator, f"parse_{decl.parse}", None)), (cls, f.name)


def test_the_estimator_does_not_declare_processing_keys_again() -> None:
    """The estimator reads ``[processing]`` by name (``EstimatorSettings.processing``); none of
    its own fields repeats a processing key. (Two share a name, not a declaration: its
    ``calibration`` and ``refraction`` are what ``processing.calibration`` and
    ``processing.refraction`` become with the sensors: per-sensor terms and refractivities,
    ``stages.fuse.estimator_settings``.)"""
    own = {f.name for f in dataclasses.fields(EstimatorSettings)} - {"calibration", "refraction"}
    assert own.isdisjoint(f.name for f in dataclasses.fields(ProcessingSettings))


# ---- a key without a meaning is refused ---------------------------------------------------

def test_a_key_declared_without_a_meaning_is_reported() -> None:
    @dataclasses.dataclass(frozen=True, kw_only=True, slots=True)
    class Fake:
        documented: float = key(1.0, doc="A documented key.", unit="s", bounds=(0.0, 2.0))
        blank: float = key(2.0, doc="  ")
        bare: int = 3
        odd: complex = key(1j, doc="A value no generic check covers and no parser reads.")

    problems = declaration_problems(Fake)
    assert any(p.startswith("Fake.blank: declared without a meaning") for p in problems)
    assert any(p.startswith("Fake.bare: not declared") for p in problems)
    assert any(p.startswith("Fake.odd: type") and "needs a parser" in p for p in problems)
    assert not any(p.startswith("Fake.documented") for p in problems)
    assert len(problems) == 3


# ---- unknown keys: today's messages ---------------------------------------------------------

@pytest.mark.parametrize(("text", "message"), [
    (BASE + "gate = 0.99\n",
     "sample.toml: processing.gate: unknown key (expected one of: gate_probability, "
     "noise_passes, adapt_noise, process_noise, filter, max_gap, time_margin, keep_isolated, "
     "max_speed, "
     "max_range, sage_husa_window, sage_husa_mean, maneuver_norm, stukf_forgetting, "
     "stukf_weakening, stukf_ratios, imm_models, imm_sojourn, spline_knot_spacing, "
     "spline_anomaly_probability, calibration, refraction, refractivity, optical_refractivity, "
     "hampel_window, hampel_threshold)"),
    ("foo = 1\n" + BASE,
     "sample.toml: foo: unknown key (expected one of: range, output, targets, sensors, "
     "processing)"),
    (BASE.replace('id = "R1"', 'id = "R1"\nazimth = 1'),
     "sample.toml: sensors[0].azimth: unknown key (expected one of: id, kind, file, site, "
     "platform, lever_arm, angle_unit, time_offset, sigma, target, stations, "
     "allow_disjoint_time, calibrate, calibration, rate_hz)"),
    (BASE.replace('dir = "out"', 'dir = "out"\nrate = 10'),
     "sample.toml: output.rate: unknown key (expected one of: dir, rate_hz, export, epoch)"),
    (BASE.replace("height = 100.0 }", "height = 100.0, speed = 3 }"),
     "sample.toml: targets[0].initial.speed: unknown key (expected one of: time, lat, lon, "
     "height, ve, vn, vu, sigma_position, sigma_velocity)"),
    (BASE.replace("height = 720.0 }", "height = 720.0, elev = 3 }"),
     "sample.toml: sensors[4].stations[0].elev: unknown key (expected one of: id, lat, lon, "
     "height)"),
])
def test_unknown_keys_are_refused_with_todays_message(tmp_path: Path, text: str,
                                                      message: str) -> None:
    with pytest.raises(ConfigError) as err:
        load_config(_write(tmp_path, text))
    assert str(err.value) == message


# ---- the generated reference ----------------------------------------------------------------

REFERENCE_OF = {"top": None, "range": "[range]", "range.origin": "[range] origin",
                "output": "[output]", "targets": "[[targets]]",
                "targets.initial": "[[targets]] initial", "sensors": "[[sensors]]",
                "sensors.site": "[[sensors]] site", "sensors.stations": "[[sensors]] stations",
                "processing": "[processing]"}


@pytest.mark.parametrize("table", [t for t in TABLES if REFERENCE_OF[t] is not None])
def test_every_accepted_key_is_in_the_reference(tmp_path: Path, table: str) -> None:
    rows = reference_table(REFERENCE_OF[table])
    assert set(rows) == set(accepted_keys(tmp_path, table))
    for name, (type_, default, _unit, _allowed, meaning) in rows.items():
        assert type_.strip() and default.strip() and meaning.strip(), (table, name)


@pytest.mark.parametrize(("cls", "title"), [
    (OutputSettings, "[output]"), (ProcessingSettings, "[processing]"),
    (SensorSettings, "[[sensors]]"), (TargetSettings, "[[targets]]"),
    (InitialState, "[[targets]] initial"), (StationSettings, "[[sensors]] stations"),
    (Geodetic, "[range] origin")])
def test_the_reference_states_each_fields_default(cls: type, title: str) -> None:
    """Each key's default cell: "required" exactly when the field has no default, "not set"
    for None, else the default written as TOML (or the declaration's words for it).
    Flattened fields (a position's keys) are checked in their own class's table."""
    cells = {k: row[1] for k, row in reference_table(title).items()}
    for f in key_fields(cls):
        decl = declaration(f)
        assert decl is not None
        if decl.flatten:
            continue
        cell = cells[f.name]
        if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            assert cell == "required", (cls, f.name, cell)
        elif decl.default_doc:
            assert cell == decl.default_doc, (cls, f.name, cell)
        elif f.default is None:
            assert cell == "not set", (cls, f.name, cell)
        else:
            value = tomllib.loads(f"x = {cell}")["x"]
            default = f.default if f.default is not dataclasses.MISSING \
                else f.default_factory()  # type: ignore[misc]
            expected = list(default) if isinstance(default, tuple) else default
            assert value == (str(expected) if isinstance(expected, Path) else expected), \
                (cls, f.name, cell)


def test_documented_processing_defaults_load_as_the_defaults(tmp_path: Path) -> None:
    """Written into a config, every documented ``[processing]`` default loads as the field's
    default (the reference tells the loader's truth)."""
    rows = reference_table("[processing]")
    stated = {k: row[1] for k, row in rows.items() if row[1] != "not set"}
    text = BASE + "".join(f"{k} = {v}\n" for k, v in stated.items())
    assert load_config(_write(tmp_path, text)).processing == ProcessingSettings()
    assert {k for k, row in rows.items() if row[1] == "not set"} == {
        f.name for f in dataclasses.fields(ProcessingSettings) if f.default is None}


def test_documented_output_defaults_load_as_the_defaults(tmp_path: Path) -> None:
    rows = reference_table("[output]")
    stated = "".join(f"{k} = {row[1]}\n" for k, row in rows.items() if row[1] != "not set")
    text = BASE.replace('[output]\ndir = "out"\n', "[output]\n" + stated)
    assert load_config(_write(tmp_path, text)).output == OutputSettings(
        dir=(tmp_path / "out").resolve())


def test_the_reference_gives_units_bounds_and_allowed_values() -> None:
    processing = reference_table("[processing]")
    assert processing["max_gap"][2] == "s" and processing["max_gap"][3] == "[0.001, 1e+07]"
    assert processing["gate_probability"][3] == "[0.5, 1)"
    assert processing["filter"][3].startswith('"auto", "ekf", "ukf", "stukf"')
    assert reference_table("[[sensors]]")["angle_unit"][3] == '"deg", "rad", "mil"'
