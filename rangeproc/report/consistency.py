"""``consistency.png``: per sensor, windowed mean NIS vs time against its chi-square 95 % band,
and the histogram of normalised residuals (residual / sigma) against N(0, 1).

The NIS of a row has as many degrees of freedom as the row has measured (non-NaN) components.
Used rows are cut into consecutive windows of W rows; the window's NIS sum is chi-square with
D = sum of the rows' dof, so its mean per row lies in [chi2.ppf(0.025, D), chi2.ppf(0.975, D)] / W
with 95 % probability when the noise model is right.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from rangeproc.quantiles import chi2_ppf, norm_pdf
from rangeproc.report.common import (
    CYCLE,
    KIND_COLORS,
    REJECT_COLOR,
    SensorView,
    break_gaps,
    log_axis,
    new_figure,
    t0_note,
    time_axis,
)

#: Windows per sensor aimed at (window length W = rows / this, clipped to the limits below).
TARGET_WINDOWS = 400
MIN_WINDOW, MAX_WINDOW = 10, 2_000
#: Histogram range of normalised residuals (in sigma) and bin count.
Z_MAX, Z_BINS = 5.0, 50


def window_nis(time: np.ndarray, nis: np.ndarray, dof: np.ndarray, window: int, *,
               gap: float | None = None) -> tuple[np.ndarray, ...]:
    """Mean NIS over consecutive windows of ``window`` rows and its chi-square 95 % band.

    time, nis, dof: (N,) of the rows to use (finite nis, dof > 0), time-ordered. gap: a time
    step longer than this (s) ends a window early, so no window spans a data gap.
    Returns (t_mid (B,), mean_nis (B,), expected (B,) = mean dof, lo (B,), hi (B,)).
    The last window of a stretch takes the remainder rows (fewer than ``2 * window``).
    """
    n = time.size
    if n == 0:
        e = np.zeros(0)
        return e, e, e, e, e
    seg_first = np.zeros(1, dtype=np.int64)
    if gap is not None:
        seg_first = np.concatenate([[0], np.flatnonzero(np.diff(time) > gap) + 1])
    seg = np.zeros(n, dtype=np.int64)
    seg[seg_first[1:]] = 1
    seg = np.cumsum(seg)
    seg_len = np.diff(np.append(seg_first, n))
    pos = np.arange(n) - seg_first[seg]
    win = np.minimum(pos // window, np.maximum(seg_len[seg] // window - 1, 0))
    starts = np.flatnonzero(np.concatenate([[True], (np.diff(seg) != 0) | (np.diff(win) != 0)]))
    counts = np.diff(np.append(starts, n)).astype(float)
    s_nis = np.add.reduceat(nis, starts)
    s_dof = np.add.reduceat(dof.astype(float), starts)
    t_mid = 0.5 * (time[starts] + time[np.append(starts[1:], n) - 1])
    lo = chi2_ppf(0.025, s_dof) / counts
    hi = chi2_ppf(0.975, s_dof) / counts
    return t_mid, s_nis / counts, s_dof / counts, lo, hi


def plot_consistency(views: Sequence[SensorView], t0: float) -> Figure:
    """Draw the consistency figure: one row per sensor (times relative to t0, s)."""
    nrow = max(len(views), 1)
    fig = new_figure(14.0, max(3.8, 1.45 + 1.8 * nrow))
    height = fig.get_figheight()
    top = 1.0 - 1.05 / height
    gs = fig.add_gridspec(nrow, 2, width_ratios=(3.2, 1.0), left=0.07, right=0.985, top=top,
                          bottom=0.6 / height, wspace=0.12, hspace=0.38)
    fig.suptitle("Consistency: windowed mean NIS vs chi-square 95 % band, and normalised "
                 "residuals vs N(0,1)  (used rows only)", fontsize=12, fontweight="bold",
                 y=1.0 - 0.12 / fig.get_figheight(), va="top")
    fig.text(0.995, 0.005, t0_note(t0), ha="right", va="bottom", fontsize=7, color="0.35")
    _legend(fig, top + 0.28 / height)
    ax_t0: Axes | None = None
    for i, v in enumerate(views):
        ax_t = fig.add_subplot(gs[i, 0], sharex=ax_t0)
        ax_t0 = ax_t0 or ax_t
        ax_h = fig.add_subplot(gs[i, 1])
        _nis_panel(ax_t, v, t0)
        _hist_panel(ax_h, v)
        if i < len(views) - 1:
            ax_t.tick_params(labelbottom=False)
            ax_h.tick_params(labelbottom=False)
        else:
            time_axis(ax_t, t0)
            ax_h.set_xlabel("residual / σ")
    if not views:
        ax = fig.add_subplot(gs[0, :])
        ax.text(0.5, 0.5, "no sensor residuals", transform=ax.transAxes, ha="center",
                va="center", fontsize=12, color="0.4")
        ax.set_axis_off()
    return fig


def _nis_panel(ax: Axes, v: SensorView, t0: float) -> None:
    dof = np.isfinite(v.residual).sum(axis=1)
    ok = ~v.rejected & np.isfinite(v.nis) & (dof > 0) & np.isfinite(v.time)
    color = KIND_COLORS.get(v.kind, CYCLE[0])
    ax.set_ylabel(f"{v.sensor_id}\nmean NIS", fontsize=8.5)
    n = int(ok.sum())
    if n == 0:
        ax.text(0.5, 0.5, f"{v.sensor_id}: no NIS values", transform=ax.transAxes,
                ha="center", va="center", color="0.4")
        ax.set_yticks([])
        return
    w = int(np.clip(n // TARGET_WINDOWS, MIN_WINDOW, MAX_WINDOW))
    t_ok = v.time[ok]
    steps = np.diff(t_ok)
    steps = steps[steps > 0]
    # a data gap longer than a window's duration ends the window
    gap = w * float(np.median(steps)) if steps.size else None
    t_mid, mean, expect, lo, hi = window_nis(t_ok, v.nis[ok], dof[ok], w, gap=gap)
    outside = (mean < lo) | (mean > hi)
    xg, band = break_gaps(t_mid - t0, np.column_stack([lo, hi, expect, mean]))
    ax.fill_between(xg, band[:, 0], band[:, 1], color="0.82", lw=0, step="mid")
    ax.step(xg, band[:, 2], where="mid", color="0.3", lw=0.8, ls="--")
    ax.plot(xg, band[:, 3], "-", color=color, lw=1.0, marker="." if xg.size < 60 else None,
            ms=4)
    ax.plot(t_mid[outside] - t0, mean[outside], ls="none", marker="o", ms=2.8,
            color=REJECT_COLOR, zorder=3)
    pos = np.concatenate([mean[mean > 0], lo[lo > 0], hi])
    pos = pos[np.isfinite(pos)]
    if pos.size:
        log_axis(ax)
        # at least a factor 2 either side of the expected value: mis-scaled sigmas stand out
        ax.set_ylim(min(float(pos.min()) / 1.3, float(np.min(expect)) / 2.0),
                    max(float(pos.max()) * 1.3, float(np.max(expect)) * 2.0))
    anees = float(v.nis[ok].sum() / dof[ok].sum())
    frac = 100.0 * float(outside.mean())
    ax.set_title(f"{v.sensor_id} ({v.kind}):  NIS/dof overall {anees:.3g}   window {w} rows   "
                 f"{frac:.0f} % of {mean.size:,} windows outside the 95 % band", loc="left",
                 fontsize=8.5, pad=3)


def _hist_panel(ax: Axes, v: SensorView) -> None:
    edges = np.linspace(-Z_MAX, Z_MAX, Z_BINS + 1)
    width = edges[1] - edges[0]
    used_comp = v.used_comp
    zz = np.linspace(-Z_MAX, Z_MAX, 201)
    ax.plot(zz, norm_pdf(zz), color="k", lw=1.2, ls="--", label="N(0,1)")
    any_drawn = False
    for j, comp in enumerate(v.components):
        with np.errstate(divide="ignore", invalid="ignore"):
            z = v.residual[used_comp[:, j], j] / v.sigma[used_comp[:, j], j]
        z = z[np.isfinite(z)]
        if z.size == 0:
            continue
        counts, _ = np.histogram(z, bins=edges)
        dens = counts / (z.size * width)
        rms = float(np.sqrt(np.mean(z**2)))
        ax.stairs(dens, edges, color=CYCLE[j % len(CYCLE)], lw=1.1, label=f"{comp} rms {rms:.2f}")
        any_drawn = True
    ax.set_xlim(-Z_MAX, Z_MAX)
    ax.set_yticks([])
    ax.set_title(f"{v.sensor_id}: residual / σ, used", loc="left", fontsize=8.5, pad=3)
    if any_drawn:
        ax.legend(loc="upper left", fontsize=6.5, handlelength=1.2, framealpha=0.8,
                  borderaxespad=0.2)
    else:
        ax.text(0.5, 0.5, "no used residuals", transform=ax.transAxes, ha="center",
                va="center", color="0.4")


def _legend(fig: Figure, y: float) -> None:
    handles = [Patch(fc="0.82", label="chi-square 95 % band of the window mean"),
               Line2D([], [], color="0.3", ls="--", lw=0.8, label="expected = mean dof"),
               Line2D([], [], color="0.2", lw=1.0, label="mean NIS of the window"),
               Line2D([], [], ls="none", marker="o", ms=4, color=REJECT_COLOR,
                      label="window outside band"),
               Line2D([], [], color="k", ls="--", lw=1.2, label="N(0,1) density"),
               Line2D([], [], color=CYCLE[0], lw=1.1, label="histogram per component")]
    fig.legend(handles=handles, loc="center", bbox_to_anchor=(0.5, y), ncol=len(handles),
               frameon=False, fontsize=8, columnspacing=1.4)
