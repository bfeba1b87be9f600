"""``edits.parquet``: one row per measurement component rangeproc removed or rejected, with the
reason, so that an engineer can audit every decision and the summary counts agree with it.

Reasons: those of the pre-estimation checks (``editing.record``: ``time``, ``limit``,
``speed``; component ``*`` = the whole row); ``gate``: a measured component the final
filter pass rejected by its chi-square gate (per row, then per component), with its residual
against the smoothed track and that residual normalised by its predicted spread
``sqrt(sigma^2 + H P_s H^T)`` (a rejected component is not part of the fit, so both terms add);
and the down-weighted components the final pass used with a sigma above their sensor's global
noise estimate (``editing.noise.residual_sigma``): ``burst`` (the local scale of a noise burst)
and ``residual`` (Huber's rule on a large two-sided smoother residual), normalised by
``sqrt(sigma^2 - H P_s H^T)`` of the global sigma.

Columns: ``sensor`` (id), ``row`` (1-based data row in the sensor's file, as in messages),
``time`` (s, range time scale), ``component`` (SI component name of the sensor's model, or
the file column for pre-estimation edits), ``value`` (SI), ``residual`` (SI; NaN for
pre-estimation edits), ``normalised_residual``, ``weight`` (the weight the final pass gave
the component relative to its sensor's global noise, ``(sigma_global / sigma_used)^2``; 0 when
removed or rejected), ``reason``.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from rangeproc.editing.noise import BURST, HUBER
from rangeproc.editing.record import EditRecord
from rangeproc.fusion.centralised import FusionResult
from rangeproc.io.logs import SensorLog
from rangeproc.models.measurement import COMPONENTS

EDIT_COLUMNS = ("sensor", "row", "time", "component", "value", "residual",
                "normalised_residual", "weight", "reason")
#: Smallest post-fit spread of a used component, as a fraction of its global sigma.
MIN_SPREAD_FRACTION = 0.1
#: ``reason`` of the down-weighting codes of ``editing.noise.residual_sigma``.
DOWN_WEIGHT_REASONS = {BURST: "burst", HUBER: "residual"}


def screening_edits(record: EditRecord) -> pd.DataFrame:
    """The pre-estimation edits of ``record``."""
    parts = [pd.DataFrame({"sensor": e.sensor_id, "row": e.rows, "time": e.time,
                           "component": e.component, "value": e.value,
                           "residual": np.nan, "normalised_residual": np.nan,
                           "weight": 0.0, "reason": e.reason}) for e in record.edits]
    return _frame(parts)


def gate_rejections(result: FusionResult, logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """The components of ``result``'s rows that its final pass measured and rejected."""
    b = result.batch
    r, c = np.nonzero(np.isfinite(b.z) & (b.sigma > 0) & ~result.used)
    spread = np.sqrt(b.sigma[r, c] ** 2 + np.maximum(result.hph[r, c], 0.0))
    return _components(result, logs, r, c, spread, np.zeros(r.size), np.array("gate"))


def down_weighted(result: FusionResult, logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """The components ``result``'s final pass used with a raised sigma (burst, Huber)."""
    if result.down_weight is None:
        return _frame([])
    b = result.batch
    r, c = np.nonzero(result.used & (result.down_weight > 0))
    glob = np.array([result.noise.get((int(s), int(j)), np.nan)
                     for s, j in zip(b.sensor[r], c)])
    # the post-fit residual's spread; where the track is so uncertain that H P_s H^T reaches
    # sigma^2 (a poorly observed start), a tenth of sigma keeps the ratio finite and honest
    spread = np.sqrt(np.maximum(glob ** 2 - result.hph[r, c], (MIN_SPREAD_FRACTION * glob) ** 2))
    reason = np.vectorize(DOWN_WEIGHT_REASONS.get, otypes=[object])(result.down_weight[r, c])
    return _components(result, logs, r, c, spread, (glob / b.sigma[r, c]) ** 2, reason)


def _components(result: FusionResult, logs: Mapping[str, SensorLog], r: np.ndarray,
                c: np.ndarray, spread: np.ndarray, weight: np.ndarray,
                reason: np.ndarray) -> pd.DataFrame:
    """Rows ``r``, components ``c`` of ``result``'s batch as edit-table rows."""
    if r.size == 0:
        return _frame([])
    b = result.batch
    names = {model: names for model, (names, _) in COMPONENTS.items()}
    sensor = np.asarray(b.sensor_ids, dtype=object)[b.sensor[r]]
    file_row = np.array([logs[sid].row[k] for sid, k in zip(sensor, b.source_row[r])],
                        dtype=np.int64)
    return pd.DataFrame({
        "sensor": sensor, "row": file_row, "time": b.t[r],
        "component": [names[m][j] for m, j in zip(b.model[r], c)],
        "value": b.z[r, c], "residual": result.res[r, c],
        "normalised_residual": result.res[r, c] / spread, "weight": weight,
        "reason": np.broadcast_to(reason, r.shape)})


def edit_table(record: EditRecord, fused: Sequence[tuple[str, FusionResult]],
               logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """Every edit and rejection of a run, sorted by sensor, row and component."""
    parts = [screening_edits(record), *(gate_rejections(res, logs) for _, res in fused),
             *(down_weighted(res, logs) for _, res in fused)]
    table = _frame([p for p in parts if len(p)])
    return table.sort_values(["sensor", "row", "component"], kind="stable",
                             ignore_index=True)


def _frame(parts: list[pd.DataFrame]) -> pd.DataFrame:
    """Concatenate with the columns and dtypes of ``EDIT_COLUMNS`` (also when empty)."""
    empty = pd.DataFrame({"sensor": pd.Series(dtype=object), "row": pd.Series(dtype=np.int64),
                          "time": pd.Series(dtype=float), "component": pd.Series(dtype=object),
                          "value": pd.Series(dtype=float), "residual": pd.Series(dtype=float),
                          "normalised_residual": pd.Series(dtype=float),
                          "weight": pd.Series(dtype=float), "reason": pd.Series(dtype=object)})
    table = pd.concat([empty, *parts], ignore_index=True) if parts else empty
    return table.astype({"sensor": str, "row": np.int64, "component": str, "reason": str})
