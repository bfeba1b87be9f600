"""Time sanity: time stamps that cannot be true are edited, sensors on the wrong time scale are
refused, before anything reaches the estimator.

Range logs carry time mistakes that parse perfectly: a corrupt stamp, a GPS week rollover, a
file on another time scale (UTC against GPS time, a day off), a wrong ``time_offset``, or a
logger that stamped every row with one time. Left alone, one such stamp stretches the flight
over days (and the output grid and memory with it). Per sensor (times in seconds on the range
time scale, ``time_offset`` applied):

1. stamps beyond ``MAX_ABS_TIME`` are edited (reason ``time``): float seconds cannot resolve
   an output grid there, and no range time scale reaches it (ISO times are about 1.8e9 s);
2. (repeated stamps and duplicate rows are removed before, by ``editing.repeats``);
3. isolated stamps: the sorted times are cut into clusters wherever a step exceeds
   ``max_gap``; a cluster of at most ``ISOLATED_MAX_ROWS`` rows that holds less than
   ``ISOLATED_MAX_FRACTION`` of the sensor's rows is edited (it lies more than ``max_gap`` from
   any other row of the same sensor, so it is not a re-acquisition but a wrong stamp);
4. :func:`check_overlap`: across sensors, a sensor none of whose rows lies within ``margin``
   seconds of another sensor's rows is refused (exit 2) with its span and the others' spans:
   almost always a wrong time scale or ``time_offset``. ``allow_disjoint_time = true`` in the
   sensor's config accepts it when intended.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from rangeproc.config import MAX_ABS_TIME, SensorSettings
from rangeproc.editing.record import ALL_COMPONENTS, EditRecord
from rangeproc.editing.clockscale import scale_hint, sign_hint, subunit_hint
from rangeproc.errors import DataError
from rangeproc.io.logs import SensorLog, select_rows

#: An isolated cluster holds at most this many rows ...
ISOLATED_MAX_ROWS = 5
#: ... and less than this fraction of the sensor's rows.
ISOLATED_MAX_FRACTION = 0.01


def _edit(log: SensorLog, bad: np.ndarray, record: EditRecord) -> SensorLog:
    """Remove the rows where ``bad`` is True, recording them with reason ``time``."""
    if not bad.any():
        return log
    record.add(log.sensor_id, "time", ALL_COMPONENTS, log.row[bad], log.time[bad])
    return select_rows(log, ~bad)


def isolated_stamps(time: np.ndarray, max_gap: float) -> np.ndarray:
    """(N,) bool: rows of ascending ``time`` (s) lying in small clusters far from the rest.

    Clusters are cut at steps longer than ``max_gap`` (s); see the module docstring, rule 3.
    The largest cluster is never isolated.
    """
    n = time.size
    out = np.zeros(n, dtype=bool)
    if n < 2:
        return out
    cuts = np.flatnonzero(np.diff(time) > max_gap) + 1
    if cuts.size == 0:
        return out
    starts = np.concatenate([[0], cuts])
    sizes = np.diff(np.concatenate([starts, [n]]))
    small = (sizes <= ISOLATED_MAX_ROWS) & (sizes < ISOLATED_MAX_FRACTION * n)
    small[int(np.argmax(sizes))] = False
    for s, size in zip(starts[small], sizes[small]):
        out[s:s + size] = True
    return out


def edit_time(log: SensorLog, settings: SensorSettings, record: EditRecord, *,
              max_gap: float) -> SensorLog:
    """Apply rules 1 and 3 of the module docstring to one sensor; returns the edited log.

    Raises:
        DataError: every row of the sensor has an impossible time stamp.
    """
    if len(log) == 0:
        return log
    far = np.abs(log.time) > MAX_ABS_TIME
    if far.all():
        raise DataError(f"{settings.file.name}: row {int(log.row[0])}, column 'time': "
                        f"{log.time[0]:g} s (time_offset {settings.time_offset:g} s applied) "
                        f"and every other time stamp lie beyond +-{MAX_ABS_TIME:g} s"
                        f"{subunit_hint(log.time - settings.time_offset)}")
    log = _edit(log, far, record)
    return _edit(log, isolated_stamps(log.time, max_gap), record)


def _span(t: np.ndarray) -> str:
    return f"{t.min():.3f} to {t.max():.3f} s" if t.size else "empty"


def check_overlap(logs: Mapping[str, SensorLog], sensors: Sequence[SensorSettings], *,
                  margin: float) -> None:
    """Refuse a sensor whose rows all lie more than ``margin`` (s) from every other sensor's.

    Observing sensors (not ``ins``) are compared with the other observing sensors; an ``ins``
    with the sensors mounted on its platform. Sensors with ``allow_disjoint_time`` and sensors
    without rows are skipped. When several sensors fail, the one farthest from the median of
    all sensors' mid-times is named (with two sensors either may be the wrong one; the message
    gives both spans).

    Raises:
        DataError: ``<file>: sensor <id> time span A to B s does not come within <margin> s of
            the other sensors (C to D s): <both scales and the aligning time_offset> ...``
            (``editing.clockscale``).
    """
    by_id = {s.id: s for s in sensors}
    observing = [s.id for s in sensors if s.kind != "ins" and len(logs[s.id])]
    mids = {sid: 0.5 * (float(logs[sid].time[0]) + float(logs[sid].time[-1]))
            for sid in logs if len(logs[sid])}
    centre = float(np.median(list(mids.values()))) if mids else 0.0
    failures: list[tuple[float, str, np.ndarray]] = []
    for s in sensors:
        if s.allow_disjoint_time or not len(logs[s.id]):
            continue
        if s.kind == "ins":
            others = [o.id for o in sensors if o.platform == s.id and len(logs[o.id])]
        else:
            others = [o for o in observing if o != s.id]
        if not others:
            continue
        ref = np.sort(np.concatenate([logs[o].time for o in others]))
        if _comes_near(logs[s.id].time, ref, margin):
            continue
        failures.append((abs(mids[s.id] - centre), s.id, ref))
    if not failures:
        return
    _, sid, ref = max(failures, key=lambda f: f[0])
    s = by_id[sid]
    what = "the sensors on its platform" if s.kind == "ins" else "the other sensors"
    hint = (scale_hint(logs[sid].time, ref) or sign_hint(logs[sid].time, s.time_offset, ref, margin)
            or "likely a wrong time scale or time_offset")
    raise DataError(
        f"{s.file.name}: sensor {sid} time span {_span(logs[sid].time)} does not come within "
        f"{margin:g} s of {what} ({_span(ref)}): {hint} "
        f"(set allow_disjoint_time = true for sensor {sid} if this is intended)")


def _comes_near(t: np.ndarray, ref: np.ndarray, margin: float) -> bool:
    """True when some time in ``t`` lies within ``margin`` of a time in sorted ``ref``."""
    k = np.clip(np.searchsorted(ref, t), 1, ref.size - 1) if ref.size > 1 else \
        np.zeros(t.size, dtype=np.int64)
    near = np.minimum(np.abs(t - ref[k]), np.abs(t - ref[np.maximum(k - 1, 0)]))
    return bool((near <= margin).any())
