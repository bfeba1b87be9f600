"""``residuals_<sensor>.png``: post-fit residuals per measured component vs time.

Used points are small dots (coloured per MISTRAM station / target when there are several),
rejected points red crosses, the +-3 sigma envelope of the estimator's noise a shaded band.
The y-range is chosen from the used residuals (robust spread), so one wild point cannot squash
the plot; points beyond it are drawn clipped at the edge as triangles.

Every rejected point is drawn (:func:`rejected_points`): the gate's, from the residual rows,
and those removed before estimation, from ``edits.parquet``'s table with their residual
against the smoothed track; one with no residual (a whole row, a GPS latitude, a row removed
with its time stamp) or a time off the axis is a red diamond on the panel's top edge.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rangeproc.editing.robust import robust_spread
from rangeproc.report.common import (
    CYCLE,
    REJECT_COLOR,
    SensorView,
    binned_extreme,
    decimate_indices,
    display_unit,
    new_figure,
    t0_note,
    time_axis,
)

#: Half-height of the y-range in robust spreads (1.4826 MAD) of the used residuals.
SPREAD_FACTOR = 6.0
#: Time bins of the drawn +-3 sigma envelope (per-bin maximum).
ENVELOPE_BINS = 800
#: A step between samples longer than this many median intervals is a gap in the band.
GAP_SAMPLES = 3.0
_BAND_COLOR = "#9ecae1"
_EDGE = 0.97  # clipped points sit at this fraction of the half-height
#: Panel of an edited GPS file column (``edits.parquet``) among the model's components.
_PANEL_OF = {"lat": "n", "lon": "e", "height": "u"}


@dataclass(frozen=True, slots=True)
class RejectedPoints:
    """The rejected points one residual figure draws.

    n: rejections (a gate-rejected component or an ``edits.parquet`` row of action
    ``rejected``; a removed whole row is one, drawn on every measured panel);
    time: (K,) s range time scale; panel: (K,) int64 index into the view's components;
    residual: (K,) SI (NaN where there is none); reason: (K,) str.
    """

    n: int
    time: np.ndarray
    panel: np.ndarray
    residual: np.ndarray
    reason: np.ndarray


def rejected_points(view: SensorView, edits: pd.DataFrame | None = None) -> RejectedPoints:
    """Every rejected point of ``view``'s sensor: the gate's from the view, the others from
    ``edits`` (the ``edits.parquet`` table; its ``gate`` rows are the view's). An edited
    column the view has no panel for is drawn on the first measured panel."""
    r, c = np.nonzero(view.rejected_comp)
    time, panel, res = [view.time[r]], [c.astype(np.int64)], [view.residual[r, c]]
    reason = [np.full(r.size, "gate", dtype=object)]
    n = int(r.size)
    if edits is not None and len(edits):
        mine = edits[(edits["sensor"] == view.sensor_id) & (edits["action"] == "rejected")
                     & (edits["reason"] != "gate")]
        measured = [j for j in range(len(view.components))
                    if np.isfinite(view.residual[:, j]).any()] or [0]
        k, j = _panels(mine["component"].to_numpy(dtype=object), view.components, measured)
        time.append(mine["time"].to_numpy(dtype=float)[k])
        panel.append(j)
        res.append(mine["residual"].to_numpy(dtype=float)[k])
        reason.append(mine["reason"].to_numpy(dtype=object)[k])
        n += len(mine)
    return RejectedPoints(n, np.concatenate(time), np.concatenate(panel),
                          np.concatenate(res).astype(float), np.concatenate(reason))


def _panels(components: np.ndarray, names: tuple[str, ...], measured: list[int]
            ) -> tuple[np.ndarray, np.ndarray]:
    """(index into ``components``, panel) of each point the edited components are drawn
    as: on its own panel (GPS latitude, longitude, height on n, e, u), a whole row (``*``)
    on every measured one, any other on the first measured one."""
    index = {name: j for j, name in enumerate(names)}
    index.update({col: index[name] for col, name in _PANEL_OF.items() if name in index})
    own = pd.Series(components, dtype=object).map(index).fillna(measured[0])
    whole = components == "*"
    count = np.where(whole, len(measured), 1)
    k = np.repeat(np.arange(components.size), count)
    j = np.repeat(own.to_numpy(dtype=np.int64), count)
    at_whole = whole[k]
    j[at_whole] = np.tile(np.asarray(measured, dtype=np.int64), int(whole.sum()))
    return k, j


def plot_residuals(view: SensorView, t0: float, rejected: RejectedPoints | None = None
                   ) -> Figure:
    """Draw the residual figure of one sensor (times relative to t0, s); ``rejected``: its
    rejected points (default: the gate's, :func:`rejected_points`)."""
    rejected = rejected_points(view) if rejected is None else rejected
    finite = np.isfinite(view.residual)
    measured = [j for j in range(len(view.components)) if finite[:, j].any()]
    missing = [c for j, c in enumerate(view.components) if j not in measured]
    npan = max(len(measured), 1)
    fig = new_figure(13.0, max(3.4, 1.45 + 2.2 * npan))
    height = fig.get_figheight()
    top = 1.0 - 1.3 / height
    axes = fig.subplots(npan, 1, sharex=True, squeeze=False)[:, 0]
    fig.subplots_adjust(left=0.085, right=0.975, top=top, bottom=0.6 / height,
                        hspace=0.28)
    used = view.used
    n = view.time.size
    x = view.time - t0
    rms_parts = []
    for ax, j in zip(axes, measured):
        scale, unit = display_unit(view.units[j])
        r = view.residual[:, j] * scale
        s3 = 3.0 * view.sigma[:, j] * scale
        mine = rejected.panel == j
        rms = _draw_component(ax, view, x, r, s3, view.used_comp[:, j],
                              (rejected.time[mine] - t0, rejected.residual[mine] * scale), unit)
        ax.set_ylabel(f"{view.components[j]} [{unit}]")
        rms_parts.append(f"{view.components[j]} {_fmt(rms)} {unit}")
    if not measured:
        axes[0].text(0.5, 0.5, "no measurements" if n == 0 else "no finite residuals",
                     transform=axes[0].transAxes, ha="center", va="center", fontsize=12,
                     color="0.4")
        axes[0].set_yticks([])
    time_axis(axes[-1], t0)
    targets = ", ".join(view.targets)
    n_used, n_rej = int(used.sum()), rejected.n
    n_points = int(finite.sum()) + n_rej - int(view.rejected_comp.sum())
    pct = 100.0 * n_rej / n_points if n_points else 0.0
    fig.suptitle(f"Residuals (measured - smoothed): {view.sensor_id}  ({view.kind}, target "
                 f"{targets})", fontsize=12, fontweight="bold", y=1.0 - 0.12 / fig.get_figheight(),
                 va="top")
    line2 = f"used {n_used:,} rows   rejected {n_rej:,} points ({pct:.2f} %)"
    if rms_parts:
        line2 += "   |   RMS of used: " + ",  ".join(rms_parts)
    if missing:
        line2 += "   |   not measured: " + ", ".join(missing)
    fig.text(0.5, 1.0 - 0.45 / fig.get_figheight(), line2, ha="center", va="top", fontsize=9)
    _legend(fig, view, used, rejected, top)
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")
    return fig


def _fmt(v: float) -> str:
    if not np.isfinite(v):
        return "n/a"
    return f"{v:.3g}"


def _limit(r_used: np.ndarray, r_rej: np.ndarray, s3_used: np.ndarray) -> float:
    """Symmetric half-height of the y-range (display units) from the used residuals.

    |median| + 6 robust spreads, widened to show the +-3 sigma band (99th percentile, so
    noise bursts fit) unless that band is more than 5x wider than the residuals.
    """
    base = r_used if r_used.size else r_rej
    spread = robust_spread(base)
    centre = float(np.median(base)) if base.size else 0.0
    half = abs(centre) + SPREAD_FACTOR * spread
    s3 = s3_used[np.isfinite(s3_used) & (s3_used > 0)]
    if s3.size:
        band = 1.1 * float(np.percentile(s3, 99.0))  # the band, bursts included, fits
        cap = abs(centre) + 5.0 * SPREAD_FACTOR * spread if spread > 0 else band
        half = max(half, min(band, cap))
    if not (np.isfinite(half) and half > 0):
        mag = np.abs(base[np.isfinite(base)]) if base.size else np.zeros(0)
        half = 1.2 * float(mag.max()) if mag.size and mag.max() > 0 else 1.0
    return half


def _draw_component(ax: Axes, view: SensorView, x: np.ndarray, r: np.ndarray, s3: np.ndarray,
                    used: np.ndarray, rejected: tuple[np.ndarray, np.ndarray],
                    unit: str) -> float:
    """One panel; ``rejected``: (time since t0 s, residual in display units, NaN where none)
    of its rejected points. Returns the RMS of the used residuals (display units)."""
    fin = np.isfinite(r)
    u_ok = used & fin
    ru = r[u_ok]
    half = _limit(ru, rejected[1][np.isfinite(rejected[1])], s3[u_ok])
    _envelope(ax, x, s3, fin)
    ax.axhline(0.0, color="0.3", lw=0.7, zorder=1.5)
    # used points: decimated for drawing, coloured per group
    idx = decimate_indices(np.where(u_ok, r, np.nan))
    yy = np.clip(r[idx], -half * _EDGE, half * _EDGE)
    off = np.abs(r[idx]) > half * _EDGE
    dot = 4.0 if idx.size < 300 else 2.4 if idx.size < 3_000 else 1.6
    for g in np.unique(view.group[idx]) if idx.size else []:
        sel = view.group[idx] == g
        col = CYCLE[int(g) % len(CYCLE)] if len(view.group_names) > 1 else CYCLE[0]
        ax.plot(x[idx][sel & ~off], yy[sel & ~off], ls="none", marker="o", ms=dot, mew=0,
                color=col, zorder=2, rasterized=False)
        _clipped(ax, x[idx][sel & off], r[idx][sel & off], half, col, ms=3.5)
    # rejected points: every one is drawn
    n_off = _draw_rejected(ax, x, *rejected, half)
    ax.set_ylim(-half, half)
    rms = float(np.sqrt(np.mean(ru**2))) if ru.size else float("nan")
    mean = float(np.mean(ru)) if ru.size else float("nan")
    sig = float(np.nanmedian(s3[u_ok]) / 3.0) if u_ok.any() and np.isfinite(s3[u_ok]).any() \
        else float("nan")
    ax.set_title(f"used {int(u_ok.sum()):,}   mean {mean:+.3g}   RMS {_fmt(rms)}   "
                 f"median σ {_fmt(sig)} {unit}", loc="left", fontsize=8, pad=3)
    n_rej = int(rejected[0].size)
    if n_rej:
        ax.set_title(f"rejected {n_rej:,}" + (f" ({n_off:,} off-scale ▲▼)" if n_off else ""),
                     loc="right", fontsize=8, pad=3, color=REJECT_COLOR)
    return rms


def _draw_rejected(ax: Axes, x: np.ndarray, rx: np.ndarray, ry: np.ndarray,
                   half: float) -> int:
    """Rejected points at times ``rx`` (s since t0) with residuals ``ry`` (display units)
    on a panel of half-height ``half`` whose used rows are at ``x``: crosses, triangles at
    the edge beyond it, diamonds on the top edge where there is no residual or the time is
    off the data's span. Returns how many are off-scale (triangles and diamonds)."""
    fin_x = x[np.isfinite(x)]
    lo, hi = (float(fin_x.min()), float(fin_x.max())) if fin_x.size else (0.0, 0.0)
    fin = np.isfinite(ry) & np.isfinite(rx) & (rx >= lo) & (rx <= hi)
    inside = fin & (np.abs(ry) <= half * _EDGE)
    ms = reject_marker_size(rx.size)
    ax.plot(rx[inside], ry[inside], ls="none", marker="x", ms=ms, mew=0.25 * ms,
            color=REJECT_COLOR, alpha=0.8 if rx.size > 1_000 else 1.0, zorder=3)
    _clipped(ax, rx[fin & ~inside], ry[fin & ~inside], half, REJECT_COLOR, ms=ms + 1.0)
    if (~fin).any():
        ax.plot(np.clip(np.nan_to_num(rx[~fin], nan=lo), lo, hi),
                np.full(int((~fin).sum()), half * _EDGE), ls="none", marker="D", ms=ms,
                color=REJECT_COLOR, mec="k", mew=0.4, zorder=3.5, clip_on=False)
    return int((~inside).sum())


def reject_marker_size(n: int) -> float:
    """Marker size (points) of rejected crosses: 4.5 up to 300 points, shrinking to 1.8 at 1e5,
    so that thousands of wild points mark where they are without hiding the used data."""
    if n <= 300:
        return 4.5
    return float(max(1.8, 4.5 - 1.1 * np.log10(n / 300.0)))


def _envelope(ax: Axes, x: np.ndarray, s3: np.ndarray, fin: np.ndarray) -> None:
    """+-3 sigma band: per-time-bin maximum of 3 sigma; open only across real data gaps.

    Bins are at least two median sample intervals wide; an empty bin inside a data step
    shorter than ``GAP_SAMPLES`` intervals takes the preceding bin's value.
    """
    ok = fin & np.isfinite(s3) & np.isfinite(x)
    if not ok.any():
        return
    xs, vs = x[ok], s3[ok]
    lo, hi = float(xs[0]), float(xs[-1])
    if hi <= lo:
        lo, hi = lo - 0.5, hi + 0.5
    dt = np.diff(xs)
    dt_med = float(np.median(dt[dt > 0])) if (dt > 0).any() else 0.0
    nbin = ENVELOPE_BINS if dt_med <= 0 else int(np.clip((hi - lo) / (2 * dt_med), 1,
                                                          ENVELOPE_BINS))
    edges = np.linspace(lo, hi, nbin + 1)
    band = binned_extreme(xs, vs, edges, "max")
    centres = 0.5 * (edges[:-1] + edges[1:])
    empty = ~np.isfinite(band)
    if empty.any() and dt_med > 0:
        k = np.clip(np.searchsorted(xs, centres), 1, xs.size - 1)
        short = (xs[k] - xs[k - 1]) <= GAP_SAMPLES * dt_med
        prev = np.maximum.accumulate(np.where(~empty, np.arange(nbin), -1))
        fill = empty & short & (prev >= 0)
        band[fill] = band[prev[fill]]
    # each bin drawn flat from its left to its right edge; NaN bins leave a gap
    xx = np.column_stack([edges[:-1], edges[1:]]).ravel()
    yy = np.repeat(band, 2)
    ax.fill_between(xx, -yy, yy, color=_BAND_COLOR, alpha=0.45, lw=0, zorder=1)
    for sgn in (-1.0, 1.0):
        ax.plot(xx, sgn * yy, color="#2171b5", lw=0.9, zorder=3.6)


def _clipped(ax: Axes, x: np.ndarray, y: np.ndarray, half: float, color: str,
             ms: float) -> None:
    """Points beyond +-half drawn at the edge: triangles pointing the way they went off."""
    for sgn, mk in ((1.0, "^"), (-1.0, "v")):
        sel = np.sign(y) == sgn
        if sel.any():
            ax.plot(x[sel], np.full(int(sel.sum()), sgn * half * _EDGE), ls="none", marker=mk,
                    ms=ms, color=color, mec="k" if sel.sum() < 300 else color, mew=0.4,
                    zorder=3.5, clip_on=False)


def _legend(fig: Figure, view: SensorView, used: np.ndarray, rejected: RejectedPoints,
            top: float) -> None:
    handles: list = []
    if len(view.group_names) > 1:
        for g, name in enumerate(view.group_names):
            cnt = int((used & (view.group == g)).sum())
            handles.append(Line2D([], [], ls="none", marker="o", ms=5, mew=0,
                                  color=CYCLE[g % len(CYCLE)], label=f"used {name} ({cnt:,})"))
    else:
        handles.append(Line2D([], [], ls="none", marker="o", ms=5, mew=0, color=CYCLE[0],
                              label=f"used ({int(used.sum()):,})"))
    handles.append(Line2D([], [], ls="none", marker="x", ms=6, mew=1.2, color=REJECT_COLOR,
                          label=f"rejected ({rejected.n:,})"))
    if not np.isfinite(rejected.residual).all():
        handles.append(Line2D([], [], ls="none", marker="D", ms=5, color=REJECT_COLOR, mec="k",
                              mew=0.4, label="no residual (top edge)"))
    handles.append(Line2D([], [], ls="none", marker="^", ms=6, color="0.5", mec="k", mew=0.4,
                          label="off-scale (clipped at edge)"))
    handles.append(Patch(fc=_BAND_COLOR, ec="#3182bd", alpha=0.8,
                         label="±3σ (noise used by the estimator)"))
    fig.legend(handles=handles, loc="lower center",
               bbox_to_anchor=(0.5, top + 0.2 / fig.get_figheight()), ncol=len(handles),
               frameon=False, fontsize=8, handletextpad=0.3, columnspacing=1.5)
