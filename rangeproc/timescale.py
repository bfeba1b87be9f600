"""Which calendar a run's times have: the one rule every output that shows a time follows.

Times in rangeproc are float seconds on the range's time scale (contract section 2). They are
shown as UTC clock time (``2026-05-11 14:00:00.0 UTC``) when their calendar is known, and as
seconds from the run's start (``t = 12.3 s from start``, the raw start given once) otherwise.
The calendar is known, in this order:

1. **[output] epoch** (or export's ``--epoch``) is given: it is the UTC instant of time 0 on
   the range's time scale, so a time ``t`` is ``epoch + t`` (a range on seconds of day gives
   the day's 00:00 UTC, one on GPS seconds of week the week's start).
2. **Unix scale**: every time of the run lies in :data:`UNIX_RANGE`, 1e8 s to 4102444800 s
   (1973-03-03 to 2100-01-01). ISO-8601 stamps in an input file are read as Unix seconds
   (``io.timeparse``), an ISO date or instant given as ``time_offset`` is Unix seconds too
   (``config_checks.instant``), and the time checks (``editing.timecheck``) keep the run's
   other sensors on that scale, so a run with any ISO-stamped sensor or ISO offset lands here;
   float stamps that are Unix seconds do too. Seconds of day (< 86,400), GPS seconds of week
   (< 604,800) and seconds from a start never do. Caveat: seconds counted from another
   far-past epoch (e.g. GPS seconds since 1980-01-06, about 1.4e9 in 2026) also lie in that
   range and would be shown as Unix time; give ``[output] epoch`` for them.
3. Otherwise the calendar is **unknown**.
"""
from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from rangeproc.errors import DataError
from rangeproc.summary_types import RunSummary, TimeScaleRecord

#: The epoch that makes ``time`` Unix seconds (contract section 2's ISO conversion).
UNIX_EPOCH = "1970-01-01T00:00:00Z"
#: Calendar years a viewer can show (CZML and KML use ISO 8601 with four-digit years).
YEAR_RANGE = (1900, 2200)

def parse_epoch(text: str, what: str = "--epoch") -> np.datetime64:
    """The UTC instant of time 0, from an ISO-8601 string with an explicit UTC offset or ``Z``.

    Raises DataError naming ``what`` for a string that is not such an instant."""
    try:
        stamp = pd.Timestamp(text)
    except (ValueError, TypeError) as exc:
        raise DataError(f"{what}: '{text}' is not an ISO-8601 time ({exc})") from None
    if stamp.tzinfo is None:
        raise DataError(f"{what}: '{text}' has no UTC offset (add Z or +hh:mm)")
    if not YEAR_RANGE[0] <= stamp.tz_convert("UTC").year < YEAR_RANGE[1]:
        raise DataError(f"{what}: '{text}' is outside the years {YEAR_RANGE[0]}-{YEAR_RANGE[1]}")
    return np.datetime64(stamp.tz_convert("UTC").tz_localize(None).to_datetime64(), "ns")



#: Times (s) read as Unix seconds when every time of a run lies in [lo, hi): 1973-03-03 to
#: 2100-01-01 UTC.
UNIX_RANGE = (1.0e8, 4102444800.0)

#: Where the calendar came from (``TimeScale.basis``).
BASIS_EPOCH, BASIS_UNIX, BASIS_UNKNOWN = "epoch", "unix", "unknown"


@dataclass(frozen=True, slots=True)
class TimeScale:
    """The calendar of a run's times and its start.

    zero: the UTC instant (``datetime64[ns]``) of time 0 on the range's time scale, None when
    the calendar is unknown; basis: :data:`BASIS_EPOCH` (given epoch), :data:`BASIS_UNIX`
    (times in :data:`UNIX_RANGE`) or :data:`BASIS_UNKNOWN`; start: the run's first time (s,
    range time scale; NaN when there is none).
    """

    zero: np.datetime64 | None
    basis: str
    start: float

    @property
    def known(self) -> bool:
        """True when the times have a calendar date."""
        return self.zero is not None

    def utc(self, t: float) -> np.datetime64:
        """The UTC instant of range time ``t`` (s); ValueError when the calendar is unknown."""
        if self.zero is None:
            raise ValueError("the calendar of the range's time scale is unknown")
        return self.zero + np.timedelta64(int(round(float(t) * 1e9)), "ns")

    def clock(self, t: float) -> str:
        """``t`` as '2026-05-11 14:00:00.0 UTC' (calendar known) or 't = 12.3 s from start'."""
        if self.zero is None or not np.isfinite(t):
            return relative_text(t, self.start)
        return utc_text(self.utc(t))

    def start_text(self) -> str:
        """The run's start once, in full: the UTC instant and the raw range time, or the raw
        range time with a word on the unknown calendar."""
        if not np.isfinite(self.start):
            return "no epochs"
        raw = f"{self.start:.3f} s on the range time scale"
        if self.zero is None:
            return (f"start t0 = {raw}; calendar date unknown (times shown as seconds from "
                    "start; set [output] epoch for UTC)")
        how = ("time 0 = [output] epoch" if self.basis == BASIS_EPOCH
               else "read as Unix seconds")
        return f"start {self.clock(self.start)} ({raw}, {how})"

    def as_dict(self) -> TimeScaleRecord:
        """The ``summary.json`` entry ``time_scale`` (``summary_types.TimeScaleRecord``)."""
        return {"calendar": "utc" if self.known else "unknown", "basis": self.basis,
                "epoch": None if self.zero is None else
                np.datetime_as_string(self.zero, unit="ms") + "Z",
                "t0": float(self.start) if np.isfinite(self.start) else None}


def utc_text(instant: np.datetime64) -> str:
    """'2026-05-11 14:00:00.0 UTC' (tenths of a second)."""
    rounded = np.datetime64(instant, "ns") + np.timedelta64(50, "ms")     # to 0.1 s, rounded
    text = np.datetime_as_string(np.datetime64(rounded, "ms"), unit="ms")
    return f"{text[:10]} {text[11:21]} UTC"


def relative_text(t: float, start: float) -> str:
    """'t = 12.3 s from start' (the raw time when there is no start)."""
    if not np.isfinite(start):
        return f"t = {t:.3f} s"
    return f"t = {t - start:.1f} s from start"


def on_unix_scale(lo: float, hi: float) -> bool:
    """True when the times from ``lo`` to ``hi`` (s) all lie in :data:`UNIX_RANGE`."""
    return bool(UNIX_RANGE[0] <= lo and hi < UNIX_RANGE[1])


def time_scale(times: Iterable[np.ndarray], epoch: str | None = None) -> TimeScale:
    """The calendar of a run whose times (s, range time scale) are ``times`` (arrays, any
    shape; non-finite values ignored), with ``[output] epoch`` = ``epoch`` (ISO 8601 with an
    offset; None when not given). The rule is the module's."""
    finite = [a[np.isfinite(a)] for a in (np.asarray(x, dtype=float).ravel() for x in times)]
    finite = [a for a in finite if a.size]
    lo = min((float(a.min()) for a in finite), default=float("nan"))
    hi = max((float(a.max()) for a in finite), default=float("nan"))
    if epoch is not None:
        return TimeScale(parse_epoch(epoch, "output.epoch"), BASIS_EPOCH, lo)
    if finite and on_unix_scale(lo, hi):
        return TimeScale(parse_epoch(UNIX_EPOCH), BASIS_UNIX, lo)
    return TimeScale(None, BASIS_UNKNOWN, lo)


def from_summary(summary: RunSummary | Mapping[str, Any]) -> TimeScale:
    """The run's time scale from its ``summary.json`` dictionary: its ``time_scale`` entry, or
    (an older summary) the rule applied to the objects' ``t_start`` / ``t_end``."""
    entry = summary.get("time_scale")
    if isinstance(entry, Mapping):
        t0 = entry.get("t0")
        start = float(t0) if isinstance(t0, (int, float)) else float("nan")
        epoch = entry.get("epoch")
        zero = parse_epoch(epoch) if isinstance(epoch, str) else None
        return TimeScale(zero, str(entry.get("basis", BASIS_UNKNOWN)), start)
    ends = [v for t in (summary.get("targets") or {}).values() if isinstance(t, Mapping)
            for v in (t.get("t_start"), t.get("t_end")) if isinstance(v, (int, float))]
    return time_scale([np.asarray(ends, dtype=float)])
