"""Config keys declared once: a settings dataclass field carries its key's declaration.

A field of a settings dataclass (``rangeproc.settings``) is declared with :func:`key`: its
default, and in ``metadata`` a :class:`Key` with the meaning, unit, allowed values or
plausibility bounds, and (for values beyond the generic checks) the name of the loader's parser.
Everything else is computed from ``dataclasses.fields``: the loader's known keys of a table
(:func:`toml_keys`), its checks and one-line messages (``config_checks.ValueChecks.declared``),
and the generated config reference (``rangeproc.config_reference``). Adding a key is adding a
field; :func:`declaration_problems` (run by the tests over every settings class) refuses one
without a meaning.
"""
from __future__ import annotations

import dataclasses
import importlib
import types
import typing
from functools import cache
from pathlib import Path
from typing import Any

#: The ``metadata`` entry of a declared field.
KEY = "rangeproc.key"


@dataclasses.dataclass(frozen=True, kw_only=True, slots=True)
class Key:
    """The declaration of one config key (beside its field's name, type and default).

    doc: its meaning (one or more sentences; required).
    unit: SI unit of the value ("" for none), as the messages and the reference write it.
    allowed: the strings it may be (a string key), or the items it may list;
        ``allowed_from``: instead, the ``"module:NAME"`` of the tuple that lists them, where
        the module that acts on the value owns that list (read by :func:`allowed_values`).
    what: the noun of the unknown-value message (``unknown filter 'x' (expected one of: ...)``).
    bounds: plausibility bounds ``(lo, hi)`` of a number, inclusive unless ``half_open``
        (``[lo, hi)``, a probability); ``positive``: ``> 0`` is checked (and said) first.
    parts: names of the items of a fixed-length array (``[position, velocity, ...]``), or of
        the separate keys it is read from when ``flatten``.
    flatten: the field's keys (a dataclass's, or ``parts``) sit directly in the enclosing table.
    table: the TOML table the key sits in when not its dataclass's own (``range`` for
        ``Config.origin``).
    parse: the loader's parser (``config._Validator.parse_<parse>``) for a value the generic
        checks of the field's type do not cover; it keeps its own messages.
    toml: the value's TOML type in words when the field's annotation does not say it.
    default_doc: the default in words when the field's default is not what a config gets.
    in_toml: False for a field that is no config key (derived by the loader, e.g. the config
        file's path); it still carries a meaning.
    """

    doc: str
    unit: str = ""
    allowed: tuple[str, ...] = ()
    allowed_from: str = ""
    what: str = "value"
    bounds: tuple[float, float] | None = None
    half_open: bool = False
    positive: bool = False
    parts: tuple[str, ...] = ()
    flatten: bool = False
    table: str = ""
    parse: str = ""
    toml: str = ""
    default_doc: str = ""
    in_toml: bool = True


def key(default: Any = dataclasses.MISSING, *, doc: str,
        factory: Any = dataclasses.MISSING, **declaration: Any) -> Any:
    """A settings field declaring a config key: ``default`` (or ``factory`` for a mutable
    one; neither: the key is required) and its :class:`Key` (``doc`` and the rest)."""
    meta = {KEY: Key(doc=doc, **declaration)}
    if factory is not dataclasses.MISSING:
        return dataclasses.field(default_factory=factory, metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def derived(doc: str, default: Any = dataclasses.MISSING) -> Any:
    """A settings field that is no config key (the loader derives it), with its meaning."""
    return key(default, doc=doc, in_toml=False)


def declaration(f: dataclasses.Field) -> Key | None:
    """The :class:`Key` of a field (None: undeclared)."""
    return f.metadata.get(KEY)


def declared(cls: type, name: str) -> Key:
    """The declaration of field ``name`` of settings class ``cls``."""
    decl = declaration(next(f for f in dataclasses.fields(cls) if f.name == name))
    if decl is None:
        raise LookupError(f"{cls.__name__}.{name} is not declared with rangeproc.keys.key")
    return decl


def key_fields(cls: type) -> tuple[dataclasses.Field, ...]:
    """The fields of ``cls`` that are config keys, in declaration order."""
    return tuple(f for f in dataclasses.fields(cls)
                 if (d := declaration(f)) is not None and d.in_toml)


def allowed_values(decl: Key) -> tuple[str, ...]:
    """The values a key may take (or its array list): ``allowed``, else the tuple named by
    ``allowed_from`` (imported when asked: the owner may be heavier than the settings)."""
    if decl.allowed or not decl.allowed_from:
        return decl.allowed
    module, name = decl.allowed_from.split(":")
    return tuple(getattr(importlib.import_module(module), name))


@cache
def field_types(cls: type) -> dict[str, Any]:
    """The resolved annotations of ``cls``' fields (``from __future__`` strings evaluated)."""
    return typing.get_type_hints(cls)


def optional_of(tp: Any) -> Any:
    """``X`` of ``X | None``; ``tp`` itself otherwise."""
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) == 1:
            return args[0]
    return tp


def nested(cls: type, f: dataclasses.Field) -> type | None:
    """The settings dataclass a field holds (itself, optional, or a tuple of them), or None."""
    tp = optional_of(field_types(cls)[f.name])
    if typing.get_origin(tp) is tuple:
        args = typing.get_args(tp)
        tp = args[0] if len(args) == 2 and args[1] is Ellipsis else None
    return tp if isinstance(tp, type) and dataclasses.is_dataclass(tp) else None


def toml_keys(cls: type, table: str = "") -> tuple[str, ...]:
    """The TOML keys of ``cls``' table, in declaration order: its key fields (those of
    ``table``, when given: keys grouped in a sub-table such as ``[range]``), the keys of
    flattened fields in their place, and a sub-table's name once for its grouped keys."""
    out: dict[str, None] = {}
    for f in key_fields(cls):
        d = declaration(f)
        assert d is not None
        if table:
            if d.table == table:
                out[f.name] = None
        elif d.table:
            out[d.table] = None
        elif d.flatten:
            sub = nested(cls, f)
            out.update(dict.fromkeys(toml_keys(sub) if sub is not None else d.parts))
        else:
            out[f.name] = None
    return tuple(out)


#: Field types the loader checks without a parser (``config_checks.ValueChecks.declared``).
GENERIC_TYPES = (float, int, bool, str)


def generic(tp: Any, decl: Key) -> bool:
    """Whether a value of resolved type ``tp`` is checked by the generic checks."""
    tp = optional_of(tp)
    if tp in GENERIC_TYPES or tp is Path:
        return True
    args = typing.get_args(tp)
    return (typing.get_origin(tp) is tuple and bool(decl.parts) and not decl.flatten
            and len(args) == len(decl.parts) and all(a is float for a in args))


def declaration_problems(cls: type) -> list[str]:
    """What is wrong with the declarations of settings class ``cls`` and the classes it holds:
    a field not declared with :func:`key`/:func:`derived`, one without a meaning, a key whose
    type the generic checks do not cover and that names no parser, allowed values on a
    non-string, bounds on a non-number. Empty when all is well."""
    problems: list[str] = []
    for f in dataclasses.fields(cls):
        where = f"{cls.__name__}.{f.name}"
        d = declaration(f)
        if d is None:
            problems.append(f"{where}: not declared (use rangeproc.keys.key or derived)")
            continue
        if not d.doc.strip():
            problems.append(f"{where}: declared without a meaning (doc)")
        sub = nested(cls, f)
        if sub is not None:
            problems.extend(declaration_problems(sub))
        if not d.in_toml or sub is not None or d.parse or d.flatten:
            continue
        tp = optional_of(field_types(cls)[f.name])
        if not generic(tp, d):
            problems.append(f"{where}: type {tp} needs a parser (parse=...)")
        if (d.allowed or d.allowed_from) and tp is not str:
            problems.append(f"{where}: allowed values on a non-string (use a parser)")
        if (d.bounds or d.positive) and tp not in (float, int) and not d.parts:
            problems.append(f"{where}: bounds on a non-number")
    return list(dict.fromkeys(problems))

