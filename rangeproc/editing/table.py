"""``edits.parquet``: one row per measurement component rangeproc removed or rejected, with the
reason, so that an engineer can audit every decision and the summary counts agree with it.

Reasons: those of the pre-estimation checks (``editing.record``: ``time``, ``limit``,
``speed``; component ``*`` = the whole row) and ``gate``: a measured component the final
filter pass rejected by its chi-square gate (per row, then per component), with its residual
against the smoothed track and that residual normalised by its predicted spread
``sqrt(sigma^2 + H P_s H^T)`` (a rejected component is not part of the fit, so both terms add).

Columns: ``sensor`` (id), ``row`` (1-based data row in the sensor's file, as in messages),
``time`` (s, range time scale), ``component`` (SI component name of the sensor's model, or
the file column for pre-estimation edits), ``value`` (SI), ``residual`` (SI; NaN for
pre-estimation edits), ``normalised_residual``, ``reason``.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from rangeproc.editing.record import EditRecord
from rangeproc.fusion.centralised import FusionResult
from rangeproc.io.logs import SensorLog
from rangeproc.models.measurement import COMPONENTS

EDIT_COLUMNS = ("sensor", "row", "time", "component", "value", "residual",
                "normalised_residual", "reason")


def screening_edits(record: EditRecord) -> pd.DataFrame:
    """The pre-estimation edits of ``record``."""
    parts = [pd.DataFrame({"sensor": e.sensor_id, "row": e.rows, "time": e.time,
                           "component": e.component, "value": e.value,
                           "residual": np.nan, "normalised_residual": np.nan,
                           "reason": e.reason}) for e in record.edits]
    return _frame(parts)


def gate_rejections(result: FusionResult, logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """The components of ``result``'s rows that its final pass measured and rejected."""
    b = result.batch
    measured = np.isfinite(b.z) & (b.sigma > 0)
    r, c = np.nonzero(measured & ~result.used)
    if r.size == 0:
        return _frame([])
    names = {model: names for model, (names, _) in COMPONENTS.items()}
    sensor = np.asarray(b.sensor_ids, dtype=object)[b.sensor[r]]
    file_row = np.array([logs[sid].row[k] for sid, k in zip(sensor, b.source_row[r])],
                        dtype=np.int64)
    spread = np.sqrt(b.sigma[r, c] ** 2 + np.maximum(result.hph[r, c], 0.0))
    return pd.DataFrame({
        "sensor": sensor, "row": file_row, "time": b.t[r],
        "component": [names[m][j] for m, j in zip(b.model[r], c)],
        "value": b.z[r, c], "residual": result.res[r, c],
        "normalised_residual": result.res[r, c] / spread, "reason": "gate"})


def edit_table(record: EditRecord, fused: Sequence[tuple[str, FusionResult]],
               logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """Every edit and rejection of a run, sorted by sensor, row and component."""
    parts = [screening_edits(record), *(gate_rejections(res, logs) for _, res in fused)]
    table = _frame([p for p in parts if len(p)])
    return table.sort_values(["sensor", "row", "component"], kind="stable",
                             ignore_index=True)


def _frame(parts: list[pd.DataFrame]) -> pd.DataFrame:
    """Concatenate with the columns and dtypes of ``EDIT_COLUMNS`` (also when empty)."""
    empty = pd.DataFrame({"sensor": pd.Series(dtype=object), "row": pd.Series(dtype=np.int64),
                          "time": pd.Series(dtype=float), "component": pd.Series(dtype=object),
                          "value": pd.Series(dtype=float), "residual": pd.Series(dtype=float),
                          "normalised_residual": pd.Series(dtype=float),
                          "reason": pd.Series(dtype=object)})
    table = pd.concat([empty, *parts], ignore_index=True) if parts else empty
    return table.astype({"sensor": str, "row": np.int64, "component": str, "reason": str})
