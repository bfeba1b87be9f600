"""The config reference (``docs/config.md``), generated from the settings' declarations.

Every table of a run's TOML config, every key with its type, default, unit, allowed values or
bounds and meaning, read from the settings dataclasses' fields (``rangeproc.settings``,
``rangeproc.keys``): the same declarations the loader checks against, so the page cannot
list a key the loader refuses or miss one it accepts. The docs build serves it through the
MkDocs hook ``docs/hooks/config_reference.py``; ``python -m rangeproc.config_reference [FILE]``
prints it (or writes FILE).
"""
from __future__ import annotations

import dataclasses
import sys
import typing
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from rangeproc.keys import (Key, allowed_values, declaration, field_types, key_fields, nested,
                            optional_of, toml_keys)
from rangeproc.settings import (
    ANGLE_COMPONENTS,
    CALIBRATION_BY_KIND,
    DEFAULT_SIGMAS,
    Config,
    OutputSettings,
    ProcessingSettings,
    SensorSettings,
    TargetSettings,
)

#: The config's top-level tables: (heading, settings class, what it is).
SECTIONS = (
    ("[output]", OutputSettings, "Where and how the products are written; optional, every key "
     "has a default."),
    ("[[targets]]", TargetSettings, "The tracked objects with an id, one entry each; optional "
     '(by default the targets the gps and mistram sensors name, else one target "T1").'),
    ("[[sensors]]", SensorSettings, "One entry per sensor, at least one."),
    ("[processing]", ProcessingSettings, "rangeproc's own processing choices; optional, every "
     "key has a working default."),
)

_TYPE_NAMES = {float: "number", int: "integer", bool: "boolean", str: "string",
               Path: "string (path)"}


@dataclasses.dataclass(frozen=True, slots=True)
class Row:
    """One key of a table: TOML name, type, default, unit, allowed values or bounds, meaning
    (the cells as they are written)."""

    key: str
    type: str
    default: str
    unit: str
    allowed: str
    meaning: str


def toml_value(value: Any) -> str:
    """A default as TOML writes it (``true``, ``"ekf"``, ``[1, 1, 1]``, ``5e+07``)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (str, Path)):
        return f'"{value}"'
    if isinstance(value, float):
        text = f"{value:g}"
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return str(value)


def type_name(tp: Any, decl: Key) -> str:
    """The TOML type of a field of resolved type ``tp``, in words."""
    if decl.toml:
        return decl.toml
    tp = optional_of(tp)
    if tp in _TYPE_NAMES:
        return _TYPE_NAMES[tp]
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if dataclasses.is_dataclass(tp):
        return "table"
    if origin is tuple and len(args) == 2 and args[1] is Ellipsis:
        if dataclasses.is_dataclass(args[0]):
            return "array of tables"
        return f"array of {_TYPE_NAMES.get(args[0], 'value')}s"
    if origin is tuple:
        return f"array of {len(args)} {_TYPE_NAMES.get(args[0], 'value')}s"
    if origin in (Mapping, dict) or tp is Mapping:
        return "table of numbers"
    return str(tp)


def default_text(f: dataclasses.Field, decl: Key) -> str:
    """The default of a key as the reference writes it ("required" when it has none)."""
    if decl.default_doc:
        return decl.default_doc
    if f.default is not dataclasses.MISSING:
        return "not set" if f.default is None else toml_value(f.default)
    if f.default_factory is not dataclasses.MISSING:
        return toml_value(f.default_factory())
    return "required"


def limits_text(decl: Key) -> str:
    """Allowed values or plausibility bounds, as written in the reference."""
    allowed = allowed_values(decl)
    if allowed:
        return ", ".join(f'"{a}"' for a in allowed)
    parts = []
    if decl.positive:
        parts.append("> 0")
    if decl.bounds is not None:
        lo, hi = decl.bounds
        close = ")" if decl.half_open else "]"
        parts.append(f"[{lo:g}, {hi:g}{close}")
    text = "; ".join(parts)
    return f"each {text}" if text and decl.parts else text


def rows(cls: type) -> Iterator[Row]:
    """The reference rows of settings class ``cls``' table: one per TOML key, flattened
    fields expanded in their place (a position's lat, lon, height; a velocity's ve, vn, vu)."""
    types = field_types(cls)
    for f in key_fields(cls):
        decl = declaration(f)
        assert decl is not None
        sub = nested(cls, f)
        if decl.flatten and sub is not None:
            for row in rows(sub):
                yield dataclasses.replace(row, meaning=f"{decl.doc.rstrip('.')}: "
                                          f"{row.meaning[:1].lower()}{row.meaning[1:]}")
        elif decl.flatten:
            defaults = f.default if f.default is not dataclasses.MISSING else ()
            for i, part in enumerate(decl.parts):
                default = toml_value(defaults[i]) if i < len(defaults) else "required"
                yield Row(part, _TYPE_NAMES[typing.get_args(types[f.name])[i]], default,
                          decl.unit, limits_text(dataclasses.replace(decl, parts=())),
                          f"{decl.doc.rstrip('.')}: item {i + 1} of {', '.join(decl.parts)}.")
        else:
            yield Row(f.name, type_name(types[f.name], decl), default_text(f, decl), decl.unit,
                      limits_text(decl), decl.doc + (f" Items: {', '.join(decl.parts)}."
                                                     if decl.parts else ""))


def tables() -> Iterator[tuple[str, str, list[Row]]]:
    """Every table of the config: (heading, what it is, rows), the top-level sections first,
    then the tables they hold (each settings class once, headed by every key that holds it)."""
    in_range = toml_keys(Config, "range")
    yield "[range]", "The range; required.", [r for r in rows(Config) if r.key in in_range]
    holders: dict[type, list[str]] = {}
    sub_order: list[type] = []
    walk = [(f"[range] {f.name}", nested(Config, f)) for f in key_fields(Config)
            if f.name in in_range]
    for heading, cls, what in SECTIONS:
        yield heading, what, list(rows(cls))
        for f in key_fields(cls):
            decl = declaration(f)
            sub = nested(cls, f)
            if sub is not None and decl is not None and not decl.flatten:
                walk.append((f"{heading} {f.name}", sub))
    while walk:
        where, cls = walk.pop(0)
        if cls is None:
            continue
        if cls not in holders:
            holders[cls] = []
            sub_order.append(cls)
            for f in key_fields(cls):
                decl = declaration(f)
                sub = nested(cls, f)
                if sub is not None and decl is not None and not decl.flatten:
                    walk.append((f"{where} {f.name}", sub))
        holders[cls].append(where)
    for cls in sub_order:
        doc = " ".join((cls.__doc__ or "").strip().split("\n\n")[0].split())
        yield ", ".join(f"`{w}`" for w in holders[cls]), doc, list(rows(cls))


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") or " "


def _markdown_table(header: tuple[str, ...], body: list[tuple[str, ...]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in body]
    return lines


def config_reference_markdown() -> str:
    """The config reference page (Markdown): one table per config table, every key with its
    type, default, unit, allowed values or bounds and meaning, then the per-kind defaults of
    ``sigma`` and the calibration terms of ``calibrate`` and ``calibration``."""
    out = [
        "# Config reference",
        "",
        "<!-- Generated from the settings' declarations (rangeproc/settings.py) by "
        "rangeproc.config_reference; edit the declarations, not this page. -->",
        "",
        "A run's config is one TOML file (`rangeproc run CONFIG`). Every key below is declared "
        "once, as a field of the settings in `rangeproc/settings.py`; the loader accepts "
        "exactly these keys, checks them as listed here, and names the file and the dotted "
        "key in every error (`flight.toml: processing.max_gap: ...`, exit status 2). Units "
        "are SI (m, s, m/s) except degrees of latitude and longitude and the angles in a "
        "sensor's `angle_unit`.",
        "",
    ]
    header = ("Key", "Type", "Default", "Unit", "Allowed / bounds", "Meaning")
    for heading, what, body in tables():
        title = heading if heading.startswith("`") else f"`{heading}`"
        out += [f"## {title}", "", what, ""]
        out += _markdown_table(header, [(f"`{r.key}`", r.type, r.default, r.unit, r.allowed,
                                         r.meaning) for r in body])
        out.append("")
    out += ["## Default sigmas by sensor kind", "",
            "What `[[sensors]] sigma` holds for a component it does not state (SI: m, m/s; "
            "angles in rad, whatever the sensor's `angle_unit`).", ""]
    out += _markdown_table(("Kind", "Component", "Default 1-sigma", "Unit"), [
        (kind, f"`{name}`", f"{value:g}", "rad" if name in ANGLE_COMPONENTS else
         ("m/s" if "velocity" in name or name == "range_rate" else "m"))
        for kind, sigmas in DEFAULT_SIGMAS.items() for name, value in sigmas.items()])
    out += ["", "## Calibration terms by sensor kind", "",
            "The terms `[[sensors]] calibrate` may list (`true`: all of them) and "
            "`calibration` may state (all but `latency`); the mount terms only for a sensor "
            "on a platform.", ""]
    out += _markdown_table(("Kind", "Terms"), [
        (kind, ", ".join(f"`{n}`" for n in names) or "none")
        for kind, names in CALIBRATION_BY_KIND.items()])
    out.append("")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    """``python -m rangeproc.config_reference [FILE]``: print the page, or write FILE."""
    args = sys.argv[1:] if argv is None else argv
    text = config_reference_markdown()
    if args:
        Path(args[0]).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
