"""No phantom object: the objects a sensor makes alone far from every other view are left out.

A radar or theodolite with a wrong site or a range in kilometres still makes a smooth object of
its own rows, far from what the other sensors see (``fusion.agreement`` finds it and warns).
Written out, that object would be a phantom in ``fused.parquet`` and the headline. Unless
``[processing] keep_isolated = true``, :func:`isolated_objects` picks the objects to leave out
and :func:`leave_out` removes them from the fused results and records their rows in the edit
record with reason ``isolated`` (whole rows, in ``edits.parquet``).

Which: the objects of a far radar or theodolite (all its rows went to objects only it sees).
A GPS or MISTRAM names its target and has no site to get wrong: its objects are kept. Two
radars/theodolites that only see each other far away leave the choice open (either may be
wrong): both are kept and the warning names both.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from rangeproc.config import Config
from rangeproc.editing.record import ALL_COMPONENTS, EditRecord
from rangeproc.fusion.agreement import FarSensor
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.io.logs import SensorLog

#: ``reason`` of the rows of an object left out.
ISOLATED = "isolated"
_SITED = ("radar", "theodolite")


def isolated_objects(cfg: Config, far: Sequence[FarSensor]) -> dict[str, tuple[str, ...]]:
    """Sensor id -> the ids of its objects to leave out (module docstring)."""
    kind = {s.id: s.kind for s in cfg.sensors}
    by_id = {f.sensor_id: f for f in far}
    out: dict[str, tuple[str, ...]] = {}
    for f in far:
        if kind[f.sensor_id] not in _SITED:
            continue
        mate = by_id.get(f.others[0]) if len(f.others) == 1 else None
        if mate is not None and mate.others == (f.sensor_id,) and kind[mate.sensor_id] in _SITED:
            continue                                      # two sited sensors: either is wrong
        out[f.sensor_id] = f.object_ids
    return out


def leave_out(fused: Sequence[tuple[str, FusionResult]], isolated: Mapping[str, tuple[str, ...]],
              logs: Mapping[str, SensorLog], record: EditRecord
              ) -> list[tuple[str, FusionResult]]:
    """``fused`` without the ``isolated`` objects; every row they were fused from is added to
    ``record`` (reason :data:`ISOLATED`, whole rows)."""
    drop = {oid for ids in isolated.values() for oid in ids}
    for oid, res in fused:
        if oid not in drop:
            continue
        b = res.batch
        for i, sid in enumerate(b.sensor_ids):
            sel = np.flatnonzero(b.sensor == i)
            if sel.size:
                rows = logs[sid].row[b.source_row[sel]]
                order = np.argsort(rows, kind="stable")
                record.add(sid, ISOLATED, ALL_COMPONENTS, rows[order], b.t[sel][order])
    return [(oid, res) for oid, res in fused if oid not in drop]


def mark_isolated(table: pd.DataFrame, record: EditRecord) -> pd.DataFrame:
    """``association.parquet``'s table with the rows left out (reason :data:`ISOLATED` in
    ``record``) taken from their object: no ``target_id``, reason ``isolated``."""
    gone = [(e.sensor_id, e.rows) for e in record.edits if e.reason == ISOLATED]
    if not gone or not len(table):
        return table
    hit = np.zeros(len(table), dtype=bool)
    sensor, row = table["sensor"].to_numpy(), table["row"].to_numpy() + 1
    for sid, rows in gone:
        hit |= (sensor == sid) & np.isin(row, rows)
    table = table.copy()
    table.loc[hit, "target_id"] = ""
    table.loc[hit, "reason"] = ISOLATED
    return table
