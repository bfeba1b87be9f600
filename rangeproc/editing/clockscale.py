"""Which clock scale a sensor's time stamps are on, and the offset that aligns two scales.

Range logs come stamped on different scales: ISO-8601 UTC (read as Unix seconds), float Unix
seconds, seconds of the UTC day, or GPS seconds of the week. A sensor on another scale than the
rest never overlaps them in time; :func:`scale_hint` names both scales and the ``time_offset``
that would put the sensor on the others' scale (data contract section 1: the offset is added
to the stamps, and may be given as an ISO date or instant).

Scales are recognised from the stamps' values alone (:func:`clock_scale`):

* Unix: 1e8 s (1973-03-03) to 2100-01-01 (``rangeproc.timescale.UNIX_RANGE``, the rule the
  outputs' calendar follows); shown with its UTC date and time.
* seconds of day: 0 to 90,000 s (a day plus an hour for flights that cross midnight).
* GPS seconds of week: 0 to 604,800 s, beyond a day.

GPS time runs ahead of UTC by the leap seconds since 1980 (:data:`GPS_UTC_LEAP_S`, 18 s since
2017-01-01); GPS seconds of week are aligned with UTC by the week's start less that.
"""
from __future__ import annotations

import datetime as dt
import math

import numpy as np

from rangeproc.timescale import on_unix_scale

DAY = 86400.0                         #: s
WEEK = 7 * DAY                        #: s
SOD_MAX = DAY + 3600.0                #: s, seconds of day of a flight crossing midnight
GPS_EPOCH_UNIX = 315964800.0          #: s, 1980-01-06T00:00:00Z, start of GPS week 0
GPS_UTC_LEAP_S = 18.0                 #: s, GPS minus UTC since 2017-01-01


def clock_scale(t: np.ndarray) -> str:
    """"unix", "day" (seconds of day), "week" (GPS seconds of week) or "unknown" for stamps
    ``t`` (s), judged from their first and last values."""
    lo, hi = float(np.min(t)), float(np.max(t))
    if on_unix_scale(lo, hi):
        return "unix"
    if 0.0 <= lo and hi <= SOD_MAX:
        return "day"
    if 0.0 <= lo and hi <= WEEK:
        return "week"
    return "unknown"


def utc(seconds: float) -> dt.datetime:
    """The UTC instant of Unix time ``seconds``."""
    return dt.datetime.fromtimestamp(seconds, dt.timezone.utc)


def describe_scale(t: np.ndarray) -> str:
    """The scale of stamps ``t`` in words, e.g. 'Unix time (UTC 2026-05-11 14:00:00)'."""
    scale = clock_scale(t)
    if scale == "unix":
        return f"Unix time (UTC {utc(float(np.min(t))):%Y-%m-%d %H:%M:%S})"
    if scale == "day":
        return "seconds of day (or of the GPS week)"
    if scale == "week":
        return "GPS seconds of week"
    return "an unrecognised scale"


def _gps_week_start_unix(unix: float) -> float:
    """Unix time of the start (GPS time) of the GPS week holding Unix instant ``unix``."""
    week = math.floor((unix + GPS_UTC_LEAP_S - GPS_EPOCH_UNIX) / WEEK)
    return GPS_EPOCH_UNIX + week * WEEK


def aligning_offset(t: np.ndarray, ref: np.ndarray) -> tuple[float, str] | None:
    """The ``time_offset`` (s) that puts stamps ``t`` on the scale of ``ref``, with the
    config text to write (an ISO date where that is what the offset means); None when the
    scales are not two different recognised ones."""
    mine, theirs = clock_scale(t), clock_scale(ref)
    if mine == theirs or "unknown" in (mine, theirs):
        return None
    ref_start = float(np.min(ref))
    t_start = float(np.min(t))
    if theirs == "unix":
        if mine == "day":
            day = utc(ref_start).date()
            offset = dt.datetime(day.year, day.month, day.day, tzinfo=dt.timezone.utc).timestamp()
            return offset, f'time_offset = "{day.isoformat()}"'
        offset = _gps_week_start_unix(ref_start) - GPS_UTC_LEAP_S
        return offset, (f"time_offset = {offset:.1f} (the GPS week starting "
                        f"{utc(offset + GPS_UTC_LEAP_S):%Y-%m-%d}, less {GPS_UTC_LEAP_S:g} leap "
                        "seconds)")
    if mine == "unix":
        back = aligning_offset(ref, t)
        if back is None:
            return None
        return -back[0], f"time_offset = {-back[0]:.1f}"
    if mine == "day" and theirs == "week":      # UTC seconds of day onto GPS seconds of week
        offset = math.floor(ref_start / DAY) * DAY + GPS_UTC_LEAP_S
        return offset, f"time_offset = {offset:.1f}"
    offset = -(math.floor(t_start / DAY) * DAY + GPS_UTC_LEAP_S)    # week onto day
    return offset, f"time_offset = {offset:.1f}"


def scale_hint(t: np.ndarray, ref: np.ndarray) -> str:
    """A clause naming the scales of ``t`` and ``ref`` and the offset that aligns them, or
    '' when the scales look alike."""
    found = aligning_offset(t, ref)
    if found is None:
        return ""
    return (f"its stamps are {describe_scale(t)}, the others' {describe_scale(ref)}: "
            f"{found[1]} would align them")


#: Sub-second units a time column is sometimes written in, with their seconds.
SUBUNITS = (("milliseconds", 1e-3), ("microseconds", 1e-6), ("nanoseconds", 1e-9))


def subunit_hint(raw: np.ndarray) -> str:
    """': they look like Unix milliseconds (UTC ...): time must be in seconds' when stamps
    ``raw`` (s as read, before any offset) are Unix time in a sub-second unit, else ''."""
    lo, hi = float(np.min(raw)), float(np.max(raw))
    for name, factor in SUBUNITS:
        if on_unix_scale(lo * factor, hi * factor):
            start = f"{utc(lo * factor):%Y-%m-%d %H:%M:%S}"
            return (f": they look like Unix {name} (from UTC {start}); the time column must be "
                    "in seconds")
    return ""


def sign_hint(t: np.ndarray, offset: float, ref: np.ndarray, margin: float) -> str:
    """A clause saying the sensor's ``time_offset`` has the wrong sign when stamps ``t``
    (offset applied) would come within ``margin`` (s) of ``ref`` with the opposite sign, else
    ''."""
    if offset == 0.0:
        return ""
    flipped = t - 2.0 * offset
    if float(np.min(flipped)) - margin <= float(np.max(ref)) and \
            float(np.max(flipped)) + margin >= float(np.min(ref)):
        return f"time_offset = {-offset!r} (the other sign) would align them"
    return ""
