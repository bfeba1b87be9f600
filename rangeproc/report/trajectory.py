"""``trajectory.png``: plan view, altitude, speed and 1-sigma position uncertainty vs time."""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from rangeproc.report.common import (
    CYCLE,
    ClockFormatter,
    ClockLocator,
    break_gaps,
    day_seconds,
    log_axis,
    n_sensors_colormap,
    n_sensors_running_max,
    new_figure,
    stride_indices,
    t0_note,
    time_axis,
)
from rangeproc.report.mapview import Label, place_labels
from rangeproc.results import TrackEstimate

#: Most epochs per target drawn in a line (tracks are decimated by stride for drawing).
MAX_TRACK_POINTS = 20_000
_AXIS_STYLES = (("e", "-", "#1f77b4"), ("n", "--", "#ff7f0e"), ("u", ":", "#2ca02c"))
#: Title and label of the altitude panel (rangeproc has no geoid model, so no MSL height).
HEIGHT_TITLE = "height above the WGS-84 ellipsoid"
HEIGHT_LABEL = "ellipsoidal height [m]"


def height_series(track: TrackEstimate, idx: np.ndarray | slice = slice(None)
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(time (K,) s, height (K,) m above the WGS-84 ellipsoid) of ``track``'s epochs ``idx``,
    with NaN rows across data gaps (``break_gaps``): the altitude panel's series. The height is
    the track's geodetic height, as in ``fused.parquet``, not the range ENU frame's up (which
    falls away from a constant-height flight with the Earth's curvature, ~16 m at 14 km)."""
    t = np.asarray(track.time, dtype=float)[idx]
    h = np.asarray(track.height, dtype=float)[idx]
    tg, hg = break_gaps(t, h)
    return tg, hg



def plot_trajectory(tracks: Sequence[TrackEstimate], sites: Mapping[str, np.ndarray] | None,
                    t0: float) -> Figure:
    """Draw the trajectory figure.

    tracks: smoothed trajectories (range ENU, m); sites: id -> (3,) fixed ENU position (m) or
    (N, 3) platform track (m); t0: time origin (s) of the time axes.
    """
    fig = new_figure(15.0, 9.0)
    gs = fig.add_gridspec(3, 2, width_ratios=(1.12, 1.0), left=0.06, right=0.97, top=0.92,
                          bottom=0.07, wspace=0.16, hspace=0.12)
    ax_map = fig.add_subplot(gs[:, 0])
    ax_up = fig.add_subplot(gs[0, 1])
    ax_spd = fig.add_subplot(gs[1, 1], sharex=ax_up)
    ax_sig = fig.add_subplot(gs[2, 1], sharex=ax_up)
    tracks = [tr for tr in tracks if np.size(tr.time) > 0]
    single = len(tracks) == 1
    fig.suptitle(_title(tracks), fontsize=12, fontweight="bold")
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")

    site_labels = _draw_sites(ax_map, sites or {})
    for k, tr in enumerate(tracks):
        color = CYCLE[k % len(CYCLE)]
        idx = stride_indices(tr.time.size, MAX_TRACK_POINTS)
        t = np.asarray(tr.time, dtype=float)[idx]
        x = np.asarray(tr.x, dtype=float)[idx]
        _draw_plan(fig, ax_map, tr, idx, color, single, t0)
        tg, v = break_gaps(t, x[:, 3:6])
        spd = np.linalg.norm(v, axis=1)
        marker = "o" if t.size == 1 else None
        lab = tr.target_id
        th, height = height_series(tr, idx)
        ax_up.plot(th - t0, height, color=color, lw=1.2, marker=marker, label=lab)
        ax_spd.plot(tg - t0, spd, color=color, lw=1.2, marker=marker, label=lab)
        with np.errstate(invalid="ignore"):
            sig = np.sqrt(np.diagonal(np.asarray(tr.P, dtype=float)[idx], axis1=1, axis2=2)[:, :3])
        sig = np.where(sig > 0, sig, np.nan)
        _, sig = break_gaps(t, sig)
        for j, (name, ls, c) in enumerate(_AXIS_STYLES):
            ax_sig.plot(tg - t0, sig[:, j], ls=ls if not single else "-",
                        color=c if single else color, lw=1.1, marker=marker,
                        label=f"σ_{name}" if single else f"{tr.target_id} σ_{name}")
        if single and tr.achievable is not None:        # what the instruments allow
            _, ach = break_gaps(t, np.asarray(tr.achievable, dtype=float)[idx])
            for j, (name, _, c) in enumerate(_AXIS_STYLES):
                ax_sig.plot(tg - t0, ach[:, j], ls=(0, (1, 1.5)), color=c, lw=1.0, alpha=0.9,
                            label=f"achievable σ_{name}")

    _finish_map(ax_map, tracks, sites)
    place_labels(ax_map, site_labels)
    ax_up.set_ylabel(HEIGHT_LABEL)
    ax_up.set_title(HEIGHT_TITLE)
    ax_spd.set_ylabel("speed |v| [m/s]")
    ax_spd.set_title("speed")
    ax_sig.set_ylabel("1-σ position [m]")
    ax_sig.set_title("1-σ position uncertainty per axis (e, n, u)", loc="left")
    time_axis(ax_sig, t0)
    if any(np.isfinite(line.get_ydata()).any() and (np.asarray(line.get_ydata()) > 0).any()
           for line in ax_sig.get_lines()):
        log_axis(ax_sig)
    for ax in (ax_up, ax_spd):
        ax.tick_params(labelbottom=False)
    if len(tracks) > 1:
        ax_up.legend(loc="best", ncol=min(len(tracks), 4))
    if tracks:
        # single target: colour = axis; several: colour = target (as above), style = axis
        handles = [Line2D([], [], color=c if single else "0.2", ls="-" if single else ls,
                          lw=1.1, label=f"σ_{name}") for name, ls, c in _AXIS_STYLES]

        if single and tracks[0].achievable is not None:    # inside: the axes' own note
            ax_sig.add_artist(ax_sig.legend(
                handles=[Line2D([], [], color="0.2", ls=(0, (1, 1.5)), lw=1.0,
                                label="achievable: what the instruments allow")],
                loc="upper right", fontsize=7, frameon=False))
        ax_sig.legend(handles=handles, loc="lower right", bbox_to_anchor=(1.0, 1.0), ncol=3,
                      fontsize=7.5, frameon=False, borderaxespad=0.1, handlelength=2.2,
                      columnspacing=1.2)
    else:
        for ax in (ax_up, ax_spd, ax_sig):
            ax.text(0.5, 0.5, "no track", transform=ax.transAxes, ha="center", va="center",
                    color="0.4")
    return fig


def _title(tracks: Sequence[TrackEstimate]) -> str:
    if not tracks:
        return "Trajectory: no track estimated"
    spans = ", ".join(f"{tr.target_id} ({tr.time.size:,} epochs, "
                      f"{float(tr.time[-1] - tr.time[0]):.1f} s)" for tr in tracks[:6])
    more = f" +{len(tracks) - 6} more" if len(tracks) > 6 else ""
    return f"Trajectory: {spans}{more}"


def _draw_plan(fig: Figure, ax: Axes, tr: TrackEstimate, idx: np.ndarray, color: str,
               single: bool, t0: float) -> None:
    """Plan view of one track (km); coloured by n_sensors when it is the only track."""
    t = np.asarray(tr.time, dtype=float)[idx]
    e = np.asarray(tr.x, dtype=float)[idx, 0] / 1e3
    n = np.asarray(tr.x, dtype=float)[idx, 1] / 1e3
    if single and t.size > 1:
        ns = n_sensors_running_max(tr.time, tr.n_sensors)[idx]
        cmap, norm = n_sensors_colormap(int(np.nanmax(ns)) if np.isfinite(ns).any() else 1)
        pts = np.column_stack([e, n])
        segs = np.stack([pts[:-1], pts[1:]], axis=1)
        seg_ns = np.fmin(ns[:-1], ns[1:])
        ok = np.isfinite(segs).all(axis=(1, 2)) & _not_gap(t)
        lc = LineCollection(segs[ok], cmap=cmap, norm=norm, linewidths=2.0, zorder=3)
        lc.set_array(seg_ns[ok])
        ax.add_collection(lc)
        cb = fig.colorbar(lc, ax=ax, shrink=0.6, pad=0.02, aspect=30,
                          ticks=np.arange(0, norm.boundaries[-1] + 0.5))
        cb.set_label("n_sensors, max over 1 s (0 = no data, coasting)")
        _time_marks(ax, t, e, n, t0)
    else:
        tg, eg, ng = break_gaps(t, e, n)
        ax.plot(eg, ng, color=color, lw=1.6, zorder=3, label=tr.target_id)
    ax.plot(e[:1], n[:1], "o", ms=8, mfc="white", mec=color if not single else "k", mew=2,
            zorder=5, label="start" if single else None)
    ax.plot(e[-1:], n[-1:], "s", ms=7, color=color if not single else "k", zorder=5,
            label="end" if single else None)
    if not single:
        ax.annotate(tr.target_id, (e[0], n[0]), xytext=(6, 6), textcoords="offset points",
                    color=color, fontsize=8, fontweight="bold")


def _not_gap(t: np.ndarray, factor: float = 3.0) -> np.ndarray:
    """(K-1,) bool: the step t[i] -> t[i+1] is no longer than ``factor`` x the median step."""
    dt = np.diff(t)
    pos = dt[dt > 0]
    if pos.size == 0:
        return np.ones(dt.size, dtype=bool)
    return dt <= factor * np.median(pos)


def _time_marks(ax: Axes, t: np.ndarray, e: np.ndarray, n: np.ndarray, t0: float) -> None:
    """Small labelled ticks along the track at round times for map/time lookup: UTC clock
    times (hh:mm:ss) when ``t0`` carries a known calendar, else seconds since t0."""
    span = float(t[-1] - t[0])
    if not span > 0:
        return
    scale = getattr(t0, "scale", None)
    if scale is not None:
        base = scale.utc(t0)
        marks = ClockLocator(day_seconds(base), nbins=6).tick_values(t[0] - t0, t[-1] - t0)
        step = float(np.diff(marks).min()) if marks.size > 1 else span
        labels = ClockFormatter(base).format_ticks(marks)
    else:
        step = _nice_step(span / 6.0)
        marks = np.arange(np.ceil((t[0] - t0) / step) * step, t[-1] - t0, step)
        labels = [f"{m:g} s" for m in marks]
    keep = (marks > t[0] - t0 + 0.3 * step) & (marks < t[-1] - t0)
    marks, labels = marks[keep], [lab for lab, k in zip(labels, keep) if k]
    if marks.size == 0:
        return
    j = np.clip(np.searchsorted(t - t0, marks), 0, t.size - 1)
    ax.plot(e[j], n[j], "o", ms=3.5, color="k", zorder=4)
    for jj, label in zip(j, labels):
        ax.annotate(label, (e[jj], n[jj]), xytext=(4, -10), textcoords="offset points",
                    fontsize=7, color="0.2")


def _nice_step(x: float) -> float:
    """The 1-2-5 x 10^k number nearest above ``x``."""
    p = 10.0 ** np.floor(np.log10(x))
    for f in (1.0, 2.0, 5.0, 10.0):
        if f * p >= x:
            return f * p
    return 10.0 * p


def _draw_sites(ax: Axes, sites: Mapping[str, np.ndarray]) -> list[Label]:
    """Fixed sites as triangles; moving platforms as thin grey tracks (km). Returns their
    labels, for :func:`~rangeproc.report.mapview.place_labels` once the view is final (so
    that sensors sharing a platform get one label, and no label overprints another)."""
    labels: list[Label] = []
    for name, pos in sites.items():
        p = np.asarray(pos, dtype=float)
        if p.ndim == 1 and p.size >= 2:
            if not np.isfinite(p[:2]).all():
                continue
            ax.plot(p[0] / 1e3, p[1] / 1e3, "^", ms=8, color="k", mfc="#ffd700", zorder=6)
            labels.append(Label(p[0] / 1e3, p[1] / 1e3, name, color="k"))
        elif p.ndim == 2 and p.shape[0] > 0 and p.shape[1] >= 2:
            p = p[np.isfinite(p[:, :2]).all(axis=1)]
            if p.shape[0] == 0:
                continue
            p = p[stride_indices(p.shape[0], 5_000)]
            ax.plot(p[:, 0] / 1e3, p[:, 1] / 1e3, "-", lw=1.0, color="0.45", zorder=2)
            ax.plot(p[-1, 0] / 1e3, p[-1, 1] / 1e3, "D", ms=6, color="0.3", zorder=6)
            labels.append(Label(p[-1, 0] / 1e3, p[-1, 1] / 1e3, name, " (platform)"))
    return labels


def _finish_map(ax: Axes, tracks: Sequence[TrackEstimate],
                sites: Mapping[str, np.ndarray] | None) -> None:
    ax.set_xlabel("east [km]")
    ax.set_ylabel("north [km]")
    ax.set_title("plan view, range ENU frame (▲ fixed site, ◆ platform at end)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.margins(0.05)
    if not tracks:
        ax.text(0.5, 0.5, "no track estimated", transform=ax.transAxes, ha="center",
                va="center", color="0.4", fontsize=11)
    if len(tracks) == 1:
        ax.legend(loc="best")
    elif tracks:
        ax.legend(loc="best", title="target")
