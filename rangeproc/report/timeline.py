"""``coverage.png``: when each sensor delivered used data, where it was rejected, and how many
sensors supported each target's estimate."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from matplotlib.transforms import blended_transform_factory

from rangeproc.report.common import (
    CYCLE,
    KIND_COLORS,
    REJECT_COLOR,
    SensorView,
    binned_extreme,
    n_sensors_colormap,
    n_sensors_running_max,
    new_figure,
    t0_note,
    time_axis,
)
from rangeproc.report.residuals import rejected_points
from rangeproc.results import TrackEstimate

#: Edge colour of the hatched gaps between a target's separately estimated spans.
GAP_COLOR = "0.45"
#: Spans closer than this many median sample intervals are merged.
GAP_SAMPLES = 3.0
#: Horizontal resolution (cells across the time axis) of merged spans, ticks and n_sensors strip.
RESOLUTION = 3_000


def used_spans(t: np.ndarray, *, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """Merge ascending times into spans; a new span starts after a step longer than ``gap`` s.

    Returns (start (S,), end (S,)) in the units of t.
    """
    t = t[np.isfinite(t)]
    if t.size == 0:
        return np.zeros(0), np.zeros(0)
    brk = np.flatnonzero(np.diff(t) > gap)
    starts = t[np.concatenate([[0], brk + 1])]
    ends = t[np.concatenate([brk, [t.size - 1]])]
    return starts, ends


def _median_step(t: np.ndarray) -> float:
    dt = np.diff(t)
    dt = dt[dt > 0]
    return float(np.median(dt)) if dt.size else 0.0


def plot_coverage(views: Sequence[SensorView], tracks: Sequence[TrackEstimate],
                  t0: float, edits: pd.DataFrame | None = None) -> Figure:
    """Draw the coverage timeline (times relative to t0, s).

    Each sensor's row says its rows used and its rejected points, counted as the residual
    figure and the page count them (``residuals.rejected_points``: the gate's rejected
    components and ``edits`` rejections, a removed whole row once), and marks each."""
    tracks = [tr for tr in tracks if np.size(tr.time) > 0]
    nrow = len(views) + len(tracks)
    fig = new_figure(14.0, max(3.2, 1.7 + 0.42 * max(nrow, 1)))
    box = (0.11, 0.62 / fig.get_figheight(), 0.76, 1.0 - 1.42 / fig.get_figheight())
    ax = fig.add_axes(box)
    fig.suptitle("Coverage: used data spans per sensor, rejected points, sensors per target",
                 fontsize=12, fontweight="bold", y=1.0 - 0.12 / fig.get_figheight(), va="top")
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")
    all_t = [v.time for v in views] + [tr.time for tr in tracks]
    fin = [a[np.isfinite(a)] for a in all_t if np.size(a)]
    fin = [a for a in fin if a.size]
    lo = min(float(a.min()) for a in fin) - t0 if fin else 0.0
    hi = max(float(a.max()) for a in fin) - t0 if fin else 1.0
    span = max(hi - lo, 1e-9)
    cell = span / RESOLUTION
    labels = []
    trans = blended_transform_factory(ax.transAxes, ax.transData)
    for i, v in enumerate(views):
        y = nrow - 1 - i
        color = KIND_COLORS.get(v.kind, CYCLE[0])
        used = v.used
        tu = v.time[used] - t0
        gap = max(GAP_SAMPLES * _median_step(tu), cell)
        s, e = used_spans(tu, gap=gap)
        width = np.maximum(e - s, cell)
        ax.broken_barh(list(zip(s, width)), (y - 0.32, 0.64), facecolors=color, lw=0)
        rejected = rejected_points(v, edits)
        tr_rej = np.unique(rejected.time) - t0
        tr_rej = tr_rej[np.isfinite(tr_rej) & (tr_rej >= lo) & (tr_rej <= hi)]
        if tr_rej.size:
            # one tick per drawn pixel column: identical on the page to drawing every point
            cols = np.unique(np.round((tr_rej - lo) / cell))
            ax.plot(lo + cols * cell, np.full(cols.size, y + 0.0), ls="none", marker="|",
                    ms=11, mew=0.9, color=REJECT_COLOR, zorder=3)
        n = v.time.size
        ax.text(1.005, y, f"{int(used.sum()):,} rows used\n{rejected.n:,} points rejected"
                f"\n{s.size:,} spans", transform=trans, fontsize=7, va="center", ha="left",
                gid=f"counts {v.sensor_id}")
        labels.append(f"{v.sensor_id}\n({v.kind})" if n else f"{v.sensor_id}\n(no rows)")
    mappable = None
    n_max = max((int(np.nanmax(tr.n_sensors)) for tr in tracks if np.size(tr.n_sensors)),
                default=1)
    cmap, norm = n_sensors_colormap(n_max)
    edges = lo + cell * np.arange(RESOLUTION + 1)
    for k, tr in enumerate(tracks):
        y = len(tracks) - 1 - k
        tt = np.asarray(tr.time, dtype=float) - t0
        ns = n_sensors_running_max(tr.time, tr.n_sensors)
        step = _median_step(tt)
        if 0 < step < cell:  # dense epochs: the worst (minimum) n_sensors of each cell
            cells = binned_extreme(tt, ns, edges, "min")
        else:  # sparse epochs: each fills +-half a grid step
            cells = _epoch_cells(tt, ns, edges, step)
        mappable = ax.pcolormesh(edges, [y - 0.36, y + 0.36], np.ma.masked_invalid(cells)[None],
                                 cmap=cmap, norm=norm, shading="flat")
        gaps = [(a[1] - t0, b[0] - a[1]) for a, b in zip(tr.spans[:-1], tr.spans[1:])]
        if gaps:   # unobserved beyond the gap limit: separate spans, no output epochs
            ax.broken_barh(gaps, (y - 0.36, 0.72), facecolors="none", edgecolors=GAP_COLOR,
                           hatch="////", lw=0.6, zorder=2)
        cov = 100.0 * float(np.mean(np.asarray(tr.n_sensors) > 0)) if ns.size else 0.0
        note = f"{cov:.1f} % epochs\nwith data"
        if gaps:
            note += f", {len(tr.spans)} spans"
        ax.text(1.005, y, note, transform=trans, fontsize=7, va="center", ha="left")
        labels.append(f"{tr.target_id}\nn_sensors")
    if tracks:
        ax.axhline(len(tracks) - 0.5, color="0.3", lw=1.0)
    ax.set_yticks(np.arange(nrow)[::-1] if nrow else [])
    ax.set_yticklabels(labels, fontsize=8)
    ax.set_ylim(-0.6, max(nrow, 1) - 0.4)
    ax.set_xlim(lo - 0.01 * span, hi + 0.01 * span)
    time_axis(ax, t0)
    ax.grid(axis="y", visible=False)
    if mappable is not None:
        cax = fig.add_axes((0.955, box[1], 0.011, box[3]))
        cb = fig.colorbar(mappable, cax=cax, ticks=np.arange(0, n_max + 1))
        cb.set_label("n_sensors, max over 1 s (0 = coasting)", fontsize=8)
    kinds = list(dict.fromkeys(v.kind for v in views))
    handles = [Patch(fc=KIND_COLORS.get(k, CYCLE[0]), label=f"{k}: used data") for k in kinds]
    handles.append(Patch(fc=REJECT_COLOR, label="rejected point"))
    if any(len(tr.spans) > 1 for tr in tracks):
        handles.append(Patch(fc="none", ec=GAP_COLOR, hatch="////",
                             label="unobserved beyond the gap limit: no output"))
    fig.legend(handles=handles, loc="upper center", ncol=len(handles), frameon=False,
               bbox_to_anchor=(0.48, 1.0 - 0.42 / fig.get_figheight()), fontsize=8)
    if nrow == 0:
        ax.text(0.5, 0.5, "no data", transform=ax.transAxes, ha="center", va="center",
                fontsize=12, color="0.4")
    return fig


def _epoch_cells(tt: np.ndarray, ns: np.ndarray, edges: np.ndarray, step: float) -> np.ndarray:
    """n_sensors per cell when epochs are sparser than cells: each epoch fills +-step/2.

    Cells are filled from the nearest epoch within half a grid step (NaN beyond: a gap).
    """
    mid = 0.5 * (edges[:-1] + edges[1:])
    j = np.clip(np.searchsorted(tt, mid), 1, max(tt.size - 1, 1))
    if tt.size == 1:
        near = np.zeros(mid.size, dtype=np.int64)
    else:
        near = np.where(np.abs(mid - tt[j - 1]) <= np.abs(tt[j] - mid), j - 1, j)
    half = 0.5 * step if step > 0 else 0.5 * (edges[1] - edges[0])
    out = ns[near].astype(float)
    out[np.abs(mid - tt[near]) > max(half, 0.5 * (edges[1] - edges[0]))] = np.nan
    return out
