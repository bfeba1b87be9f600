"""What ``summary.json`` and the report page say about a run's edits, from ``edits.parquet``'s
table (``fusion.edit_table``), so that their counts agree with the file.

Per sensor: ``n_rejected_points`` (components not used at all, every reason; a whole removed
row counts once) with ``n_rejected_by_reason``; ``n_down_weighted`` (components used with a
weight below ``table.MATERIAL_WEIGHT``) with ``n_down_weighted_by_reason``; and
``n_down_weighted_expected``: how many of those Huber's rule gives on Gaussian noise of the
estimated sigma (:func:`down_weight_expected`), so that a count far above it says the noise
is not what the model thinks (heavy tails, outliers, a poor track).

For the page: the rejected points themselves (:func:`rejected_examples`), in time order, at
most :data:`REJECTED_SHOWN`, values in the files' own units.
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
import pandas as pd
from scipy.special import erfc

from rangeproc.fusion.noise import BURST
from rangeproc.fusion.edit_table import (
    DOWN_WEIGHT_Z,
    DOWN_WEIGHTED,
    MIN_SPREAD_FRACTION,
    REJECTED,
)
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.models.measurement import N_COMPONENTS
from rangeproc.summary_types import EditCounts, RejectedPoint, RejectedPoints

#: Most rejected points listed in the summary and on the page (the rest are in edits.parquet).
REJECTED_SHOWN = 50


def edit_counts(table: pd.DataFrame, sensor_id: str,
                expected: float = 0.0) -> EditCounts:
    """One sensor's rejections and down-weightings in ``table``: totals and per reason, and
    ``expected`` (:func:`down_weight_expected`, rounded to 2 decimals)."""
    mine = table[table["sensor"] == sensor_id]
    rejected = mine[mine["action"] == REJECTED]
    weighted = mine[mine["action"] == DOWN_WEIGHTED]
    return {"n_rejected_points": int(len(rejected)),
            "n_rejected_by_reason": _by_reason(rejected),
            "n_down_weighted": int(len(weighted)),
            "n_down_weighted_by_reason": _by_reason(weighted),
            "n_down_weighted_expected": round(float(expected), 2)}


def _by_reason(rows: pd.DataFrame) -> dict[str, int]:
    return {str(k): int(v) for k, v in sorted(rows["reason"].value_counts().items())}


def down_weight_expected(result: FusionResult, sensor_index: int) -> float:
    """Expected count of ``result``'s components of one sensor that Huber's rule records as
    down-weighted (``|u| > DOWN_WEIGHT_Z``) when the noise is Gaussian with the estimated
    global sigma: the sum over the used components outside noise bursts of
    ``P(|r| > DOWN_WEIGHT_Z sigma)``, the residual ``r`` having the post-fit spread
    ``sqrt(sigma^2 - H P_s H^T)``. 0 without noise adaptation (nothing is down-weighted)."""
    if result.down_weight is None:
        return 0.0
    b = result.batch
    at = np.flatnonzero(b.sensor == sensor_index)      # the sensor's rows, in order
    hph, used, down = result.hph[at], result.used[at], result.down_weight[at]
    total = 0.0
    for c in range(N_COMPONENTS):
        sigma = result.noise.get((sensor_index, c))
        if sigma is None or not np.isfinite(sigma) or sigma <= 0.0:
            continue
        cand = used[:, c] & (down[:, c] != BURST) & np.isfinite(hph[:, c])
        spread = np.sqrt(np.maximum(sigma ** 2 - hph[cand, c],
                                    (MIN_SPREAD_FRACTION * sigma) ** 2))
        total += float(erfc(DOWN_WEIGHT_Z * sigma / (spread * math.sqrt(2.0))).sum())
    return total


def edit_summary(table: pd.DataFrame, fused: Sequence[tuple[str, FusionResult]],
                 sensor_ids: Iterable[str]) -> dict[str, EditCounts]:
    """Per sensor id: :func:`edit_counts` and ``n_down_weighted_expected`` (summed over the
    objects the sensor's rows went to, 2 decimals)."""
    out: dict[str, EditCounts] = {}
    for sid in sensor_ids:
        expected = sum(down_weight_expected(res, res.batch.sensor_ids.index(sid))
                       for _, res in fused if sid in res.batch.sensor_ids)
        out[sid] = edit_counts(table, sid, expected)
    return out


def rejected_examples(table: pd.DataFrame, limit: int = REJECTED_SHOWN) -> RejectedPoints:
    """``{"n": every rejected point, "shown": the first `limit` in time order}``; each shown
    point: sensor, row (1-based in its file), time (s, range time scale), component, value
    and residual in ``unit`` (its file's unit; None where there is none), reason."""
    rejected = table[table["action"] == REJECTED]
    first = rejected.sort_values(["time", "sensor", "row"], kind="stable").head(limit)
    shown: list[RejectedPoint] = [
        {"sensor": str(p.sensor), "row": int(p.row), "time": _finite(p.time),
         "component": str(p.component), "value": _finite(p.value_file_unit),
         "residual": _finite(p.residual_file_unit), "unit": str(p.file_unit),
         "reason": str(p.reason)} for p in first.itertuples(index=False)]
    return {"n": int(len(rejected)), "shown": shown}


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None
