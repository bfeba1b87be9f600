"""Screening stage: every sensor log is checked before anything reaches the estimator.

Order: time stamps (``editing.timecheck``: beyond the representable range, repeated stamps of
GPS/INS, isolated far stamps), then physical limits and impossible jumps
(``editing.limits``), then the cross-sensor time overlap (a sensor on the wrong time scale is
refused). Every removed row or component goes into the run's :class:`EditRecord`.
"""
from __future__ import annotations

import logging
from collections.abc import Callable

from rangeproc.config import Config
from rangeproc.editing.limits import Limits, apply_limits
from rangeproc.editing.record import EditRecord
from rangeproc.editing.timecheck import check_overlap, edit_time
from rangeproc.errors import DataError
from rangeproc.io.logs import SensorLog

log = logging.getLogger(__name__)


def screen_logs(cfg: Config, logs: dict[str, SensorLog], record: EditRecord,
                tick: Callable[..., None] = lambda *a, **k: None) -> dict[str, SensorLog]:
    """Edited logs of every sensor (new dict; the input logs are not changed).

    ``tick(1, sensor_id)`` is called after each sensor (progress display).

    Raises:
        DataError: a sensor whose every time stamp is impossible, or whose rows do not come
            near any other sensor's (``check_overlap``).
    """
    p = cfg.processing
    limits = Limits(max_range=p.max_range, max_speed=p.max_speed)
    out: dict[str, SensorLog] = {}
    for s in cfg.sensors:
        edited = edit_time(logs[s.id], s, record, max_gap=p.max_gap)
        edited = apply_limits(edited, s, record, limits)
        counts = record.counts(s.id)
        if counts:       # a time edit is rare and worth a word; the rest is in the summary
            (log.warning if "time" in counts else log.info)(
                "%s: edited before estimation: %s", s.id,
                ", ".join(f"{n} {reason}" for reason, n in counts.items()))
        if s.kind == "ins" and len(edited) < 2 <= len(logs[s.id]):
            first = record.examples(s.id, 1)[0]
            raise DataError(f"{s.file.name}: fewer than 2 usable rows left after editing "
                            f"({len(logs[s.id]) - len(edited)} rows removed, first row "
                            f"{first['row']}, column '{first['component']}', reason "
                            f"{first['reason']}): the platform's attitude is unusable")
        out[s.id] = edited
        tick(1, s.id)
    check_overlap(out, cfg.sensors, margin=p.time_margin)
    return out
