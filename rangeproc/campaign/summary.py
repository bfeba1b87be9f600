"""The campaign's instrument accuracy assessment: ``campaign.parquet``, one row per sortie and
sensor, from each sortie's ``summary.json``.

Columns: ``sortie``, ``status``, ``sensor``, ``kind``; counts ``n_read``, ``n_used``,
``n_rejected`` (wild), ``n_edited``; the sensor's span ``t_first``, ``t_last`` (s, range time
scale); per noise component ``noise_<c>`` (estimated 1-sigma, SI) and ``noise_<c>_apriori``;
per calibration term ``cal_<t>`` (estimate, SI), ``cal_<t>_sigma`` (its 1-sigma, NaN when
unobservable) and ``cal_<t>_moved``; and ``calibration_moved`` (any term).

**Moved.** A term of a sensor has moved at a sortie when its estimate differs from the same
sensor's estimate in the previous sortie that had one (campaign order) by more than
:data:`MOVE_SIGMAS` times the combined 1-sigma ``sqrt(s1² + s2²)``: the instrument's
calibration changed between the two flights beyond what either flight's uncertainty allows.
"""
from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from rangeproc.campaign.sortie import Outcome
from rangeproc.summary_types import RunSummary

#: Combined sigmas beyond which a calibration term counts as moved between two sorties.
MOVE_SIGMAS = 3.0
KEYS = ("sortie", "status", "sensor", "kind")


def sortie_rows(sortie: str, status: str, summary: RunSummary) -> list[dict]:
    """The table's rows of one sortie (one per sensor) from its ``summary.json``."""
    rows = []
    for sid, s in summary.get("sensors", {}).items():
        row: dict = {"sortie": sortie, "status": status, "sensor": sid, "kind": s.get("kind"),
                     "n_read": s.get("n_read"), "n_used": s.get("n_used"),
                     "n_rejected": s.get("n_rejected"),
                     "n_edited": sum((s.get("n_edited") or {}).values()),
                     "t_first": s.get("t_first"), "t_last": s.get("t_last")}
        for comp, n in (s.get("noise") or {}).items():
            row[f"noise_{comp}"] = n.get("estimated")
            row[f"noise_{comp}_apriori"] = n.get("apriori")
        for term, c in (s.get("calibration") or {}).items():
            row[f"cal_{term}"] = c.get("estimate")
            row[f"cal_{term}_sigma"] = c.get("sigma")
        rows.append(row)
    return rows


def campaign_table(outcomes: Sequence[Outcome]) -> pd.DataFrame:
    """``campaign.parquet``'s table (module docstring) over the sorties that have outputs."""
    rows = []
    for o in outcomes:
        if o.status in ("done", "skipped") and o.out_dir:
            summary = json.loads((Path(o.out_dir) / "summary.json").read_text())
            rows.extend(sortie_rows(o.id, o.status, summary))
    table = pd.DataFrame(rows)
    if table.empty:
        return pd.DataFrame(columns=[*KEYS, "calibration_moved"])
    terms = sorted({c[4:] for c in table.columns
                    if c.startswith("cal_") and not c.endswith("_sigma")})
    for c in table.columns:
        if c not in KEYS:
            table[c] = pd.to_numeric(table[c], errors="coerce")
    moved_any = np.zeros(len(table), dtype=bool)
    for term in terms:
        moved = moved_between_sorties(table, f"cal_{term}", f"cal_{term}_sigma")
        table[f"cal_{term}_moved"] = moved
        moved_any |= moved
    table["calibration_moved"] = moved_any
    return table


def moved_between_sorties(table: pd.DataFrame, value: str, sigma: str) -> np.ndarray:
    """(N,) bool: the row's ``value`` differs from the same sensor's previous finite value
    (rows in campaign order) by more than :data:`MOVE_SIGMAS` combined sigmas."""
    out = np.zeros(len(table), dtype=bool)
    for _, idx in table.groupby("sensor", sort=False).indices.items():
        v = table[value].to_numpy(float)[idx]
        s = table[sigma].to_numpy(float)[idx]
        prev = None
        for k in range(len(idx)):
            if not (np.isfinite(v[k]) and np.isfinite(s[k])):
                continue
            if prev is not None:
                pv, ps = prev
                out[idx[k]] = abs(v[k] - pv) > MOVE_SIGMAS * np.hypot(s[k], ps)
            prev = (v[k], s[k])
    return out
