"""The edit record: every measurement component that rangeproc removed before estimation, with
the reason, so that every decision can be audited and the summary counts agree with it.

Reasons written by the pre-estimation checks (``editing.repeats``, ``editing.timecheck``,
``editing.limits``):

* ``duplicate``: a row repeating an earlier file row exactly (``editing.repeats``);
* ``repeated stamp``: a row with the time stamp of an earlier row of the same measurement
  series but other values (a stuck clock; ``editing.repeats``);
* ``time``: a time stamp that cannot be true for this sensor: isolated far outside the sensor's
  own sequence (a corrupt stamp, a week rollover) or outside the representable range;
* ``limit``: a value outside physical limits (range <= 0 or beyond the maximum range, an
  elevation beyond +-90 degrees, a height below the deepest ocean or beyond the maximum, a
  speed or range rate beyond the maximum speed, an attitude angle out of range);
* ``speed``: a position fix that implies an impossible speed to both its neighbours.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from rangeproc.summary_types import EditExample

#: Component name used when a whole row is removed (every component at once).
ALL_COMPONENTS = "*"


@dataclass(frozen=True, slots=True)
class Edit:
    """A batch of edits of one sensor with one reason.

    rows: (K,) int64 1-based data-row numbers in the sensor's file (as in error messages);
    time: (K,) float64 s on the range time scale (as read, time_offset applied);
    component: the edited column name, or ``ALL_COMPONENTS`` for the whole row;
    value: (K,) float64 the edited value in SI (NaN for whole rows).
    """

    sensor_id: str
    reason: str
    component: str
    rows: np.ndarray
    time: np.ndarray
    value: np.ndarray


@dataclass(slots=True)
class EditRecord:
    """Every edit of a run, appended stage by stage (the one mutable log of a run)."""

    edits: list[Edit] = field(default_factory=list)

    def add(self, sensor_id: str, reason: str, component: str, rows: np.ndarray,
            time: np.ndarray, value: np.ndarray | None = None) -> None:
        """Append the edits of ``rows`` (no-op when empty)."""
        rows = np.asarray(rows, dtype=np.int64)
        if rows.size == 0:
            return
        val = np.full(rows.size, np.nan) if value is None else np.asarray(value, dtype=float)
        self.edits.append(Edit(sensor_id, reason, component, rows.copy(),
                               np.asarray(time, dtype=float).copy(), val.copy()))

    def counts(self, sensor_id: str) -> dict[str, int]:
        """Edited measurements per reason for one sensor (a removed row counts once)."""
        out: Counter[str] = Counter()
        for e in self.edits:
            if e.sensor_id == sensor_id:
                out[e.reason] += int(e.rows.size)
        return dict(sorted(out.items()))

    def examples(self, sensor_id: str, limit: int = 5) -> list[EditExample]:
        """The first ``limit`` edits of a sensor, for the summary (row, time, component,
        value, reason)."""
        out: list[EditExample] = []
        for e in self.edits:
            if e.sensor_id != sensor_id:
                continue
            for k in range(min(e.rows.size, limit - len(out))):
                v = float(e.value[k])
                out.append({"row": int(e.rows[k]), "time": float(e.time[k]),
                            "component": e.component, "reason": e.reason,
                            "value": v if np.isfinite(v) else None})
            if len(out) >= limit:
                break
        return out
