"""Which rows each object is fused from, and the record of where every row went.

``object_rows`` is the pipeline's association stage: GPS and MISTRAM rows go to the target
their sensor names (DATA_CONTRACT section 2); radar and theodolite rows go through track
synthesis (``tracking.synthesis``). ``association_table`` is ``association.parquet``
(DATA_CONTRACT section 4: one row per radar/theodolite input row) and
``association_summary`` the summary's ``association`` section.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
import pandas as pd

from rangeproc.config import Config, SensorSettings
from rangeproc.fusion.assemble import Assembled
from rangeproc.fusion.batch import SensorRows
from rangeproc.fusion.estimator_types import EstimatorSettings
from rangeproc.fusion.initialise import Prior
from rangeproc.summary_types import AssociatedObject, AssociationSummary
from rangeproc.tracking.synthesis import Synthesis, synthesise

#: Kinds whose rows are associated (the others name their target).
ASSOCIATED_KINDS = ("radar", "theodolite")
#: ``reason`` of input rows that never reached association (edited, no platform geometry).
NOT_ASSOCIATED = "removed before association (see edits.parquet)"
ASSOCIATION_COLUMNS = ("sensor", "row", "time", "target_id", "segment", "reason")


def target_of(sensor: SensorSettings, cfg: Config) -> str:
    """The declared target a GPS or MISTRAM sensor measures (its ``target``, else the first)."""
    if sensor.target is not None:
        return sensor.target
    return cfg.targets[0].id


def _subset(rows: SensorRows, sel: np.ndarray) -> SensorRows:
    if sel.size == rows.t.size:
        return rows
    return SensorRows(**{f: getattr(rows, f)[sel] for f in SensorRows.__slots__})


def object_rows(cfg: Config, rows: Mapping[str, Assembled], settings: EstimatorSettings,
                priors: Mapping[str, Prior | None],
                tick: Callable[..., None] = lambda *a, **k: None
                ) -> tuple[dict[str, list[tuple[int, SensorRows]]], Synthesis | None]:
    """Object id -> [(sensor index, rows)] in output order, and the synthesis (None when no
    radar/theodolite has rows: every sensor then names its target, as for one object)."""
    ids = tuple(s.id for s in cfg.sensors)
    index = {sid: i for i, sid in enumerate(ids)}
    kinds = [s.kind for s in cfg.sensors]
    associated = [sid for sid, a in rows.items()
                  if kinds[index[sid]] in ASSOCIATED_KINDS and len(a.rows.t)]
    anchors = {t.id: [index[s.id] for s in cfg.sensors if s.kind in ("gps", "mistram")
                      and target_of(s, cfg) == t.id and s.id in rows] for t in cfg.targets}
    if not associated:
        out = {t.id: [(i, rows[ids[i]].rows) for i in anchors[t.id] if len(rows[ids[i]].rows.t)]
               for t in cfg.targets}
        tick(1, "")
        return out, None
    syn = synthesise({index[sid]: a.rows for sid, a in rows.items()}, kinds, ids, anchors,
                     [t.id for t in cfg.targets], settings,
                     priors={k: v for k, v in priors.items() if v is not None})
    tick(1, "")
    out = {name: [(i, _subset(rows[ids[i]].rows, sel)) for i, sel in parts]
           for name, parts in syn.members.items()}
    for t in cfg.targets:
        out.setdefault(t.id, [])
    return out, syn


def stray_points(cfg: Config, rows: Mapping[str, Assembled], syn: Synthesis | None,
                 most: int = 200_000) -> np.ndarray:
    """(M, 3) range ENU m of the unassigned radar/theodolite rows with range (clutter and the
    rows no object fits), for the plan view; at most ``most``, evenly spread."""
    if syn is None:
        return np.zeros((0, 3))
    out = []
    for i, s in enumerate(cfg.sensors):
        if i not in syn.row_object or s.id not in rows:
            continue
        r = rows[s.id].rows
        sel = np.flatnonzero((syn.row_object[i] == "") & np.isfinite(r.z[:, 0])
                             & np.isfinite(r.z[:, 1]))
        if sel.size == 0:
            continue
        z = r.z[sel]
        el = np.where(np.isfinite(z[:, 2]), z[:, 2], 0.0)
        d = np.column_stack([z[:, 0] * np.cos(el) * np.sin(z[:, 1]),
                             z[:, 0] * np.cos(el) * np.cos(z[:, 1]), z[:, 0] * np.sin(el)])
        out.append(r.s[sel] + np.einsum("nji,nj->ni", r.Qr[sel], d))
    if not out:
        return np.zeros((0, 3))
    pts = np.concatenate(out)
    if len(pts) > most:
        pts = pts[np.linspace(0, len(pts) - 1, most).astype(np.int64)]
    return pts


def association_table(cfg: Config, syn: Synthesis | None,
                      file_rows: Mapping[str, tuple[np.ndarray, np.ndarray]],
                      kept: Mapping[str, np.ndarray], n_read: Mapping[str, int],
                      single: str | None) -> pd.DataFrame:
    """``association.parquet``: every radar/theodolite input row (0-based data row).

    file_rows: sensor id -> (1-based file row, time) of its screened log rows; kept: sensor
    id -> indices of those log rows that became measurement rows (source_row); n_read: rows
    in each file; single: the target of every row when there was no synthesis.
    """
    parts = []
    for i, s in enumerate(cfg.sensors):
        if s.kind not in ASSOCIATED_KINDS:
            continue
        n = n_read[s.id]
        target = np.full(n, "", dtype=object)
        segment = np.full(n, -1, dtype=np.int64)
        reason = np.full(n, NOT_ASSOCIATED, dtype=object)
        time = np.full(n, np.nan)
        file_row, log_time = file_rows[s.id]
        time[file_row - 1] = log_time
        src = kept[s.id]
        at = file_row[src] - 1
        if syn is not None and i in syn.row_object:
            target[at] = syn.row_object[i]
            segment[at] = syn.row_segment[i]
            reason[at] = syn.row_reason[i]
        elif single is not None:
            target[at] = single
            reason[at] = "associated"
        parts.append(pd.DataFrame({"sensor": s.id, "row": np.arange(n, dtype=np.int64),
                                   "time": time, "target_id": target, "segment": segment,
                                   "reason": reason}))
    if not parts:
        return pd.DataFrame({c: pd.Series(dtype=d) for c, d in zip(
            ASSOCIATION_COLUMNS, (str, np.int64, float, str, np.int64, str))})
    table = pd.concat(parts, ignore_index=True)
    return table.astype({"sensor": str, "target_id": str, "reason": str})


def association_summary(syn: Synthesis | None, sensor_ids: tuple[str, ...]
                        ) -> AssociationSummary:
    """The summary's ``association``: objects and their segments, the chosen hypothesis'
    score and the runner-up's (over the searches, summed), whether the search was exact,
    per sensor with angle-only plots the share of them associated by line of sight, per
    plot sensor its stationary returns, the re-association rounds of the plots and their
    ambiguous stretches (object, runner-up, sensor, t0, t1 s, plots, llr margin)
    (``summary_types.AssociationSummary``)."""
    if syn is None:
        return {"n_segments": 0, "objects": {}, "score": None, "runner_up": None,
                "exact": True}
    objects: dict[str, AssociatedObject] = {}
    for seg in syn.segments:
        name = syn.segment_object[seg.id]
        if name is None:
            continue
        o = objects.setdefault(name, {"discovered": name in syn.discovered, "segments": []})
        o["segments"].append({"segment": seg.id, "sensor": sensor_ids[seg.sensor],
                              "track_id": seg.track, "rows": int(seg.rows.size),
                              "t0": seg.t0, "t1": seg.t1})
    best = sum(r.best.score for r in syn.searches)
    runner = [r for r in syn.searches if r.runner_up is not None]
    return {
        "n_segments": len(syn.segments),
        "n_unassigned_segments": sum(v is None for v in syn.segment_object.values()),
        "objects": objects,
        "score": best,
        # the best alternative: the runner-up of the closest-run search, the others as chosen
        "runner_up": None if not runner else {
            "score": best - min(r.best.score - r.runner_up.score for r in runner),
            "search": int(np.argmin([r.best.score - r.runner_up.score for r in runner]))},
        "exact": all(r.exact for r in syn.searches),
        "n_searches": len(syn.searches),
        # camera/theodolite detections without range, joined to objects by line of sight
        "angle_plots": {sensor_ids[i]: {"n_rows": n, "n_associated": k,
                                        "fraction_used": k / n if n else None}
                        for i, (n, k) in sorted(syn.angle_plots.items())},
        # quays, moored boats, shore: places with plots in most scans (range ENU m)
        "stationary_returns": {sensor_ids[i]: cells
                               for i, cells in sorted(syn.stationary.items())},
        # plots re-associated against the smoothed objects until stable (rounds, plots
        # moved per round), and the stretches where a runner-up object came close
        "plot_rounds": syn.plot_rounds,
        "ambiguous_plots": [{**a, "sensor": sensor_ids[a["sensor"]]} for a in syn.ambiguous]}
