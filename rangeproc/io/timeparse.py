"""Cell parsing for the readers: Arrow columns -> float64 numbers and time in seconds.

Every function here is vectorised over a whole column (pyarrow compute kernels); when a column
holds a bad cell, :class:`CellError` gives the 0-based position of the *first* bad cell and a
short problem text, and the reader turns it into a one-line ``DataError`` naming file, row and
column. Nothing here knows file names.

Time conventions (data contract section 1): a time column holds float seconds on the range
time scale, or ISO-8601 strings with an explicit UTC offset or ``Z``, converted to float
seconds since 1970-01-01T00:00:00Z (float64 keeps ~0.2 µs at 1.7e9 s). One column uses one
form. A null (empty cell) is an error: time is required.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import TypeAlias

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

# Number text accepted by Arrow's float parser, after trimming whitespace.
_NUMBER_RE = r"^[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?$"
_NONFINITE_RE = r"(?i)^[+-]?(nan|inf|infinity)$"
_ISO_ZONED_RE = (r"^[0-9]{4}-[0-9]{2}-[0-9]{2}[T ][0-9]{2}:[0-9]{2}(:[0-9]{2}(\.[0-9]+)?)?"
                 r"(Z|[+-][0-9]{2}(:?[0-9]{2})?)$")
_ISO_NAIVE_RE = r"^[0-9]{4}-[0-9]{2}-[0-9]{2}([T ][0-9]{2}:[0-9]{2}(:[0-9]{2}(\.[0-9]+)?)?)?$"

Column: TypeAlias = "pa.Array | pa.ChunkedArray"


class CellError(Exception):
    """A bad cell: ``index`` is its 0-based position in the column (None: the whole column)."""

    def __init__(self, index: int | None, problem: str) -> None:
        super().__init__(problem)
        self.index = index
        self.problem = problem


def _first(mask: Column) -> int:
    """0-based index of the first True in a boolean column (nulls count as False), or -1."""
    return int(pc.index(mask, True).as_py())


def _quote(value: object) -> str:
    text = str(value)
    return repr(text if len(text) <= 40 else text[:37] + "...")


def first_failing(arr: Column, fn: Callable[[Column], object]) -> int:
    """Index of the first element on which ``fn`` raises ``ArrowInvalid`` (bisection).

    ``fn`` must raise on ``arr`` as a whole; costs about two passes over ``arr``.
    """
    lo, hi = 0, len(arr)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            fn(arr.slice(lo, mid - lo))
        except pa.ArrowInvalid:
            hi = mid
        else:
            lo = mid
    return lo


def clean_strings(col: Column) -> Column:
    """Text column -> trimmed strings; empty or whitespace-only cells become null."""
    if not pa.types.is_string(col.type):
        col = pc.cast(col, pa.string())
    col = pc.utf8_trim_whitespace(col)
    return pc.if_else(pc.equal(col, ""), pa.scalar(None, pa.string()), col)


def _raise_nonfinite(values: Column, text: Column | None, what: str) -> None:
    """CellError at the first NaN/±inf value of a float column (quoting ``text`` if given)."""
    i = _first(pc.or_(pc.is_nan(values), pc.is_inf(values)))
    if i >= 0:
        shown = (text if text is not None else values)[i].as_py()
        raise CellError(i, f"{_quote(shown)} is not a finite {what}")


def check_finite(arr: Column, what: str = "number") -> None:
    """Raise CellError at the first NaN or ±inf *value* (nulls are fine: not measured)."""
    if pa.types.is_floating(arr.type):
        _raise_nonfinite(arr, None, what)


def _try_float(s: Column, what: str) -> Column | None:
    """Cast text to float64 as a whole; None if any cell does not parse."""
    try:
        out = pc.cast(s, pa.float64())
    except pa.ArrowInvalid:
        return None
    _raise_nonfinite(out, s, what)
    return out


def strings_to_float(col: Column, what: str = "number") -> Column:
    """Text column -> float64 (null where empty); CellError at the first bad/non-finite cell."""
    out = _try_float(col, what)  # the raw text first: the common, fast case
    if out is not None:
        return out
    s = clean_strings(col)
    out = _try_float(s, what)
    if out is not None:
        return out
    ok = pc.match_substring_regex(s, _NUMBER_RE)
    i = _first(pc.invert(ok))
    if i >= 0:
        text = s[i].as_py()
        if _matches(text, _NONFINITE_RE):
            raise CellError(i, f"{_quote(text)} is not a finite {what}")
        raise CellError(i, f"{_quote(text)} is not a {what}")
    i = first_failing(s, lambda a: pc.cast(a, pa.float64()))
    raise CellError(i, f"{_quote(s[i].as_py())} is not a {what}")


def _matches(text: str, pattern: str) -> bool:
    """One string against an RE2 pattern (same engine as the vectorised checks)."""
    return bool(pc.match_substring_regex(pa.array([text]), pattern)[0].as_py())


def to_float(col: Column, what: str = "number") -> Column:
    """Any numeric or text column -> finite float64 array with nulls (see module docstring)."""
    t = col.type
    if pa.types.is_null(t):
        return pa.nulls(len(col), pa.float64())
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        out = strings_to_float(col, what)
    elif pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_decimal(t):
        out = pc.cast(col, pa.float64())
    else:
        raise CellError(None, f"has type {t}, expected numbers")
    check_finite(out, what)
    return out


def _check_no_nulls(arr: Column) -> None:
    """CellError at the first null (empty cell): time is required."""
    if arr.null_count:
        raise CellError(_first(pc.is_null(arr)), "empty (time is required)")


def timestamps_to_seconds(arr: Column) -> np.ndarray:
    """Timezone-aware Arrow timestamps (no nulls) -> float64 seconds since the Unix epoch.

    Split into whole seconds and the fraction so that no precision is lost before the final
    float64 rounding.
    """
    per_s = {"s": 1, "ms": 1_000, "us": 1_000_000, "ns": 1_000_000_000}[arr.type.unit]
    ticks = pc.cast(arr, pa.int64()).to_numpy(zero_copy_only=False)
    whole, frac = np.divmod(ticks, per_s)
    return whole.astype(np.float64) + frac.astype(np.float64) / per_s


def _iso_to_seconds(s: Column) -> np.ndarray:
    """Trimmed, null-free ISO-8601 text -> seconds since the epoch; CellError on bad cells."""
    s = pc.utf8_upper(s)  # 't' / 'z' are valid ISO-8601 but Arrow wants upper case
    s = pc.replace_substring_regex(s, r"\s+(Z|[+-][0-9]{2}(:?[0-9]{2})?)$", r"\1")
    i = _first(pc.invert(pc.match_substring_regex(s, _ISO_ZONED_RE)))
    if i >= 0:
        text = s[i].as_py()
        if _matches(text, _ISO_NAIVE_RE):
            raise CellError(i, f"ISO-8601 time {_quote(text)} has no UTC offset or 'Z'")
        raise CellError(i, f"{_quote(text)} is not a number or an ISO-8601 time")
    ts_type = pa.timestamp("ns", tz="UTC")
    try:
        ts = pc.cast(s, ts_type)
    except pa.ArrowInvalid:
        i = first_failing(s, lambda a: pc.cast(a, ts_type))
        raise CellError(i, f"{_quote(s[i].as_py())} is not a valid ISO-8601 time") from None
    return timestamps_to_seconds(ts)


def _fast_text_time(s: Column) -> np.ndarray | None:
    """Whole column as numbers, or as zoned ISO-8601 text; None if neither parses as a whole."""
    try:
        out = pc.cast(s, pa.float64())
    except pa.ArrowInvalid:
        pass
    else:
        _raise_nonfinite(out, s, "time")
        return out.to_numpy(zero_copy_only=False)
    try:
        return timestamps_to_seconds(pc.cast(s, pa.timestamp("ns", tz="UTC")))
    except pa.ArrowInvalid:
        return None


def _text_time_to_seconds(col: Column) -> np.ndarray:
    _check_no_nulls(col)
    out = _fast_text_time(col)
    if out is not None:
        return out
    s = clean_strings(col)
    _check_no_nulls(s)
    # Slow path: classify every cell to report the first bad one (or accept lower-case 't'/'z'
    # and a space before the offset, which Arrow's parser rejects).
    numeric = pc.or_(pc.match_substring_regex(s, _NUMBER_RE),
                     pc.match_substring_regex(s, _NONFINITE_RE))
    first_numeric = bool(numeric[0].as_py())
    i = _first(pc.invert(numeric) if first_numeric else numeric)
    if i >= 0 and first_numeric:
        text = s[i].as_py()
        if _matches(text, _ISO_NAIVE_RE + "|" + _ISO_ZONED_RE):
            raise CellError(i, f"{_quote(text)} is ISO-8601 text but earlier times are "
                               "numbers (use one form per column)")
        raise CellError(i, f"{_quote(text)} is not a number")
    if i >= 0:
        raise CellError(i, f"{_quote(s[i].as_py())} is a number but earlier times are "
                           "ISO-8601 text (use one form per column)")
    if first_numeric:
        return strings_to_float(s, "time").to_numpy(zero_copy_only=False)
    return _iso_to_seconds(s)


def time_to_seconds(col: Column) -> np.ndarray:
    """A time column (float/int seconds, ISO-8601 text, or Arrow timestamps) -> (N,) float64 s.

    Raises CellError on the first empty cell, non-finite value, unparsable text, ISO-8601 text
    without a UTC offset, a mix of numbers and ISO text, or (Parquet) a timestamp type without
    a time zone.
    """
    t = col.type
    if len(col) == 0:
        return np.empty(0, np.float64)
    if pa.types.is_string(t) or pa.types.is_large_string(t):
        return _text_time_to_seconds(col)
    _check_no_nulls(col)
    if pa.types.is_timestamp(t):
        if t.tz is None:
            raise CellError(0, "timestamp has no time zone (store UTC-aware timestamps or "
                               "float seconds)")
        return timestamps_to_seconds(col)
    if pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_decimal(t):
        out = pc.cast(col, pa.float64())
        check_finite(out, "time")
        return out.to_numpy(zero_copy_only=False)
    raise CellError(None, f"has type {t}, expected seconds or ISO-8601 time")
