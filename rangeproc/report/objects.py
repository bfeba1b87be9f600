"""``objects.png`` and ``map.png``: which sensor saw which object when, and where each went.

``plot_object_timeline`` draws one lane per object (and one for the unassigned rows) from
``association.parquet`` (``tracking.routing.association_table``): a thin sub-row per sensor
with bars where that sensor's rows belonged to the object, swaps (a sensor's track moved to
another object), relays (another sensor took the object over after a gap) and the bridged
stretches of the fused track (no used measurement within ``BRIDGED_GAP`` s).
``plot_map`` draws every object's fused track in plan view, bridged stretches dashed, over
the unassigned / clutter plots in grey.

Times are seconds on the range time scale (``since t0`` where a name says so); positions are
range ENU metres, drawn in km. Drawing cost is bounded by the pixel grid, not by the row
count: bars are merged to ``RESOLUTION`` cells across the time axis, grey plots are thinned
to ``MAX_STRAY`` points, tracks to ``MAX_TRACK_POINTS`` epochs.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.transforms import blended_transform_factory

from rangeproc.report.common import CYCLE, break_gaps, new_figure, stride_indices, t0_note, \
    time_axis, true_runs
from rangeproc.report.timeline import RESOLUTION, _median_step, used_spans
from rangeproc.report.mapview import (Label, direction_arrow, edge_point, inside, map_extent,
                                      place_labels, site_points)
from rangeproc.report.trajectory import MAX_TRACK_POINTS, _draw_sites
from rangeproc.results import TrackEstimate

#: An epoch is bridged when its nearest used measurement (``data_gap``) is farther (s).
BRIDGED_GAP = 1.0
#: Bridged runs closer than this (s) are hatched as one: an object seen only by a radar
#: turning every 4 s is bridged between every two plots, and hundreds of hatched slivers
#: neither read better nor draw fast (objects.png of the 30-minute scale scenario: 0.86 s
#: to draw with them, 0.33 s without).
BRIDGED_JOIN = 5.0
#: Rows of one sensor more than this many of its median steps apart are separate bars.
GAP_STEPS = 3.0
#: Two consecutive segments of one sensor on different objects are a swap when the second
#: starts within max(SWAP_MIN_SECONDS, SWAP_STEPS x the sensor's step) of the first's end:
#: a cut in one continuous sensor track (``tracking.segments`` ends a segment at a longer
#: pause, after which the sensor acquired something new rather than swapped).
SWAP_STEPS = 10.0
SWAP_MIN_SECONDS = 2.0
#: Most unassigned / clutter plots drawn in the plan view.
MAX_STRAY = 20_000
#: Lane of the rows with an empty ``target_id``.
UNASSIGNED = "unassigned"
#: Sensor colours of the timeline (objects keep ``CYCLE``, as in trajectory.png / map.png).
SENSOR_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02",
                 "#a6761d", "#393b79", "#843c39", "#17becf")
STRAY_COLOR = "0.6"
HATCH_COLOR = "0.35"
#: Most legend entries per row in the timeline.
LEGEND_COLUMNS = 7
#: (lane, sensor) -> y of that sensor's sub-row in that object's lane.
RowY = Callable[[int, int], float]


def object_color(k: int) -> str:
    """Colour of the k-th object (tracks' order), the same in every figure."""
    return CYCLE[k % len(CYCLE)]


def _codes(column: pd.Series) -> tuple[np.ndarray, list[str]]:
    """(N,) int64 codes into the distinct values (first-seen order); missing values are ''."""
    codes, uniq = pd.factorize(column, use_na_sentinel=True)
    names = [str(u) for u in uniq]
    if (codes < 0).any():
        if "" not in names:
            names.append("")
        codes = np.where(codes < 0, names.index(""), codes)
    return np.asarray(codes, dtype=np.int64), names


def object_segments(association: pd.DataFrame) -> pd.DataFrame:
    """One row per segment of the association table (rows with ``segment >= 0`` and a time).

    Returns columns segment (int), sensor (str), target_id (str, '' = unassigned), t0, t1
    (s, first and last row time), rows (int), sorted by (sensor, segment).
    """
    scode, sensors = _codes(association["sensor"])
    tcode, targets = _codes(association["target_id"])
    return _segments(association["segment"].to_numpy(dtype=np.int64),
                     association["time"].to_numpy(dtype=float), scode, sensors, tcode, targets)


def _segments(seg: np.ndarray, t: np.ndarray, scode: np.ndarray, sensors: list[str],
              tcode: np.ndarray, targets: list[str]) -> pd.DataFrame:
    ok = (seg >= 0) & np.isfinite(t)
    g = pd.DataFrame({"segment": seg[ok], "s": scode[ok], "o": tcode[ok], "t": t[ok]}).groupby(
        "segment", sort=True).agg(s=("s", "first"), o=("o", "first"), t0=("t", "min"),
                                  t1=("t", "max"), rows=("t", "size"))
    out = pd.DataFrame({"segment": g.index.to_numpy(dtype=np.int64),
                        "sensor": np.array(sensors + [""], dtype=object)[g["s"].to_numpy()],
                        "target_id": np.array(targets + [""], dtype=object)[g["o"].to_numpy()],
                        "t0": g["t0"].to_numpy(dtype=float), "t1": g["t1"].to_numpy(dtype=float),
                        "rows": g["rows"].to_numpy(dtype=np.int64)})
    return out.sort_values(["sensor", "segment"], kind="stable").reset_index(drop=True)


def find_swaps(segments: pd.DataFrame, max_gap: Mapping[str, float] | float) -> pd.DataFrame:
    """Swaps: a sensor's consecutive segments (by id) assigned to two different objects, the
    second starting no earlier than the first's end and within ``max_gap`` s of it
    (a mapping gives the limit per sensor id).

    segments: as from :func:`object_segments`. Returns columns sensor, from_id, to_id,
    t_end (s, last row on the first object), t_start (s, first row on the second).
    """
    cols = ["sensor", "from_id", "to_id", "t_end", "t_start"]
    if len(segments) < 2:
        return pd.DataFrame({c: [] for c in cols})
    s = segments.sort_values(["sensor", "segment"], kind="stable")
    sen, tgt = s["sensor"].to_numpy(), s["target_id"].to_numpy()
    t0, t1 = s["t0"].to_numpy(dtype=float), s["t1"].to_numpy(dtype=float)
    lim = np.array([max_gap.get(x, SWAP_MIN_SECONDS) if isinstance(max_gap, Mapping)
                    else float(max_gap) for x in sen[1:]])
    gap = t0[1:] - t1[:-1]
    hit = ((sen[1:] == sen[:-1]) & (tgt[1:] != tgt[:-1]) & (tgt[1:] != "") & (tgt[:-1] != "")
           & (gap >= 0.0) & (gap <= lim))
    i = np.flatnonzero(hit)
    return pd.DataFrame({"sensor": sen[i + 1], "from_id": tgt[i], "to_id": tgt[i + 1],
                         "t_end": t1[i], "t_start": t0[i + 1]}, columns=cols)


def find_relays(segments: pd.DataFrame) -> pd.DataFrame:
    """Relays: a segment of an object starting after a gap in which no segment of that object
    was active, when the segment that ended last before the gap is another sensor's.

    segments: as from :func:`object_segments`. Returns columns target_id, from_sensor,
    to_sensor, t_end (s, the object's last row before the gap), t_start (s, first row after).
    """
    out: list[tuple[str, str, str, float, float]] = []
    assigned = segments[segments["target_id"] != ""]
    for name, part in assigned.groupby("target_id", sort=False):
        part = part.sort_values(["t0", "t1"], kind="stable")
        end, last = -np.inf, None
        for sen, a, b in zip(part["sensor"], part["t0"], part["t1"]):
            if last is not None and a > end and sen != last:
                out.append((str(name), last, sen, end, a))
            if b > end:
                end, last = b, sen
    return pd.DataFrame(out, columns=["target_id", "from_sensor", "to_sensor", "t_end",
                                      "t_start"])


def bridged_runs(track: TrackEstimate, limit: float = BRIDGED_GAP) -> np.ndarray:
    """(B, 2) s: first and last epoch of each run of epochs with ``data_gap > limit``."""
    if track.data_gap is None or np.size(track.time) == 0:
        return np.zeros((0, 2))
    start, stop = true_runs(np.asarray(track.data_gap, dtype=float) > limit)
    t = np.asarray(track.time, dtype=float)
    return np.column_stack([t[start], t[stop - 1]])


def joined_runs(runs: np.ndarray, join: float = BRIDGED_JOIN) -> np.ndarray:
    """Runs (B, 2) s with those less than ``join`` s apart merged into one (drawing only)."""
    if len(runs) < 2:
        return runs
    new = np.concatenate([[True], runs[1:, 0] - runs[:-1, 1] >= join])
    first = np.flatnonzero(new)
    last = np.concatenate([first[1:] - 1, [len(runs) - 1]])
    return np.column_stack([runs[first, 0], runs[last, 1]])


def _named_sensor_epochs(tracks: Sequence[TrackEstimate], known: set[str]
                         ) -> dict[tuple[int, str], np.ndarray]:
    """(track index, sensor id) -> (E,) epoch times (s) at which a sensor absent from the
    association table (GPS / MISTRAM: they name their object) fed the fused track."""
    out: dict[tuple[int, str], np.ndarray] = {}
    for k, tr in enumerate(tracks):
        if tr.sensors is None or np.size(tr.sensors) == 0:
            continue
        codes, uniq = pd.factorize(np.asarray(tr.sensors, dtype=object))
        members: dict[str, list[int]] = {}
        for j, text in enumerate(uniq):
            for sid in str(text).split(","):
                if sid.strip() and sid.strip() not in known:
                    members.setdefault(sid.strip(), []).append(j)
        for sid, js in members.items():
            out[(k, sid)] = np.asarray(tr.time, dtype=float)[np.isin(codes, js)]
    return out


def plot_object_timeline(association: pd.DataFrame, tracks: Sequence[TrackEstimate],
                         t0: float) -> Figure:
    """Draw the per-object coverage timeline (``objects.png``).

    association: ``association.parquet`` as a DataFrame, columns sensor (str), row, time
    (s, range time scale; NaN rows are skipped), target_id (str, '' = unassigned), segment
    (int, -1 = none), reason (str); any number of rows (2 million draw in seconds).
    tracks: fused objects, in lane order; their ``data_gap`` (K,) s gives the bridged
    stretches (> ``BRIDGED_GAP``), their ``sensors`` (K,) the epochs fed by sensors that are
    not in the table (GPS / MISTRAM). t0: time origin (s) of the x axis.
    """
    tracks = list(tracks)
    t_all = association["time"].to_numpy(dtype=float)
    scode_all, sensors = _codes(association["sensor"])
    tcode_all, targets = _codes(association["target_id"])
    segs = _segments(association["segment"].to_numpy(dtype=np.int64), t_all, scode_all,
                     sensors, tcode_all, targets)
    reasons = _reason_counts(association["reason"], tcode_all, targets)
    ok = np.isfinite(t_all)
    t, scode, tcode = t_all[ok] - t0, scode_all[ok], tcode_all[ok]
    names = [tr.target_id for tr in tracks]
    names += [x for x in targets if x and x not in names]
    lanes = names + [UNASSIGNED]
    lane_of = np.array([len(names) if x == "" else names.index(x) for x in targets],
                       dtype=np.int64)
    lane = lane_of[tcode] if tcode.size else np.zeros(0, dtype=np.int64)
    table_sensors = [str(s) for s in sensors]
    named = _named_sensor_epochs(tracks, set(table_sensors))
    sensor_ids = table_sensors + list(dict.fromkeys(sid for _, sid in named))
    n_lane, n_sen = len(lanes), max(len(sensor_ids), 1)
    key = lane * n_sen + scode
    order = np.lexsort((t, key))
    t, key, lane, scode = t[order], key[order], lane[order], scode[order]

    # x range and pixel cell: every bar is at least one cell wide, gaps under a cell merge
    ends = [t[[0, -1]]] if t.size else []
    ends += [np.asarray(tr.time, dtype=float)[[0, -1]] - t0 for tr in tracks if tr.time.size]
    lo = min((float(np.nanmin(e)) for e in ends), default=0.0)
    hi = max((float(np.nanmax(e)) for e in ends), default=1.0)
    span = max(hi - lo, 1e-9)
    cell = span / RESOLUTION

    step, bar_key, bar_t0, bar_t1 = _sensor_bars(t, key, scode, lane, len(names),
                                                 len(table_sensors), cell)
    rows_per_lane = np.bincount(lane_of[tcode_all], minlength=n_lane) if tcode_all.size \
        else np.zeros(n_lane, dtype=np.int64)

    swaps = find_swaps(segs, {sid: max(SWAP_MIN_SECONDS, SWAP_STEPS * step[i])
                              for i, sid in enumerate(table_sensors)})
    relays = find_relays(segs)

    handles = _timeline_legend(sensor_ids, len(table_sensors), bool(len(swaps)),
                               bool(len(relays)))
    ncol = min(len(handles), LEGEND_COLUMNS)
    top = 1.6 + 0.2 * -(-len(handles) // ncol)        # title, reasons line, legend rows (in)
    height = max(0.5, 0.17 * n_sen + 0.2)
    fig = new_figure(14.0, top + 0.6 + height * n_lane)
    fh = fig.get_figheight()
    box = (0.14, 0.6 / fh, 0.76, 1.0 - top / fh)
    ax = fig.add_axes(box)

    def y_of(ln: int, s: int) -> float:
        """Centre of sensor s's sub-row in lane ln (lane 0 at the top, lanes 1 unit tall)."""
        return (n_lane - 1 - ln) + 0.42 - (s + 0.5) * 0.84 / n_sen

    bar_h = 0.84 / n_sen * 0.78
    for ln in range(n_lane):
        base = n_lane - 1 - ln
        if ln % 2 == 0:
            ax.axhspan(base - 0.5, base + 0.5, color="0.96", lw=0, zorder=0)
        if ln < len(tracks) and tracks[ln].time.size:   # where the object has an estimate
            tr = tracks[ln]
            spans = tr.spans or ((float(tr.time[0]), float(tr.time[-1])),)
            ax.broken_barh([(a - t0, max(b - a, cell)) for a, b in spans], (base - 0.46, 0.92),
                           facecolors=object_color(ln), alpha=0.09, lw=0, zorder=0.5)
            runs = joined_runs(bridged_runs(tr))
            if runs.size:
                bars = ax.broken_barh([(a - t0, max(b - a, cell)) for a, b in runs],
                                      (base - 0.46, 0.92), facecolors="none",
                                      edgecolors=HATCH_COLOR, hatch="////", lw=0.5, zorder=1)
                bars.set_gid("bridged")
    for k in np.unique(bar_key):
        ln, s = divmod(int(k), n_sen)
        sel = bar_key == k
        a, b = bar_t0[sel], bar_t1[sel]
        ax.broken_barh(list(zip(a, np.maximum(b - a, cell))), (y_of(ln, s) - bar_h / 2, bar_h),
                       facecolors=SENSOR_COLORS[s % len(SENSOR_COLORS)], lw=0, zorder=2,
                       alpha=0.55 if ln == len(names) else 1.0)
    for (k, sid), et in named.items():
        s = sensor_ids.index(sid)
        a, b = used_spans(et - t0, gap=max(GAP_STEPS * _median_step(et), cell))
        ax.broken_barh(list(zip(a, np.maximum(b - a, cell))), (y_of(k, s) - bar_h / 2, bar_h),
                       facecolors=SENSOR_COLORS[s % len(SENSOR_COLORS)], lw=0, zorder=2)
    _draw_swaps(ax, swaps, lanes, sensor_ids, y_of, t0)
    _draw_relays(ax, relays, lanes, sensor_ids, y_of, t0)

    for ln in range(1, n_lane):
        ax.axhline(n_lane - 0.5 - ln, color="0.55", lw=0.7, zorder=1)
    seg_lane = segs["target_id"].replace("", UNASSIGNED).value_counts()
    labels = []
    for ln, name in enumerate(lanes):
        n_rows = int(rows_per_lane[ln])
        note = f"{n_rows:,} rows, {int(seg_lane.get(name, 0))} seg."
        if ln < len(tracks):
            runs = bridged_runs(tracks[ln])
            if runs.size:
                note += f"\nbridged {float(np.sum(runs[:, 1] - runs[:, 0])):.1f} s"
        labels.append(f"{name}\n{note}")
    ax.set_yticks(np.arange(n_lane)[::-1])
    ax.set_yticklabels(labels, fontsize=8, linespacing=1.1)
    for ln, tl in enumerate(ax.get_yticklabels()):
        tl.set_color("0.3" if ln == len(names) else object_color(ln))
        tl.set_fontweight("bold")
    ax.tick_params(axis="y", length=0)
    ax.set_ylim(-0.5, n_lane - 0.5)
    ax.set_xlim(lo - 0.01 * span, hi + 0.01 * span)
    time_axis(ax, t0)
    ax.grid(axis="y", visible=False)
    _sensor_axis(ax, sensor_ids, n_lane, y_of)

    n_assigned = int((segs["target_id"] != "").sum())
    fig.suptitle(f"Objects: which sensor saw which object when - {_n(len(names), 'object')}, "
                 f"{_n(len(segs), 'segment')} ({n_assigned} on objects), "
                 f"{_n(len(swaps), 'swap')}, {_n(len(relays), 'relay')}", fontsize=12,
                 fontweight="bold", y=1.0 - 0.1 / fh, va="top")
    fig.text(0.5, 1.0 - 0.42 / fh, _unassigned_note(reasons), ha="center", va="top",
             fontsize=8.5, color="0.25")
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")
    fig.legend(handles=handles, loc="upper center", ncol=ncol,
               frameon=False, bbox_to_anchor=(0.52, 1.0 - 0.66 / fh), fontsize=7.5,
               handlelength=1.6, columnspacing=1.2)
    if not t.size and not tracks:
        ax.text(0.5, 0.5, "no association rows", transform=ax.transAxes, ha="center",
                va="center", fontsize=12, color="0.4")
    return fig


def _sensor_bars(t: np.ndarray, key: np.ndarray, scode: np.ndarray, lane: np.ndarray,
                 unassigned: int, n_table: int, cell: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Merge rows into bars. t: (N,) s, key: (N,) lane x sensor sub-row, sorted by (key, t);
    scode, lane: (N,) sensor and lane index; unassigned: the unassigned lane's index.

    A sensor's step is the median spacing of its consecutive rows on one object (its
    unassigned rows when it has none); a bar ends at a gap longer than ``GAP_STEPS`` steps
    or one time cell (``cell`` s), whichever is longer. Returns step (n_table,) s and
    per bar its key, first and last time (s).
    """
    same = key[1:] == key[:-1]
    dt = np.diff(t)
    step = np.zeros(max(n_table, 1))
    for s in range(n_table):
        mine = same & (scode[:-1] == s) & (dt > 0)
        on_obj = mine & (lane[:-1] != unassigned)
        pick = dt[on_obj] if on_obj.any() else dt[mine]
        step[s] = float(np.median(pick)) if pick.size else 0.0
    if t.size == 0:
        return step, np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros(0)
    limit = np.maximum(GAP_STEPS * step, cell)
    brk = np.flatnonzero(~same | (dt > limit[scode[:-1]]))
    first = np.concatenate([[0], brk + 1])
    last = np.concatenate([brk, [t.size - 1]])
    return step, key[first], t[first], t[last]


def _n(count: int, noun: str) -> str:
    return f"{count:,} {noun}" + ("" if count == 1 else "s")


def _reason_counts(reason: pd.Series, tcode: np.ndarray, targets: list[str]) -> pd.Series:
    """Unassigned rows (empty target_id) per reason, most frequent first."""
    if "" not in targets:
        return pd.Series(dtype=np.int64)
    return reason[tcode == targets.index("")].value_counts()


def _unassigned_note(counts: pd.Series) -> str:
    """'unassigned rows (N): clutter 1,234 · no object fits 56 ...' (most frequent first)."""
    if counts.empty:
        return "unassigned rows: none"
    parts = [f"{reason} {int(n):,}" for reason, n in counts.items()]
    return f"unassigned rows ({int(counts.sum()):,}): " + " · ".join(parts)


def _draw_swaps(ax: Axes, swaps: pd.DataFrame, lanes: list[str], sensor_ids: list[str],
                y_of: RowY, t0: float) -> None:
    """A vertical arrow per swap, in the sensor's colour, from its sub-row in the object it
    left to its sub-row in the object it moved to (at the middle of the hand-over)."""
    if swaps.empty:
        return
    x = 0.5 * (swaps["t_end"].to_numpy() + swaps["t_start"].to_numpy()) - t0
    s = np.array([sensor_ids.index(v) for v in swaps["sensor"]])
    y0 = np.array([y_of(lanes.index(v), i) for v, i in zip(swaps["from_id"], s)])
    y1 = np.array([y_of(lanes.index(v), i) for v, i in zip(swaps["to_id"], s)])
    colors = [SENSOR_COLORS[i % len(SENSOR_COLORS)] for i in s]
    segs = np.stack([np.column_stack([x, y0]), np.column_stack([x, y1])], axis=1)
    ax.add_collection(LineCollection(segs, colors="k", linewidths=2.6, zorder=4, gid="swap"))
    ax.add_collection(LineCollection(segs, colors=colors, linewidths=1.4, zorder=4.1))
    down = y1 < y0
    for mask, marker in ((down, "v"), (~down, "^")):
        if mask.any():
            ax.scatter(x[mask], y1[mask], marker=marker, s=42, c=[colors[i] for i in
                       np.flatnonzero(mask)], edgecolors="k", linewidths=0.7, zorder=5)
    ax.scatter(x, y0, marker="o", s=14, c=colors, edgecolors="k", linewidths=0.6, zorder=5)


def _draw_relays(ax: Axes, relays: pd.DataFrame, lanes: list[str], sensor_ids: list[str],
                 y_of: RowY, t0: float) -> None:
    """A dotted connector per relay inside the object's lane, from the last row of the sensor
    that lost the object to the first row of the one that took it over."""
    if relays.empty:
        return
    ln = np.array([lanes.index(v) for v in relays["target_id"]])
    y0 = np.array([y_of(a, sensor_ids.index(v)) for a, v in zip(ln, relays["from_sensor"])])
    y1 = np.array([y_of(a, sensor_ids.index(v)) for a, v in zip(ln, relays["to_sensor"])])
    x0 = relays["t_end"].to_numpy(dtype=float) - t0
    x1 = relays["t_start"].to_numpy(dtype=float) - t0
    ax.add_collection(LineCollection(
        np.stack([np.column_stack([x0, y0]), np.column_stack([x1, y1])], axis=1),
        colors="0.15", linewidths=1.1, linestyles=":", zorder=4, gid="relay"))
    ax.scatter(x1, y1, marker=">", s=30, c="0.15", zorder=5)


def _sensor_axis(ax: Axes, sensor_ids: list[str], n_lane: int, y_of: RowY) -> None:
    """Right-hand tick labels naming each sensor sub-row (every lane when few rows)."""
    rows = len(sensor_ids) * n_lane
    show = range(n_lane) if rows <= 60 else range(1)
    trans = blended_transform_factory(ax.transAxes, ax.transData)
    for ln in show:
        for s, sid in enumerate(sensor_ids):
            ax.text(1.004, y_of(ln, s), sid, transform=trans, fontsize=6.5, va="center",
                    ha="left", color=SENSOR_COLORS[s % len(SENSOR_COLORS)])


def _timeline_legend(sensor_ids: list[str], n_table: int, swaps: bool,
                     relays: bool) -> list:
    handles: list = [Patch(fc=SENSOR_COLORS[i % len(SENSOR_COLORS)],
                           label=sid if i < n_table else f"{sid} (names its object)")
                     for i, sid in enumerate(sensor_ids)]
    handles.append(Patch(fc=CYCLE[0], alpha=0.15, label="object estimated"))
    handles.append(Patch(fc="none", ec=HATCH_COLOR, hatch="////",
                         label=f"bridged: no data within {BRIDGED_GAP:g} s "
                               f"(or none for {BRIDGED_JOIN:g} s between data)"))
    if swaps:
        handles.append(Line2D([], [], color="k", lw=1.6, marker="v", ms=6,
                              label="swap: sensor's track moved to another object"))
    if relays:
        handles.append(Line2D([], [], color="0.15", lw=1.1, ls=":", marker=">", ms=5,
                              label="relay: another sensor took over after a gap"))
    return handles


def _step_ends(steps: np.ndarray) -> np.ndarray:
    """(K,) bool: the points at either end of a True step; steps: (K-1,) bool."""
    out = np.zeros(steps.size + 1, dtype=bool)
    out[:-1] |= steps
    out[1:] |= steps
    return out


def plot_map(tracks: Sequence[TrackEstimate], stray: np.ndarray,
             sites: Mapping[str, np.ndarray] | None) -> Figure:
    """Draw the map of every object (``map.png``).

    tracks: fused objects (range ENU m; ``data_gap`` (K,) s marks bridged epochs, drawn
    dashed); stray: (M, 3) range ENU m of the unassigned / clutter plots, drawn as grey dots
    (at most ``MAX_STRAY``, evenly strided); sites: id -> (3,) fixed ENU position (m) or
    (N, 3) platform track (m), drawn as in trajectory.png. Axes: east / north in km, equal
    aspect, fitted to the objects and the sensors near them (``report.mapview.map_extent``;
    without objects, to the plots); a sensor farther away is marked on the view's edge in its
    direction with its distance, and plots farther out are counted, not shown. Labels do not
    overprint each other (``report.mapview.place_labels``).
    """
    tracks = [tr for tr in tracks if np.size(tr.time) > 0]
    fig = new_figure(11.0, 9.5)
    ax = fig.add_axes((0.08, 0.07, 0.88, 0.84))
    p = np.asarray(stray if stray is not None else np.zeros((0, 3)), dtype=float)
    p = p.reshape(-1, 3) if p.size else np.zeros((0, 3))
    p = p[np.isfinite(p[:, :2]).all(axis=1)] / 1e3

    labels = _draw_sites(ax, sites or {})
    ext: list[np.ndarray] = []
    any_bridged = False
    for k, tr in enumerate(tracks):
        color = object_color(k)
        t = np.asarray(tr.time, dtype=float)
        br = (np.asarray(tr.data_gap, dtype=float) > BRIDGED_GAP if tr.data_gap is not None
              else np.zeros(t.size, dtype=bool))
        edges = np.flatnonzero(np.diff(br.astype(np.int8))) if br.size > 1 else np.zeros(0)
        idx = np.union1d(stride_indices(t.size, MAX_TRACK_POINTS),
                         np.concatenate([edges, edges + 1]).astype(np.int64))
        x = np.asarray(tr.x, dtype=float)[idx, :2] / 1e3
        tg, xg, bg = break_gaps(t[idx], x, br[idx].astype(float))
        e, n, b = xg[:, 0], xg[:, 1], bg
        dashed = (b[:-1] > 0.5) | (b[1:] > 0.5)     # a step touching a bridged epoch
        solid_pt, dash_pt = _step_ends(~dashed) | (e.size == 1), _step_ends(dashed)
        ax.plot(np.where(solid_pt, e, np.nan), np.where(solid_pt, n, np.nan), color=color,
                lw=1.8, zorder=3, label=tr.target_id, marker="o" if e.size == 1 else None)
        if dashed.any():
            any_bridged = True
            ax.plot(np.where(dash_pt, e, np.nan), np.where(dash_pt, n, np.nan), color=color,
                    lw=1.4, ls=(0, (3.5, 2.5)), zorder=3, gid="bridged")
        ax.plot(x[:1, 0], x[:1, 1], "o", ms=8, mfc="white", mec=color, mew=2, zorder=5)
        ax.plot(x[-1:, 0], x[-1:, 1], "s", ms=7, color=color, mec="k", mew=0.6, zorder=5)
        labels.insert(k, Label(x[0, 0], x[0, 1], tr.target_id, color=color, weight="bold",
                               size=9.0))
        ext.append(x[np.isfinite(x).all(axis=1)])
    ext = [a for a in ext if a.size]
    outside = 0
    stray_handle: list[Line2D] = []
    extent = map_extent(ext or ([p[:, :2]] if p.shape[0] else []), sites or {})
    if extent is not None:
        lo, hi = extent
        # widen the shorter side to the axes' shape, so equal aspect needs no other change
        bbox = ax.get_position()
        shape = (bbox.width * fig.get_figwidth()) / (bbox.height * fig.get_figheight())
        mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
        half = np.maximum(half, [half[1] * shape, half[0] / shape])
        lo, hi = mid - half, mid + half
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        in_view = ((p[:, 0] >= lo[0]) & (p[:, 0] <= hi[0]) & (p[:, 1] >= lo[1])
                   & (p[:, 1] <= hi[1]))
        outside = int((~in_view).sum())
    if p.shape[0]:
        j = stride_indices(p.shape[0], MAX_STRAY)
        label = f"unassigned / clutter plots ({p.shape[0]:,}"
        label += f", {j.size:,} drawn" if j.size < p.shape[0] else ""
        label += f", {outside:,} outside the view)" if outside else ")"
        ax.plot(p[j, 0], p[j, 1], ls="none", marker="o", ms=1.6, mew=0, color=STRAY_COLOR,
                alpha=0.7, zorder=1, gid="stray")
        stray_handle = [Line2D([], [], ls="none", marker="o", ms=5, mew=0, color=STRAY_COLOR,
                               label=label)]
    if extent is not None:
        ax.set_aspect("equal", adjustable="box")
        labels += _far_sites(ax, sites or {}, lo, hi)
    else:
        ax.set_aspect("equal", adjustable="datalim")
        ax.autoscale_view()
    ax.set_xlabel("east [km]")
    ax.set_ylabel("north [km]")
    ax.set_title("range ENU frame; ▲ fixed site, ◆ platform at end; hollow on the edge: a "
                 "sensor outside the view, its direction and distance", fontsize=8.5,
                 color="0.3")
    fig.suptitle(f"Map: {len(tracks)} objects, {p.shape[0]:,} unassigned / clutter "
                 "plots", fontsize=12, fontweight="bold")
    extra = [Line2D([], [], ls="none", marker="o", ms=7, mfc="white", mec="k", mew=1.6,
                    label="start"),
             Line2D([], [], ls="none", marker="s", ms=6, color="k", label="end")]
    if any_bridged:
        extra.append(Line2D([], [], color="k", lw=1.4, ls=(0, (3.5, 2.5)),
                            label=f"bridged: no data within {BRIDGED_GAP:g} s"))
    handles, _ = ax.get_legend_handles_labels()
    if handles or stray_handle:
        ax.legend(handles=handles + extra + stray_handle, loc="best",
                  title="object (fused track)", fontsize=8)
    if not tracks and not p.shape[0]:
        ax.text(0.5, 0.5, "no object, no unassigned plot", transform=ax.transAxes,
                ha="center", va="center", color="0.4", fontsize=11)
    place_labels(ax, labels)
    return fig


def _far_sites(ax: Axes, sites: Mapping[str, np.ndarray], lo: np.ndarray, hi: np.ndarray
               ) -> list[Label]:
    """A hollow marker on the view's edge for each sensor whose marker lies outside the view
    (``lo``-``hi`` km), toward it; its label gives the direction and the distance (km) from
    the view's centre. Returns the labels."""
    out = []
    centre = 0.5 * (lo + hi)
    for name, pos in sites.items():
        q = site_points(pos)
        if q.size == 0 or inside(q[-1], lo, hi):
            continue
        e = edge_point(q[-1], lo, hi)
        fixed = np.ndim(pos) == 1
        ax.plot(e[0], e[1], "^" if fixed else "D", ms=8 if fixed else 6, mfc="white",
                mec="k" if fixed else "0.3", mew=1.2, zorder=6, gid=f"far {name}")
        d = q[-1] - centre
        out.append(Label(e[0], e[1], name, f" {direction_arrow(d)} {np.hypot(*d):.3g} km"
                         + ("" if fixed else " (platform)"), color="k" if fixed else "0.2"))
    return out
