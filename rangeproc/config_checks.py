"""Checks of single config values: each returns the value or raises a one-line ConfigError.

:class:`ValueChecks` holds the primitive checks (a table with known keys, a required key, a
finite number, a bounded one, a probability, a boolean, a non-empty string, an array, unique
ids), and :meth:`ValueChecks.declared`, which checks a value as its settings field's
declaration says (``rangeproc.keys``); ``rangeproc.config`` builds the config's sections on them.
Messages name the config file and the dotted key, e.g.
``flight.toml: sensors[2].sigma.range: must be > 0, got -1``.
"""
from __future__ import annotations

import datetime as dt
import math
import re
import typing
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from rangeproc.errors import ConfigError
from rangeproc.keys import Key, optional_of


def toml_syntax_error(name: str, exc: Exception) -> ConfigError:
    """The one-line ConfigError of a TOML syntax error in file ``name`` (line and column)."""
    msg = " ".join(str(exc).split())
    m = re.fullmatch(r"(.*) \(at line (\d+), column (\d+)\)", msg)
    if m:
        return ConfigError(
            f"{name}: line {m.group(2)}, column {m.group(3)}: invalid TOML: {m.group(1)}")
    return ConfigError(f"{name}: invalid TOML: {msg}")


def is_number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def type_name(x: object) -> str:
    names = {bool: "a boolean", str: "a string", int: "an integer", float: "a number",
             dict: "a table", list: "an array"}
    return names.get(type(x), f"a {type(x).__name__}")


def show_value(x: object) -> str:
    """A TOML-looking rendering of a value for messages."""
    if isinstance(x, bool):
        return "true" if x else "false"
    return repr(x)


def a_kind(kind: str) -> str:
    """'a radar', 'an ins'."""
    return f"an {kind}" if kind[:1] in "aeiou" else f"a {kind}"


def join_names(names: Sequence[str]) -> str:
    return ", ".join(names)


class ValueChecks:
    """The primitive checks, for one config file (its name starts every message)."""

    def __init__(self, file_name: str) -> None:
        self.file_name = file_name

    def error(self, key: str, problem: str) -> ConfigError:
        where = f"{key}: " if key else ""
        return ConfigError(f"{self.file_name}: {where}{problem}")

    # ---- primitive checks ----------------------------------------------------------------
    def table(self, x: object, key: str, allowed: Sequence[str]) -> dict[str, Any]:
        if not isinstance(x, dict):
            raise self.error(key, f"expected a table, got {type_name(x)}")
        for k in x:
            if k not in allowed:
                raise self.error(f"{key}.{k}" if key else k,
                                 f"unknown key (expected one of: {join_names(allowed)})")
        return x

    def required(self, t: Mapping[str, Any], name: str, key: str) -> Any:
        if name not in t:
            raise self.error(f"{key}.{name}" if key else name, "missing required key")
        return t[name]

    def number(self, x: object, key: str) -> float:
        if not is_number(x):
            raise self.error(key, f"expected a number, got {type_name(x)} ({show_value(x)})")
        value = float(x)  # type: ignore[arg-type]
        if not math.isfinite(value):
            raise self.error(key, f"must be a finite number, got {value}")
        return value

    def positive(self, x: object, key: str) -> float:
        value = self.number(x, key)
        if value <= 0.0:
            raise self.error(key, f"must be > 0, got {value:g}")
        return value

    def probability(self, x: object, key: str, bounds: tuple[float, float]) -> float:
        """A probability in the half-open ``[lo, hi)`` of ``bounds``."""
        p = self.number(x, key)
        lo, hi = bounds
        if not lo <= p < hi:
            raise self.error(key, f"must be in [{lo:g}, {hi:g}), got {p:g}")
        return p

    def bounded(self, x: object, key: str, lo: float, hi: float, unit: str = "") -> float:
        """A number in [lo, hi] (plausibility bounds; the message gives them)."""
        value = self.number(x, key)
        if not lo <= value <= hi:
            u = f" {unit}" if unit else ""
            raise self.error(key, f"{value:g}{u} is outside the plausible range "
                                  f"[{lo:g}, {hi:g}]{u}")
        return value

    def instant(self, x: object, key: str, bound: float) -> float:
        """Seconds: a number (in [-bound, bound]), or a calendar instant as seconds from
        1970-01-01T00:00:00Z: an ISO-8601 string or TOML date-time with a UTC offset or ``Z``,
        or a date alone (an ISO ``YYYY-MM-DD`` string or TOML date: its midnight UTC)."""
        if isinstance(x, str):
            text = x.strip()
            try:
                x = (dt.date.fromisoformat(text) if len(text) == 10
                     else dt.datetime.fromisoformat(text))
            except ValueError:
                raise self.error(key, f"expected seconds or an ISO-8601 date or instant, got "
                                      f"{show_value(x)}") from None
        if isinstance(x, dt.datetime):
            if x.tzinfo is None:
                raise self.error(key, f"the instant {x.isoformat()} needs a UTC offset or 'Z' "
                                      "(e.g. 2026-05-11T00:00:00Z)")
            return x.timestamp()
        if isinstance(x, dt.date):
            return dt.datetime(x.year, x.month, x.day, tzinfo=dt.timezone.utc).timestamp()
        if isinstance(x, dt.time):
            raise self.error(key, f"a time of day ({x.isoformat()}) is not an instant: give "
                                  "seconds or a date or instant")
        return self.bounded(x, key, -bound, bound, "s")

    def integer(self, x: object, key: str, bounds: tuple[float, float] | None = None) -> int:
        """An integer (not a boolean), in ``[lo, hi]`` of ``bounds`` when given."""
        if not isinstance(x, int) or isinstance(x, bool):
            raise self.error(key, f"expected an integer, got {type_name(x)} ({show_value(x)})")
        if bounds is not None and not bounds[0] <= x <= bounds[1]:
            raise self.error(key, f"must be in [{bounds[0]:g}, {bounds[1]:g}], got {x}")
        return x

    def choice(self, x: object, key: str, allowed: Sequence[str], what: str) -> str:
        """A non-empty string, one of ``allowed`` when that is not empty."""
        s = self.string(x, key)
        if allowed and s not in allowed:
            raise self.error(key, f"unknown {what} {s!r} (expected one of: "
                                  f"{join_names(allowed)})")
        return s

    def declared(self, decl: Key, tp: Any, x: object, key: str) -> Any:
        """A value checked by its field's type ``tp`` (``X | None``: as ``X``) and
        declaration: a number (``> 0`` when ``positive``; within ``bounds``, half-open for a
        probability), an integer, a boolean, a string (one of ``allowed``), a path (relative,
        as given) or an array of ``len(parts)`` bounded numbers. Keys beyond these have a
        parser (``decl.parse``) and are not checked here."""
        tp = optional_of(tp)
        if tp is bool:
            return self.boolean(x, key)
        if tp is int:
            return self.integer(x, key, decl.bounds)
        if tp is float:
            value = self.positive(x, key) if decl.positive else self.number(x, key)
            if decl.bounds is None:
                return value
            if decl.half_open:
                return self.probability(value, key, decl.bounds)
            return self.bounded(value, key, *decl.bounds, decl.unit)
        if tp is str:
            return self.choice(x, key, decl.allowed, decl.what)
        if tp is Path:
            return Path(self.string(x, key)).expanduser()
        if typing.get_origin(tp) is tuple and decl.parts:
            n = len(decl.parts)
            if not isinstance(x, list) or len(x) != n:
                raise self.error(key, f"expected {n} numbers ({join_names(decl.parts)}), got "
                                      f"{show_value(x)}")
            lo, hi = decl.bounds if decl.bounds is not None else (-math.inf, math.inf)
            return tuple(self.bounded(v, f"{key}[{i}]", lo, hi, decl.unit)
                         for i, v in enumerate(x))
        raise TypeError(f"{key}: no generic check for {tp}; declare a parser (parse=...)")

    def boolean(self, x: object, key: str) -> bool:
        if not isinstance(x, bool):
            raise self.error(key, f"expected true or false, got {type_name(x)} ({show_value(x)})")
        return x

    def string(self, x: object, key: str) -> str:
        if not isinstance(x, str):
            raise self.error(key, f"expected a string, got {type_name(x)} ({show_value(x)})")
        if not x.strip():
            raise self.error(key, "must not be empty")
        return x

    def array(self, x: object, key: str) -> list[Any]:
        if not isinstance(x, list):
            raise self.error(key, f"expected an array, got {type_name(x)}")
        return x

    def unique_ids(self, ids: Sequence[str], key_of: Callable[[int], str], what: str) -> None:
        seen: dict[str, int] = {}
        for i, ident in enumerate(ids):
            if ident in seen:
                raise self.error(key_of(i),
                                 f"duplicate {what} id '{ident}' (also {key_of(seen[ident])})")
            seen[ident] = i
