"""``edits.parquet``: one row per measurement component rangeproc rejected or down-weighted,
with the reason, so that an engineer can audit every decision and the summary counts agree
with it.

Two kinds of decision, told apart by the ``action`` column:

* ``rejected``: the component was not used at all (weight 0). Reasons: those of the
  pre-estimation checks (``editing.record``: ``time``, ``limit``, ``speed``; ``editing.hampel``:
  ``pre-edit``; component ``*`` = the whole row), and ``gate``: a measured component the final
  filter pass rejected by its chi-square gate (per row, then per component). The residual of
  a rejected component is taken against the smoothed track, normalised by its predicted
  spread ``sqrt(sigma^2 + H P_s H^T)`` (a rejected component is not part of the fit, so both
  terms add); a pre-estimation edit has one where its component is one the sensor's
  measurement rows carry and its row reached the estimator (the value with the sensor's
  applied corrections removed, as its other rows), NaN otherwise (whole rows, GPS
  latitude / longitude / height, rows removed with their time stamp).
* ``down-weighted``: a component the final pass used with a sigma above its sensor's global
  noise estimate (``fusion.noise.residual_sigma``) so much that its weight fell below
  :data:`MATERIAL_WEIGHT`: ``burst`` (the local scale of a noise burst) and ``residual``
  (Huber's rule on a large two-sided smoother residual: weight ``k / |u|``, so recorded
  beyond ``|u| > k / MATERIAL_WEIGHT = 3`` global sigmas). Their residual is normalised by
  ``sqrt(sigma^2 - H P_s H^T)`` of the global sigma. The smaller down-weightings Huber's rule
  gives to ordinary Gaussian noise (a few per cent of the components) are not decisions an
  engineer needs to audit and are left out; ``fusion.edit_audit.down_weight_expected`` states how
  many recorded ones Gaussian noise of the estimated sigma gives.

Columns: ``sensor`` (id), ``row`` (1-based data row in the sensor's file, as in messages),
``time`` (s, range time scale), ``component`` (SI component name of the sensor's model, or
the file column for pre-estimation edits), ``value`` (SI: m, rad, m/s; latitude and
longitude deg), ``residual`` (same unit), ``normalised_residual``, ``weight`` (the weight the
final pass gave the component relative to its sensor's global noise,
``(sigma_global / sigma_used)^2``; 0 when rejected), ``reason``, ``action`` (``rejected`` or
``down-weighted``), ``unit`` (of ``value`` and ``residual``), ``file_unit`` (the unit the
sensor's file writes the component in: the sensor's ``angle_unit`` for angles, else
``unit``), ``value_file_unit``, ``residual_file_unit`` (``value``, ``residual`` in
``file_unit``). A whole-row edit has NaN values and empty units. GPS position components of
the gate (``e``, ``n``, ``u``) are receiver-local ENU metres, the file's latitude, longitude
and height converted.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from rangeproc.fusion.noise import BURST, HUBER, HUBER_K
from rangeproc.editing.record import EditRecord
from rangeproc.estimation.residuals import smoothed_residuals
from rangeproc.fusion.estimator_types import FusionResult
from rangeproc.io.logs import SensorLog
from rangeproc.models.measurement import COMPONENTS, N_COMPONENTS
from rangeproc.settings import ANGLE_COMPONENTS, ANGLE_TO_RADIANS

EDIT_COLUMNS = ("sensor", "row", "time", "component", "value", "residual",
                "normalised_residual", "weight", "reason", "action", "unit", "file_unit",
                "value_file_unit", "residual_file_unit")
#: ``action`` of a component not used at all, and of one used with a reduced weight.
REJECTED, DOWN_WEIGHTED = "rejected", "down-weighted"
#: Smallest post-fit spread of a used component, as a fraction of its global sigma.
MIN_SPREAD_FRACTION = 0.1
#: ``reason`` of the down-weighting codes of ``fusion.noise.residual_sigma``.
DOWN_WEIGHT_REASONS = {BURST: "burst", HUBER: "residual"}
#: A used component is recorded as down-weighted when its weight is below this (its sigma
#: raised by more than 22 %): for Huber's rule a normalised residual beyond
#: :data:`DOWN_WEIGHT_Z` global sigmas.
MATERIAL_WEIGHT = 2.0 / 3.0
#: Normalised residual (global sigmas) beyond which Huber's rule records a down-weighting.
DOWN_WEIGHT_Z = HUBER_K / MATERIAL_WEIGHT
#: SI unit of every component name an edit can carry (model components and file columns;
#: the SensorLog keeps latitude and longitude in degrees).
SI_UNITS = {**{name: unit for names, units in COMPONENTS.values()
               for name, unit in zip(names, units)},
            "lat": "deg", "lon": "deg", "height": "m", "roll": "rad", "pitch": "rad",
            "yaw": "rad"}


def screening_edits(record: EditRecord) -> pd.DataFrame:
    """The pre-estimation edits of ``record`` (residuals NaN; :func:`screened_residuals`)."""
    parts = [pd.DataFrame({"sensor": e.sensor_id, "row": e.rows, "time": e.time,
                           "component": e.component, "value": e.value,
                           "residual": np.nan, "normalised_residual": np.nan,
                           "weight": 0.0, "reason": e.reason, "action": REJECTED})
             for e in record.edits]
    return _frame(parts)


def screened_residuals(table: pd.DataFrame, fused: Sequence[tuple[str, FusionResult]],
                       logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """``table`` (pre-estimation edits) with ``residual`` (SI) and ``normalised_residual``
    against the smoothed track filled where an edited component is one of its sensor's
    measurement rows that reached the estimator (module docstring)."""
    res = table["residual"].to_numpy(dtype=float, copy=True)
    norm = table["normalised_residual"].to_numpy(dtype=float, copy=True)
    sensor, row = table["sensor"].to_numpy(), table["row"].to_numpy()
    comp, value = table["component"].to_numpy(), table["value"].to_numpy(dtype=float)
    for _, result in fused:
        for i, sid in enumerate(result.batch.sensor_ids):
            mine = np.flatnonzero(sensor == sid)
            if mine.size == 0 or sid not in logs:
                continue
            k, at, j = _batch_rows(result, i, logs[sid], row[mine], comp[mine])
            if k.size:
                z = value[mine[at]] - _applied_correction(result, i, logs[sid], j)
                res[mine[at]], norm[mine[at]] = _residuals_of(result, k, j, z)
    return table.assign(residual=res, normalised_residual=norm)


def _batch_rows(result: FusionResult, sensor_index: int, log: SensorLog, rows: np.ndarray,
                comps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where edits (1-based file ``rows``, component names ``comps``) of one sensor are in
    ``result``'s batch: (batch row index, index into ``rows`` of each found edit, model
    component index); whole-row edits and components the model lacks are not found."""
    b = result.batch
    idx = np.flatnonzero(b.sensor == sensor_index)
    none = np.zeros(0, dtype=np.int64)
    if idx.size == 0:
        return none, none, none
    names = COMPONENTS[int(b.model[idx[0]])][0]
    j = pd.Series(comps, dtype=object).map({n: c for c, n in enumerate(names)}).fillna(-1)
    j = j.to_numpy(dtype=np.int64)
    file_row = log.row[b.source_row[idx]]
    order = np.argsort(file_row, kind="stable")
    ordered = file_row[order]
    pos = np.clip(np.searchsorted(ordered, rows), 0, ordered.size - 1)
    at = np.flatnonzero((ordered[pos] == rows) & (j >= 0))
    return idx[order[pos[at]]], at, j[at]


def _applied_correction(result: FusionResult, sensor_index: int, log: SensorLog,
                        j: np.ndarray) -> np.ndarray:
    """(K,) the correction (SI) the sensor's rows of component ``j`` (K,) carry in the batch
    against their file values (known biases, registered calibration): the median
    difference over the rows where both are finite, 0 where there are none."""
    b = result.batch
    idx = np.flatnonzero(b.sensor == sensor_index)
    names = COMPONENTS[int(b.model[idx[0]])][0]
    out = np.zeros(j.size)
    for c in np.unique(j):
        column = log.columns.get(names[c])
        if column is None:
            continue
        diff = column[b.source_row[idx]] - b.z[idx, c]
        diff = diff[np.isfinite(diff)]
        out[j == c] = float(np.median(diff)) if diff.size else 0.0
    return out


def _residuals_of(result: FusionResult, k: np.ndarray, j: np.ndarray, z: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Residual (SI) of the values ``z`` (K,) of component ``j`` (K,) at batch rows ``k``
    (K,) against ``result``'s smoothed track, and it normalised by ``sqrt(sigma^2 + hph)``."""
    b = result.batch
    n = np.arange(k.size)
    zz = np.full((k.size, N_COMPONENTS), np.nan)
    zz[n, j] = z
    res, hph = smoothed_residuals(result.meas_epoch[k], b.model[k], zz, b.s[k], b.sv[k],
                                  b.Qr[k], result.xs, result.Ps)
    spread = np.sqrt(b.sigma[k, j] ** 2 + np.maximum(hph[n, j], 0.0))
    return res[n, j], res[n, j] / spread


def gate_rejections(result: FusionResult, logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """The components of ``result``'s rows that its final pass measured and rejected."""
    b = result.batch
    r, c = np.nonzero(np.isfinite(b.z) & (b.sigma > 0) & ~result.used)
    spread = np.sqrt(b.sigma[r, c] ** 2 + np.maximum(result.hph[r, c], 0.0))
    return _components(result, logs, r, c, spread, np.zeros(r.size), np.array("gate"),
                       REJECTED)


def down_weighted(result: FusionResult, logs: Mapping[str, SensorLog]) -> pd.DataFrame:
    """The components ``result``'s final pass used with a weight below
    :data:`MATERIAL_WEIGHT` (burst, Huber)."""
    if result.down_weight is None:
        return _frame([])
    b = result.batch
    r, c = np.nonzero(result.used & (result.down_weight > 0))
    glob = np.array([result.noise.get((int(s), int(j)), np.nan)
                     for s, j in zip(b.sensor[r], c)])
    weight = (glob / b.sigma[r, c]) ** 2
    keep = weight < MATERIAL_WEIGHT
    r, c, glob, weight = r[keep], c[keep], glob[keep], weight[keep]
    # the post-fit residual's spread; where the track is so uncertain that H P_s H^T reaches
    # sigma^2 (a poorly observed start), a tenth of sigma keeps the ratio finite and honest
    spread = np.sqrt(np.maximum(glob ** 2 - result.hph[r, c], (MIN_SPREAD_FRACTION * glob) ** 2))
    reason = np.vectorize(DOWN_WEIGHT_REASONS.get, otypes=[object])(result.down_weight[r, c])
    return _components(result, logs, r, c, spread, weight, reason, DOWN_WEIGHTED)


def _components(result: FusionResult, logs: Mapping[str, SensorLog], r: np.ndarray,
                c: np.ndarray, spread: np.ndarray, weight: np.ndarray,
                reason: np.ndarray, action: str) -> pd.DataFrame:
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
        "reason": np.broadcast_to(reason, r.shape), "action": action})


def with_file_units(table: pd.DataFrame, angle_units: Mapping[str, str]) -> pd.DataFrame:
    """``table`` with ``unit``, ``file_unit``, ``value_file_unit`` and
    ``residual_file_unit`` set: angles in their sensor's ``angle_unit`` (``angle_units``:
    sensor id -> "deg" / "rad" / "mil"; "rad" when not given), the rest as in SI."""
    comp = table["component"].astype(str)
    unit = comp.map(SI_UNITS).fillna("").to_numpy(dtype=object)
    angle = comp.isin(ANGLE_COMPONENTS).to_numpy()
    file_unit = np.where(angle, table["sensor"].map(dict(angle_units)).fillna("rad")
                         .to_numpy(dtype=object), unit)
    per_radian = pd.Series(file_unit, dtype=object).map(
        {u: 1.0 / f for u, f in ANGLE_TO_RADIANS.items()}).fillna(1.0).to_numpy(dtype=float)
    scale = np.where(angle, per_radian, 1.0)
    return table.assign(unit=unit, file_unit=file_unit,
                        value_file_unit=table["value"].to_numpy(dtype=float) * scale,
                        residual_file_unit=table["residual"].to_numpy(dtype=float) * scale)


def edit_table(record: EditRecord, fused: Sequence[tuple[str, FusionResult]],
               logs: Mapping[str, SensorLog],
               angle_units: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Every rejection and material down-weighting of a run, sorted by sensor, row and
    component (``angle_units``: sensor id -> its file's ``angle_unit``, default "rad")."""
    parts = [screened_residuals(screening_edits(record), fused, logs),
             *(gate_rejections(res, logs) for _, res in fused),
             *(down_weighted(res, logs) for _, res in fused)]
    table = _frame([p for p in parts if len(p)])
    table = with_file_units(table, angle_units or {})
    return table.sort_values(["sensor", "row", "component"], kind="stable",
                             ignore_index=True)


_DTYPES = {"sensor": object, "row": np.int64, "time": float, "component": object,
           "value": float, "residual": float, "normalised_residual": float, "weight": float,
           "reason": object, "action": object, "unit": object, "file_unit": object,
           "value_file_unit": float, "residual_file_unit": float}


def _frame(parts: list[pd.DataFrame]) -> pd.DataFrame:
    """Concatenate with the columns and dtypes of ``EDIT_COLUMNS`` (also when empty; the
    unit columns are filled by :func:`with_file_units`)."""
    empty = pd.DataFrame({name: pd.Series(dtype=_DTYPES[name]) for name in EDIT_COLUMNS})
    table = pd.concat([empty, *parts], ignore_index=True) if parts else empty
    table = table[list(EDIT_COLUMNS)]
    return table.astype({"sensor": str, "row": np.int64, "component": str, "reason": str,
                         "action": str})
