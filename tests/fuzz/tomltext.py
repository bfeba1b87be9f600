"""Text helpers of the fuzz mutations: the TOML writer, config key paths, and the small
text and number formatting helpers of operations and their descriptions.

The config is parsed with ``tomllib``, changed as a dict and written back by :func:`dump_toml`;
a :data:`Key` is a path into the parsed document. Byte positions are drawn as integers in
[0, ``POSITION_SCALE``] and mapped onto a file's length by :func:`at_fraction`.
"""
from __future__ import annotations

import datetime as dt
import math
import re
from typing import Any

Key = tuple[str | int, ...]  # a path into the parsed TOML: ("sensors", 2, "sigma", "range")
POSITION_SCALE = 1_000_000   # byte positions are drawn as k / POSITION_SCALE of the file length


# ============================================================================================
# Small helpers
# ============================================================================================

def show_key(key: Key) -> str:
    """TOML-style rendering of a key path: ``sensors[2].sigma.range``."""
    out = ""
    for part in key:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def short(value: object, limit: int = 40) -> str:
    """``repr`` of a value cut to ``limit`` characters (for descriptions)."""
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit - 8]}...({len(text)} chars)"


def fmt_float(x: float) -> str:
    """Float -> CSV text with full precision (shortest round-trip repr; 'nan', 'inf')."""
    return repr(float(x))


def as_float(cell: Any) -> float | None:
    """A cell (CSV text or Parquet value) as a float, or None when it is not a number."""
    if isinstance(cell, bool) or cell is None:
        return None
    if isinstance(cell, (int, float)):
        return float(cell)
    try:
        return float(str(cell).strip())
    except ValueError:
        return None


def iso_time(seconds: float, variant: str) -> str:
    """Seconds since 1970-01-01Z -> ISO-8601 text (microseconds) naming the same instant.

    ``variant``: 'Z', '+00:00', '+05:30', '-08:00' (an explicit offset), 'space' (a space
    instead of 'T', with 'Z'), 'naive' (no offset: not allowed by the contract).
    """
    utc = dt.datetime(1970, 1, 1, tzinfo=dt.timezone.utc) + dt.timedelta(seconds=seconds)
    if variant in ("Z", "space", "naive"):
        text = utc.replace(tzinfo=None).isoformat(sep=" " if variant == "space" else "T",
                                                  timespec="microseconds")
        return text if variant == "naive" else text + "Z"
    sign = -1 if variant.startswith("-") else 1
    hours, minutes = (int(p) for p in variant[1:].split(":"))
    zone = dt.timezone(sign * dt.timedelta(hours=hours, minutes=minutes))
    return utc.astimezone(zone).isoformat(timespec="microseconds")


def at_fraction(k: int, length: int) -> int:
    """Drawn position ``k`` in [0, POSITION_SCALE] -> byte index in [0, length]."""
    return min(length, k * length // POSITION_SCALE)


# ============================================================================================
# TOML writer (the config is parsed, mutated as a dict and written back)
# ============================================================================================

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_string(s: str) -> str:
    out = []
    for ch in s:
        code = ord(ch)
        if ch in '"\\':
            out.append("\\" + ch)
        elif code < 0x20 or code == 0x7F:
            out.append({"\n": "\\n", "\t": "\\t", "\r": "\\r"}.get(ch, f"\\u{code:04X}"))
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _toml_key(k: str) -> str:
    return k if _BARE_KEY.match(k) else _toml_string(k)


def toml_value(v: Any) -> str:
    """One TOML value (inline tables and arrays for nested values)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def dump_toml(doc: dict[str, Any]) -> str:
    """A parsed TOML document -> TOML text (top-level tables as ``[name]``, arrays of tables as
    ``[[name]]``, deeper values inline). ``tomllib.loads(dump_toml(d)) == d``."""
    head, body = [], []
    for k, v in doc.items():
        if isinstance(v, dict):
            body.append(f"\n[{_toml_key(k)}]")
            body += [f"{_toml_key(a)} = {toml_value(b)}" for a, b in v.items()]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for item in v:
                body.append(f"\n[[{_toml_key(k)}]]")
                body += [f"{_toml_key(a)} = {toml_value(b)}" for a, b in item.items()]
        else:
            head.append(f"{_toml_key(k)} = {toml_value(v)}")
    return "\n".join(head + body) + "\n"


def config_keys(doc: Any, prefix: Key = ()) -> list[Key]:
    """Every key path of a parsed TOML document, tables and leaves, in document order."""
    out: list[Key] = []
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) \
        else ()
    for k, v in items:
        out.append(prefix + (k,))
        out += config_keys(v, prefix + (k,))
    return out


def get_key(doc: Any, key: Key) -> Any:
    """The value at ``key`` (KeyError/IndexError/TypeError when absent)."""
    for part in key:
        doc = doc[part]
    return doc
