"""Screening stage: every sensor log is checked before anything reaches the estimator.

Order: duplicate rows and repeated stamps (``editing.repeats``), then time stamps
(``editing.timecheck``: beyond the representable range, isolated far stamps), then physical
limits and impossible jumps (``editing.limits``), then the Hampel pre-edit of wild values
(``editing.hampel``), then the cross-sensor time overlap (a sensor on the wrong time scale is
refused). Every removed row or component goes into the run's :class:`EditRecord`.
"""
from __future__ import annotations

import logging
from collections.abc import Callable

from rangeproc.config import Config, SensorSettings
from rangeproc.editing.hampel import pre_edit
from rangeproc.editing.limits import Limits, apply_limits
from rangeproc.editing.record import EditRecord
from rangeproc.editing.repeats import drop_repeats, repeat_lines
from rangeproc.editing.timecheck import check_overlap, edit_time
from rangeproc.errors import DataError
from rangeproc.io.logs import SensorLog
from rangeproc.parallel import thread_map

log = logging.getLogger(__name__)


def screen_logs(cfg: Config, logs: dict[str, SensorLog], record: EditRecord,
                tick: Callable[..., None] = lambda *a, **k: None) -> dict[str, SensorLog]:
    """Edited logs of every sensor (new dict; the input logs are not changed).

    Sensors are screened side by side in threads (``rangeproc.parallel``); their edits enter
    ``record`` in config order. ``tick(1, sensor_id)`` is called after each sensor (progress
    display).

    Raises:
        DataError: a sensor whose every time stamp is impossible, or whose rows do not come
            near any other sensor's (``check_overlap``).
    """
    p = cfg.processing
    limits = Limits(max_range=p.max_range, max_speed=p.max_speed)

    def screen_one(s: SensorSettings) -> tuple[SensorLog, EditRecord]:
        own = EditRecord()                      # one per sensor: threads append to their own
        edited = drop_repeats(logs[s.id], own)
        edited = edit_time(edited, s, own, max_gap=p.max_gap)
        edited = apply_limits(edited, s, own, limits)
        return pre_edit(edited, own, half_width=p.hampel_window,
                        threshold=p.hampel_threshold), own

    out: dict[str, SensorLog] = {}
    screened = thread_map(screen_one, cfg.sensors, cost=lambda s: len(logs[s.id]))
    for s, (edited, own) in zip(cfg.sensors, screened):   # config order, as one by one
        record.edits.extend(own.edits)
        for line in repeat_lines(s, own, edited):
            log.warning("%s", line)
        counts = record.counts(s.id)
        if counts:       # a time edit is rare and worth a word; the rest is in the summary
            (log.warning if "time" in counts else log.info)(
                "%s: edited before estimation: %s", s.id,
                ", ".join(f"{n} {reason}" for reason, n in counts.items()))
        if s.kind == "ins" and len(edited) < 2 and any(o.platform == s.id
                                                        for o in cfg.sensors):
            raise _unusable_ins(s.file.name, len(logs[s.id]) - len(edited),
                                record.examples(s.id, 1))
        out[s.id] = edited
        tick(1, s.id)
    check_overlap(out, cfg.sensors, margin=p.time_margin)
    return out


def _unusable_ins(name: str, n_edited: int, first: list[dict[str, object]]) -> DataError:
    """An INS with fewer than two usable rows: its platform's sensors have no attitude."""
    if first:
        e = first[0]
        why = (f"{n_edited} rows removed by editing, first row {e['row']}, column "
               f"'{e['component']}', reason {e['reason']}")
    else:
        why = "every other row lacks a roll, pitch, yaw, lat, lon or height value"
    return DataError(f"{name}: fewer than 2 usable rows ({why}): the platform's attitude "
                     "is unusable")
