"""Duplicate rows and repeated time stamps, removed first of the screening checks.

Logs repeat themselves in two ways that parse perfectly:

1. **Duplicates** (reason ``duplicate``): a row whose time stamp and every loaded value (the
   measurement columns, ``track_id``, ``station``) equal an earlier file row's: a block of the
   log written twice, an export appended to itself, a detection reported twice. The earliest
   file row is kept, the copies are dropped (any kind of sensor).
2. **Repeated stamps** (reason ``repeated stamp``): rows sharing a time stamp with other
   values. One measurement series has one value per instant: a GPS receiver, an INS, one
   MISTRAM station, one radar/theodolite track (``track_id``). Rows of a radar or theodolite
   without ``track_id`` are plots, and plots of several objects may share the stamp of their
   scan; such a sensor's repeated stamps are a stuck clock only when they look like one
   (:func:`stuck_clock`): few of its rows repeat a stamp (at most
   :data:`STUCK_MAX_FRACTION`), and after each repeated stamp the clock jumps ahead by about
   the time the repeated rows took at the sensor's usual step (the clock stopped while rows
   were written and then resumed), for at least :data:`STUCK_FIT` of the repeated rows.
   The rule: the first file row of each stamp is kept (the clock stopped after stamping it)
   and the later rows are dropped; their true times are unknown, so nothing is merged.

Both are recorded in the run's :class:`~rangeproc.editing.record.EditRecord` (whole rows,
component ``*``) and said in one warning line each (:func:`repeat_lines`), with the count.
Duplicates of a plot sensor (a detection reported twice within one scan) are said only when
they are at least :data:`DUPLICATE_SAID_FRACTION` of its rows.
"""
from __future__ import annotations

from collections.abc import Iterator

import numpy as np

from rangeproc.config import SensorSettings
from rangeproc.editing.record import ALL_COMPONENTS, EditRecord
from rangeproc.io.logs import SensorLog, select_rows

DUPLICATE, REPEATED = "duplicate", "repeated stamp"
#: A plot sensor's repeated stamps are a stuck clock only when at most this fraction of its
#: rows repeat a stamp (plots of several objects share their scan's stamp far more often).
STUCK_MAX_FRACTION = 0.25
#: ... and when the clock jumps by about the repeated rows' time after at least this
#: fraction of the repeated rows (weighted by the rows each repeated stamp holds).
STUCK_FIT = 0.8
#: Duplicates of a plot sensor are said (a warning) from this fraction of its rows on.
DUPLICATE_SAID_FRACTION = 0.01


def duplicate_rows(log: SensorLog) -> np.ndarray:
    """(N,) bool: rows whose stamp and every loaded value equal an earlier file row's."""
    n = len(log)
    out = np.zeros(n, dtype=bool)
    if n < 2:
        return out
    stamp = np.where(np.isnan(log.time), np.inf, log.time)
    if (stamp[1:] > stamp[:-1]).all():                   # no stamp twice: no duplicate
        return out
    ts = np.sort(stamp)
    at = np.flatnonzero(np.isin(stamp, ts[1:][ts[1:] == ts[:-1]]))   # rows of shared stamps
    keys = [log.time, *log.columns.values()]
    keys += [a.astype(float) for a in (log.track_id, log.station) if a is not None]
    table = np.column_stack([np.where(np.isnan(k[at]), np.inf, k[at]) for k in keys])
    order = np.lexsort((log.row[at], *table.T[::-1]))     # by every value, then file order
    same = np.zeros(len(at), dtype=bool)
    same[1:] = (table[order][1:] == table[order][:-1]).all(axis=1)
    out[at[order[same]]] = True
    return out


def repeated_stamps(time: np.ndarray, row: np.ndarray,
                    series: np.ndarray | None = None) -> np.ndarray:
    """(N,) bool: every row whose stamp an earlier file row of the same series already has.

    ``series``: (N,) int64 series label (MISTRAM station, track id), None = one series; rows
    labelled -1 (plots) are never repeats.
    """
    out = np.zeros(time.size, dtype=bool)
    if time.size < 2:
        return out
    key = np.zeros(time.size, dtype=np.int64) if series is None else series
    order = np.lexsort((row, time, key))            # by series, time, then file order
    ks, ts = key[order], time[order]
    same = np.zeros(time.size, dtype=bool)
    same[1:] = (ts[1:] == ts[:-1]) & (ks[1:] == ks[:-1]) & (ks[1:] >= 0)
    out[order[same]] = True
    return out


def stuck_clock(time: np.ndarray) -> bool:
    """True when the repeated stamps of ascending ``time`` (s) look like a stuck clock (module
    docstring, rule 2): few rows repeat a stamp, and the step after each repeated stamp is
    within half a usual step of (rows holding it) x (the median step between stamps)."""
    stamps, counts = np.unique(time, return_counts=True)
    n_repeat = time.size - stamps.size
    if n_repeat == 0 or n_repeat > STUCK_MAX_FRACTION * time.size or stamps.size < 3:
        return False
    step = np.diff(stamps)
    usual = float(np.median(step))
    if usual <= 0.0:
        return False
    k = np.flatnonzero(counts[:-1] > 1)             # repeated stamps with a stamp after them
    if k.size == 0:
        return True                                 # the clock stopped at the last stamp
    fits = np.abs(step[k] - counts[k] * usual) <= 0.5 * usual
    weight = counts[k] - 1.0
    return bool(np.sum(weight[fits]) >= STUCK_FIT * np.sum(weight))


def _series(log: SensorLog) -> np.ndarray | None | bool:
    """The series labels of a sensor for :func:`repeated_stamps`; False when its repeated
    stamps are plots sharing a scan's stamp (radar/theodolite without track ids that show
    no stuck clock)."""
    if log.kind in ("gps", "ins"):
        return None
    if log.kind == "mistram":
        return log.station
    if log.track_id is not None:
        return log.track_id
    return None if stuck_clock(log.time) else False


def drop_repeats(log: SensorLog, record: EditRecord) -> SensorLog:
    """``log`` without its duplicates and repeated stamps (module docstring), recorded in
    ``record`` with reasons ``duplicate`` and ``repeated stamp``."""
    for reason, find in ((DUPLICATE, duplicate_rows), (REPEATED, _repeats)):
        bad = find(log)
        if bad.any():
            record.add(log.sensor_id, reason, ALL_COMPONENTS, log.row[bad], log.time[bad])
            log = select_rows(log, ~bad)
    return log


def _repeats(log: SensorLog) -> np.ndarray:
    series = _series(log)
    if series is False:
        return np.zeros(len(log), dtype=bool)
    return repeated_stamps(log.time, log.row, series)


def plot_feed(log: SensorLog) -> bool:
    """True for a radar/theodolite without track ids whose rows share stamps as plots of a scan
    do (more than :data:`STUCK_MAX_FRACTION` of them)."""
    if log.kind not in ("radar", "theodolite") or log.track_id is not None or len(log) == 0:
        return False
    return len(log) - np.unique(log.time).size > STUCK_MAX_FRACTION * len(log)


def repeat_lines(s: SensorSettings, record: EditRecord, log: SensorLog) -> Iterator[str]:
    """The warning lines of sensor ``s``'s duplicates and repeated stamps in ``record`` (one
    each; ``log``: its screened log, which tells a plot feed)."""
    mine = [e for e in record.edits if e.sensor_id == s.id]
    dup = [e for e in mine if e.reason == DUPLICATE]
    rep = [e for e in mine if e.reason == REPEATED]
    name = s.file.name
    if dup:
        n = sum(e.rows.size for e in dup)
        first = int(min(e.rows.min() for e in dup))
        if not plot_feed(log) or n >= DUPLICATE_SAID_FRACTION * (len(log) + n):
            yield (f"{name}: {n} rows repeat an earlier row exactly (first: row {first}): "
                   "dropped as duplicates (the log or a block of it written twice?)")
    if rep:
        n = sum(e.rows.size for e in rep)
        k = min(range(len(rep)), key=lambda j: int(rep[j].rows.min()))
        j = int(np.argmin(rep[k].rows))
        yield (f"{name}: {n} rows repeat the time stamp of an earlier row with other values "
               f"(first: row {int(rep[k].rows[j])} at {rep[k].time[j]:.3f} s): a stuck clock? "
               f"the first row of each stamp is kept, the {n} repeats are dropped")
