"""Every row accounted for: where each row of each sensor's file went, and one line for a sensor
that contributes nothing or loses many rows for one reason.

Each data row of a sensor's file ends in exactly one place (``summary.json``'s
``sensors.<id>.rows``; the numbers add up to ``read``):

* ``used``: some component of the row entered an object's fusion (an INS row: read and kept);
* ``no_measurement``: a row with nothing measured (every measurement cell empty; an INS row
  lacking an attitude or position cell);
* ``rejected`` by reason: rows removed before estimation with a whole-row edit or every
  component edited (``edits.parquet``'s reasons: ``duplicate``, ``repeated stamp``, ``time``,
  ``limit``, ``speed``, ``pre-edit``, ``isolated``), and rows the estimator measured but used
  no component of (``gate``);
* ``no_platform_geometry``: rows of a platform sensor outside its INS log's span or gaps;
* ``not_associated`` by reason: radar/theodolite rows no object took (``association.parquet``'s
  reasons: ``no object fits``, ``clutter``, ``angle-only plot``, ``segment too short to start
  an object``);
* ``not_started``: rows of an object's span that could not be started (no position fix).

:func:`accounting_lines` gives one warning line per sensor that contributes nothing or loses
more than :data:`LOSS_FRACTION` of its rows for one reason, naming the count, the reason and
the likely cause (a wrong site, the INS log's span against the sensor's, a clock). Reasons
said by their own warning (:data:`SAID_ELSEWHERE`) and those that are a plot feed's normal
lot (:data:`EXPECTED`: clutter, another object's angle-only detections, empty rows) are not
said again. For a plot feed (a file without ``track_id``), plots that fit no object or whose
track is too short to start one (:data:`PLOT_EXPECTED`) are its normal lot too (the plots
of objects no other sensor sees, of boats at a quay): they are said only when the sensor
contributes nothing, where a wrong site, lever arm or unit is the likely cause.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence

import numpy as np
import pandas as pd

from rangeproc.config import Config, SensorSettings
from rangeproc.editing.record import ALL_COMPONENTS, EditRecord
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.io.logs import SensorLog
from rangeproc.summary_types import RowsSummary
from rangeproc.tracking.synthesis import ANGLE_PLOT, CLUTTER, NO_OBJECT, SHORT

#: A sensor losing more than this fraction of its rows for one reason gets a line.
LOSS_FRACTION = 0.10
#: Reasons with a warning line of their own (``editing.repeats``, ``editing.screen``, the
#: isolated sensor's line of ``stages.products``).
SAID_ELSEWHERE = frozenset({"duplicate", "repeated stamp", "time", "isolated"})
#: Fates that are a plot feed's normal lot, never a loss worth a line.
EXPECTED = frozenset({"no measurement", "clutter", "angle-only plot"})
#: Fates that are a plot feed's normal lot besides (module docstring).
PLOT_EXPECTED = frozenset({"no object fits", "segment too short to start an object"})
USED, NO_MEASUREMENT, NO_PLATFORM, NOT_STARTED, GATE = (
    "used", "no measurement", "no platform geometry", "not started", "gate")
#: The likely cause of each loss, for the line.
CAUSES = {
    "no object fits": "its rows fit no object the other sensors see",
    "segment too short to start an object": "its tracks are too short to start an object and "
                                            "fit none the other sensors see",
    GATE: "the estimator's gate rejected them: noise far above its sigma, a bias, a latency "
          "or a clock problem (time_offset)?",
    "limit": "values outside physical limits: a unit (km in a metre column, mils) or a "
             "column mix-up?",
    "speed": "position fixes implying impossible speeds: a clock or unit problem?",
    "pre-edit": "wild values far from their neighbours: noise far above its sigma or a clock "
                "problem?",
    NOT_STARTED: "spans with no position fix to start an object from",
}


def _file_rows(table: pd.DataFrame | None, sid: str) -> tuple[np.ndarray, np.ndarray]:
    """(1-based file row, association reason) of a sensor's rows in ``association.parquet``'s
    table (empty arrays when it has none)."""
    if table is None or not len(table):
        return np.zeros(0, np.int64), np.zeros(0, object)
    mine = table[table["sensor"] == sid]
    return mine["row"].to_numpy(np.int64) + 1, mine["reason"].to_numpy(object)


def row_fates(s: SensorSettings, n_read: int, read_rows: np.ndarray, log: SensorLog,
              edits: EditRecord, kept: np.ndarray | None, association: pd.DataFrame | None,
              fused: Sequence[tuple[str, FusionResult]]) -> np.ndarray:
    """(n_read,) object: the fate of every data row of sensor ``s``'s file (module docstring).

    read_rows: file rows (1-based) of the read log (rows with something measured); log: the
    screened log; kept: indices into ``log`` of the rows that got geometry (None for an INS).
    """
    fate = np.full(n_read + 1, NO_MEASUREMENT, dtype=object)     # index 0 unused
    fate[read_rows] = USED if kept is None else NOT_STARTED
    screened = np.zeros(n_read + 1, dtype=bool)
    screened[log.row] = True
    component_edits: dict[int, str] = {}
    for e in edits.edits:
        if e.sensor_id != s.id:
            continue
        if e.component == ALL_COMPONENTS or e.reason == "isolated":
            fate[e.rows] = e.reason
        else:
            for r in e.rows.tolist():
                component_edits.setdefault(int(r), e.reason)
    gone = np.flatnonzero(~screened)
    gone = gone[(gone > 0) & np.isin(fate[gone], [USED, NOT_STARTED])]
    fate[gone] = [component_edits.get(int(r), "edited") for r in gone]
    if kept is None:
        return fate[1:]
    whole = np.isin(fate, list(SAID_ELSEWHERE))               # isolated rows stay so
    geometry = np.zeros(len(log), dtype=bool)
    geometry[kept] = True
    lacking = log.row[~geometry]
    fate[lacking[~whole[lacking]]] = NO_PLATFORM
    rows, reason = _file_rows(association, s.id)
    if rows.size:
        off = (reason != "associated") & np.isin(rows, log.row[geometry]) & ~whole[rows]
        fate[rows[off]] = reason[off]
    for _, res in fused:
        if s.id not in res.batch.sensor_ids:
            continue
        sel = np.flatnonzero(res.batch.sensor == res.batch.sensor_ids.index(s.id))
        file_row = log.row[res.batch.source_row[sel]]
        used = res.used[sel].any(axis=1)
        measured = res.dof[sel] > 0
        fate[file_row[used]] = USED
        rej = file_row[~used & measured]
        fate[rej[fate[rej] != USED]] = GATE
        empty = file_row[~used & ~measured]
        empty = empty[fate[empty] != USED]
        fate[empty] = [component_edits.get(int(r), "edited") for r in empty]
    return fate[1:]


def rows_summary(fate: np.ndarray, platform: bool, associated: bool) -> RowsSummary:
    """``summary.json``'s ``rows`` of one sensor from its row fates
    (``summary_types.RowsSummary``: ``no_platform_geometry`` for a platform sensor,
    ``not_associated`` for an ``associated`` kind)."""
    kinds, counts = np.unique(fate.astype(str), return_counts=True)
    n = dict(zip(kinds.tolist(), counts.tolist()))
    assoc = (NO_OBJECT, CLUTTER, ANGLE_PLOT, SHORT)
    special = {USED, NO_MEASUREMENT, NO_PLATFORM, NOT_STARTED, *assoc}
    out: RowsSummary = {
        "read": int(fate.size), "used": int(n.get(USED, 0)),
        "no_measurement": int(n.get(NO_MEASUREMENT, 0)),
        "rejected": {k: int(v) for k, v in sorted(n.items()) if k not in special},
        "not_started": int(n.get(NOT_STARTED, 0))}
    if platform:
        out["no_platform_geometry"] = int(n.get(NO_PLATFORM, 0))
    if associated:
        out["not_associated"] = {k: int(n[k]) for k in assoc if n.get(k)}
    return out


def row_accounting(cfg: Config, n_read: Mapping[str, int], read_rows: Mapping[str, np.ndarray],
                   logs: Mapping[str, SensorLog], edits: EditRecord,
                   kept: Mapping[str, np.ndarray], association: pd.DataFrame | None,
                   fused: Sequence[tuple[str, FusionResult]]) -> dict[str, np.ndarray]:
    """Sensor id -> its row fates (:func:`row_fates`)."""
    return {s.id: row_fates(s, n_read[s.id], read_rows[s.id], logs[s.id], edits,
                            None if s.kind == "ins" else kept.get(s.id, np.zeros(0, np.int64)),
                            association, fused) for s in cfg.sensors}


def _span(t: np.ndarray) -> str:
    return f"{t.min():.3f} to {t.max():.3f} s"


def _platform_cause(s: SensorSettings, cfg: Config, log: SensorLog, fate: np.ndarray,
                    logs: Mapping[str, SensorLog]) -> str:
    """The INS span against the span of the sensor's rows, and where they part."""
    ins = next((o for o in cfg.sensors if o.id == s.platform), None)
    if ins is None or not len(logs[ins.id]) or not len(log):
        return "its INS log has no usable rows"
    t_ins, t = logs[ins.id].time, log.time
    lacking = t[np.isin(log.row, np.flatnonzero(fate == NO_PLATFORM) + 1)]
    parts = []
    if t.max() > t_ins.max():
        parts.append(f"the INS log ends {t.max() - t_ins.max():.1f} s before the sensor's "
                     "last row")
    if t.min() < t_ins.min():
        parts.append(f"starts {t_ins.min() - t.min():.1f} s after its first row")
    inside = int(((lacking >= t_ins.min()) & (lacking <= t_ins.max())).sum())
    if inside:
        parts.append(f"{inside} rows fall in gaps of the INS log")
    return (f"INS {ins.id} ({ins.file.name}) spans {_span(t_ins)}, sensor {s.id}'s rows "
            f"{_span(t)}: " + ", ".join(parts))


def _site_cause(s: SensorSettings) -> str:
    if s.site is not None:
        return ("its site is likely wrong (latitude and longitude swapped, or a sign "
                f"flipped? configured lat {s.site.lat:g}, lon {s.site.lon:g}), else its "
                "angle_unit or time_offset")
    return ("its lever_arm, the INS attitude, its angle_unit or time_offset is likely wrong")


def accounting_lines(cfg: Config, fates: Mapping[str, np.ndarray],
                     logs: Mapping[str, SensorLog]) -> Iterator[str]:
    """One line per observing sensor that contributes nothing or loses more than
    :data:`LOSS_FRACTION` of its rows for one reason not said elsewhere (module docstring)."""
    for s in cfg.sensors:
        fate = fates[s.id]
        if s.kind == "ins" or fate.size == 0:
            continue
        kinds, counts = np.unique(fate.astype(str), return_counts=True)
        n = dict(zip(kinds.tolist(), counts.tolist()))
        nothing = n.get(USED, 0) == 0
        plots = logs[s.id].track_id is None
        quiet = (SAID_ELSEWHERE if nothing else
                 SAID_ELSEWHERE | EXPECTED | (PLOT_EXPECTED if plots else frozenset()))
        losses = sorted(((v, k) for k, v in n.items() if k != USED and k not in quiet),
                        reverse=True)
        if not losses or (not nothing and losses[0][0] <= LOSS_FRACTION * fate.size):
            continue
        count, reason = losses[0]
        head = (f"sensor {s.id} contributes nothing, {count} of its {fate.size} rows lost"
                if nothing else
                f"sensor {s.id} loses {count} of {fate.size} rows ({count / fate.size:.0%})")
        if reason == NO_PLATFORM:
            cause = _platform_cause(s, cfg, logs[s.id], fate, logs)
        elif reason in ("no object fits", "segment too short to start an object"):
            cause = f"{CAUSES[reason]}: {_site_cause(s)}"
        else:
            cause = CAUSES.get(reason, "see edits.parquet and association.parquet")
        yield f"{s.file.name}: {head} to '{reason}': {cause}"
